// Flow depth at a point or along a line, as SPH water-level gauges measure it (DualSPHysics' GaugeSwl, the
// SPHERIC benchmarks' wave gauges): the free surface over a station is the highest height on its vertical
// where the kernel-interpolated fluid fraction
//   phi(z) = sum_j V_j W(x - x_j) + (the kernel's share under the floor),   V_j = m_j / rho_j,
// reaches wet_kernel_sum (0.5: where a half-space of fluid ends), and the depth is that height over the
// station's foot (the floor or bed under it). The floor's share is the fraction of the kernel below the
// horizontal plane through the foot: the ground under a flow is as full as the flow for this purpose, so a
// layer thinner than the kernel's reach (a debris sheet a few dp deep) still has its surface found, and a dry
// floor reads exactly 0 (phi = 0.5 on it). On a sloping bed the wedges between that plane and the bed above
// and below the foot nearly cancel. Stations are independent: each sample is one pass over the flow particles
// near the gauge (binned by plan cell) and a short vertical search per station.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "monitor_types.hpp"

namespace runout::monitor_detail {
namespace {

// fill[k] = the fraction of the kernel's integral below a plane k/n of the support under its centre (k = 0:
// one half). The kernel's marginal along the vertical is integrated numerically once per gauge.
template <int D>
std::vector<real> floor_fill_table(KernelKind kind, real h, int n) {
  return with_kernel<D>(kind, h, [n](auto kernel) {
    const real R = kernel.support();
    const int fine = 8 * n, quad = 400;
    // marginal(t) = integral of W over the plane (3D) or line (2D) at height t; 3D: 2 pi int_t^R W(r) r dr.
    auto marginal = [&](real t) {
      real sum = 0;
      if constexpr (D == 3) {
        const real dr = (R - t) / quad;
        for (int q = 0; q < quad; ++q) {
          const real r = t + (q + 0.5) * dr;
          sum += kernel.W(r) * r * dr;
        }
        return 2 * kPi * sum;
      } else {
        const real umax = std::sqrt(std::max(real(0), R * R - t * t)), du = umax / quad;
        for (int q = 0; q < quad; ++q) sum += kernel.W(std::hypot(t, (q + 0.5) * du)) * du;
        return 2 * sum;
      }
    };
    // Cumulative from the support's edge down to the centre (midpoint rule on `fine` cells).
    std::vector<real> tail(fine + 1, 0.0);
    const real dt = R / fine;
    for (int q = fine - 1; q >= 0; --q) tail[q] = tail[q + 1] + marginal((q + 0.5) * dt) * dt;
    std::vector<real> fill(n + 1);
    for (int k = 0; k <= n; ++k) fill[k] = 0.5 * tail[k * (fine / n)] / tail[0];  // normalised: exactly 1/2 at 0
    return fill;
  });
}

// A flow particle near a station: squared plan distance, height, volume.
struct ColumnParticle {
  real r2, z, volume;
};

// Flow particles near each station, found through plan cells of the kernel support.
template <int D>
std::vector<std::vector<ColumnParticle>> columns_near(const ParticleArrays<D>& f, const std::vector<Vec<D>>& feet,
                                                      real support) {
  constexpr int P = D - 1;  // plan axes
  Vec<D> lo = Vec<D>::Constant(std::numeric_limits<real>::infinity()), hi = -lo;
  for (const auto& x : feet) lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  auto cell_of = [&](const Vec<D>& p, int d) { return static_cast<int64_t>(std::floor((p[d] - lo[d]) / support)); };
  auto key_of = [](const std::array<int64_t, P>& c) {
    uint64_t k = 0;
    for (int d = 0; d < P; ++d) k = k * 2097143u + static_cast<uint64_t>(c[d] + 1048576);
    return k;
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells;
  for (size_t j = 0; j < f.size(); ++j) {
    const Vec<D> p = f.position(j);
    bool near = !Solver<D>::is_inlet_buffer(f.tag[j]);
    for (int d = 0; d < P; ++d) near = near && p[d] > lo[d] - support && p[d] < hi[d] + support;
    if (!near) continue;
    std::array<int64_t, P> c;
    for (int d = 0; d < P; ++d) c[d] = cell_of(p, d);
    cells[key_of(c)].push_back(static_cast<uint32_t>(j));
  }
  std::vector<std::vector<ColumnParticle>> columns(feet.size());
  const real support2 = support * support;
#pragma omp parallel for schedule(dynamic, 4)
  for (size_t k = 0; k < feet.size(); ++k) {
    std::array<int64_t, P> c;
    for (int d = 0; d < P; ++d) c[d] = cell_of(feet[k], d);
    int offsets = 1;
    for (int d = 0; d < P; ++d) offsets *= 3;
    for (int o = 0; o < offsets; ++o) {
      std::array<int64_t, P> n = c;
      for (int d = 0, rem = o; d < P; ++d, rem /= 3) n[d] += rem % 3 - 1;
      const auto it = cells.find(key_of(n));
      if (it == cells.end()) continue;
      for (uint32_t j : it->second) {
        real r2 = 0;
        for (int d = 0; d < P; ++d) r2 += (f.pos[d][j] - feet[k][d]) * (f.pos[d][j] - feet[k][d]);
        if (r2 < support2) columns[k].push_back({r2, f.pos[D - 1][j], f.mass[j] / f.rho[j]});
      }
    }
  }
  return columns;
}

// The highest height z >= floor on the station's vertical where phi(z) >= wet; `floor` when there is none
// (phi(floor) = 1/2 + the flow's share, so with wet = 1/2 a dry floor is its own surface). Steps down from
// above the highest particle by h/4 (phi varies on the scale of h) and bisects the step that crosses.
template <class Kernel>
real surface_height(const std::vector<ColumnParticle>& column, real floor, const Kernel& kernel,
                    const std::vector<real>& fill, real wet) {
  const real R = kernel.support(), n = static_cast<real>(fill.size() - 1);
  auto phi = [&](real z) {
    real sum = 0;
    for (const auto& c : column) sum += c.volume * kernel.W(std::sqrt(c.r2 + (z - c.z) * (z - c.z)));
    const real s = (z - floor) / R * n;  // the floor's share, linear between table entries
    if (s < n) {
      const int k = static_cast<int>(s);
      sum += fill[k] + (s - k) * (fill[k + 1] - fill[k]);
    }
    return sum;
  };
  real top = floor, low = std::numeric_limits<real>::infinity();
  for (const auto& c : column) top = std::max(top, c.z + R), low = std::min(low, c.z - R);
  const real step = 0.25 * kernel.h;
  real above = top;  // phi(above) < wet: nothing reaches it
  for (real z = top;;) {
    if (phi(z) >= wet) {
      real lo = z, hi = above;
      for (int q = 0; q < 40 && hi - lo > 1e-9 * R; ++q) {
        const real mid = 0.5 * (lo + hi);
        (phi(mid) >= wet ? lo : hi) = mid;
      }
      return lo;
    }
    if (z <= floor) return floor;
    above = z;
    z = std::max(floor, z - step);
    if (z < low && z > floor + R) z = floor + R;  // nothing between the flow and the floor's reach
  }
}

template <int D>
class DepthGauge final : public Monitor<D> {
 public:
  DepthGauge(const MonitorSpec& spec, const Solver<D>& s)
      : Monitor<D>(spec.name), along_(spec.probe_stations), wet_(spec.number("wet_kernel_sum")) {
    if (spec.probe_points.empty())
      throw std::invalid_argument("monitor '" + spec.name + "': a depth gauge needs a point or a line");
    if (!along_.empty() && along_.size() != spec.probe_points.size())
      throw std::invalid_argument("monitor '" + spec.name + "': one distance along the line per station");
    for (size_t k = 0; k < spec.probe_points.size(); ++k) feet_.push_back(probe_point<D>(spec, k));
    fill_ = floor_fill_table<D>(s.config().kernel, s.config().smoothing_length, 256);
  }

  std::vector<std::string> columns() const override {
    if (along_.empty()) return {"depth_m", "surface_m"};
    return {"depth_m", "surface_m", "station_m"};
  }

  // The deepest station: its depth, its surface height and where it is along the line.
  std::vector<real> sample(const Solver<D>& s) override {
    const auto& cfg = s.config();
    const auto near = columns_near(s.fluid(), feet_, 2.0 * cfg.smoothing_length);
    std::vector<real> surface(feet_.size());
    with_kernel<D>(cfg.kernel, cfg.smoothing_length, [&](auto kernel) {
#pragma omp parallel for schedule(dynamic, 1)
      for (size_t k = 0; k < feet_.size(); ++k)
        surface[k] = surface_height(near[k], feet_[k][D - 1], kernel, fill_, wet_);
    });
    size_t deepest = 0;
    for (size_t k = 1; k < feet_.size(); ++k)
      if (depth(surface, k) > depth(surface, deepest)) deepest = k;
    const real d = depth(surface, deepest), t = s.time();
    const real station = along_.empty() ? 0.0 : along_[deepest];
    if (d > max_ || max_time_ < 0) max_ = d, max_time_ = t, max_station_ = station;
    final_ = d;
    if (along_.empty()) return {d, surface[deepest]};
    return {d, surface[deepest], station};
  }

  std::vector<std::pair<std::string, real>> summary() const override {
    std::vector<std::pair<std::string, real>> out = {
        {"max_depth_m", max_}, {"time_of_max_depth_s", max_time_}, {"final_depth_m", final_}};
    if (!along_.empty()) out.emplace_back("station_of_max_depth_m", max_station_);
    return out;
  }

  void save_state(StateWriter& out) const override {
    out.label("depth_gauge:" + this->name());
    out.value(max_), out.value(max_time_), out.value(max_station_), out.value(final_);
  }

  void load_state(StateReader& in) override {
    in.expect("depth_gauge:" + this->name());
    in.value(max_), in.value(max_time_), in.value(max_station_), in.value(final_);
  }

 private:
  std::vector<Vec<D>> feet_;
  std::vector<real> along_, fill_;
  real wet_;
  real max_ = 0, max_time_ = -1, max_station_ = 0, final_ = 0;

  real depth(const std::vector<real>& surface, size_t k) const { return std::max(real(0), surface[k] - feet_[k][D - 1]); }
};

// Stations every `spacing` or closer along a polyline (the ends and every vertex included) and their
// distances along it.
void stations_along(const std::vector<std::array<real, 2>>& line, real spacing, std::vector<std::array<real, 2>>& at,
                    std::vector<real>& along) {
  real walked = 0;
  at.push_back(line.front());
  along.push_back(0.0);
  for (size_t k = 0; k + 1 < line.size(); ++k) {
    const real dx = line[k + 1][0] - line[k][0], dy = line[k + 1][1] - line[k][1], length = std::hypot(dx, dy);
    const long n = std::max(1L, static_cast<long>(std::ceil(length / spacing - 1e-9)));
    for (long q = 1; q <= n; ++q) {
      const real s = static_cast<real>(q) / n;
      at.push_back({line[k][0] + s * dx, line[k][1] + s * dy});
      along.push_back(walked + s * length);
    }
    walked += length;
  }
}

// One foot (point) or stations along a line; the feet on the bed on terrain, at the point's last coordinate,
// the 2D line's y or a 3D line's `floor` elsewhere.
void read_depth_gauge(const MonitorInput& in, MonitorSpec& spec) {
  const auto& fields = depth_gauge_type().fields;
  const int D = in.dimensions();
  const bool has_point = in.has("point"), has_line = in.has("line");
  if (has_point == has_line) in.refuse(in.at("point"), "give one of point or line (the stations' feet)");
  if (in.has("floor") && (has_point || in.on_terrain() || D == 2))
    in.refuse(in.at("floor"), has_point ? "only with a line: a point's floor is its last coordinate"
                                        : "only with a 3D line off terrain (the floor is the bed, or the line's y)");
  const real ox = in.origin()[0], oy = in.origin()[1];
  if (has_point) {
    const FieldSpec& key = field_spec(fields, "point");
    const auto c = in.coordinates(key, {static_cast<size_t>(in.on_terrain() ? 2 : D)});
    std::array<real, 3> p{0, 0, 0};
    for (size_t d = 0; d < c.size(); ++d) p[d] = c[d];
    if (in.on_terrain()) p = {c[0] - ox, c[1] - oy, in.bed_under(in.at(key.key), c[0] - ox, c[1] - oy)};
    in.check_in_domain(in.at(key.key), p, true);
    spec.probe_points = {p};
    return;
  }
  const FieldSpec& key = field_spec(fields, "line");
  const std::vector<std::array<real, 2>> line = in.line(key);
  const real spacing = spec.number("spacing");
  std::vector<std::array<real, 2>> at;
  stations_along(line, spacing > 0 ? spacing : in.dp(), at, spec.probe_stations);
  constexpr size_t kMaxStations = 100000;  // each sample searches every station's vertical
  if (at.size() > kMaxStations)
    in.refuse(in.at("spacing"), "gives " + std::to_string(at.size()) + " stations along the line (at most " +
                                    std::to_string(kMaxStations) + "): raise it");
  const real floor = spec.number("floor");
  for (const auto& q : at) {
    std::array<real, 3> p = {q[0], q[1], 0.0};  // 2D: x and the floor's height
    if (D == 3) p[2] = in.on_terrain() ? in.bed_under(in.at(key.key), q[0], q[1]) : floor;
    in.check_in_domain(in.at(key.key), p, false);
    spec.probe_points.push_back(p);
  }
}

}  // namespace

const MonitorType& depth_gauge_type() {
  static const MonitorType type = [] {
    FieldSpec point = shaped_field(
        "point", "vector",
        "the gauge's foot, where depth is measured from: [x, y] in 2D (y the floor's height), [x, y, z] in 3D (z the "
        "floor's); on terrain [x, y] map coordinates (the foot on the bed); one of point or line",
        false);
    point.parameters = {point_component()};
    FieldSpec line = shaped_field(
        "line", "polyline",
        "stations along a line instead of a point: [x, y] points; in 2D y is the floor's height, in 3D the points "
        "are in plan (map coordinates on terrain) and the feet are on the bed (terrain) or at `floor`",
        false, 0, 2);
    return monitor_type_of<DepthGauge>(
        "depth_gauge",
        "flow depth (free-surface height over the floor or bed) at a point, or its largest along a line",
        {point, line,
         number_field({"floor", "m", 0.0, -1e7, 1e7, false, false, false,
                       "the floor's height under a line in a 3D scene without terrain"},
                      3),
         number_field({"spacing", "m", 0.0, 0.0, 1e6, false, false, false,
                       "distance between stations along the line (0: dp)"},
                      0, "dp"),
         wet_kernel_sum_field(0.5, false, 1.0, true,
                              "fluid fraction sum V W (the floor's share included) that marks the free surface")},
        read_depth_gauge);
  }();
  return type;
}

}  // namespace runout::monitor_detail
