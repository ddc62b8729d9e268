// The cross-section gauge: discharge and volume through a line, the front's arrival.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "runout/engine/geometry.hpp"
#include "runout/engine/load_filter.hpp"
#include "../ordered_sum.hpp"
#include "monitor_types.hpp"

namespace runout::monitor_detail {
namespace {

// Flow through a section: each particle's side (upstream -1, downstream +1, 0 beyond the section's ends)
// is remembered by id; a particle crossing upstream -> downstream adds its volume to the volume passed, one
// crossing back subtracts it. Q is the volume passed in a sliding window over its length. A particle's
// volume is m/rho0 (debris at its bulk density), not the SPH m/rho: a cohesionless material carries no
// tension, so a thin spreading sheet's kernel density falls below rho0 and m/rho would count it up to twice.
template <int D>
class SectionGauge final : public Monitor<D> {
 public:
  SectionGauge(const MonitorSpec& spec, const Solver<D>& s) : Monitor<D>(spec.name), pts_(spec.points) {
    if (pts_.empty() || (D == 3 && pts_.size() < 2))
      throw std::invalid_argument("monitor '" + spec.name + "': a section needs " +
                                  std::string(D == 3 ? "at least 2 points" : "1 point"));
    const auto& f = s.fluid();
    for (const auto& m : s.materials()) inv_rho0_.push_back(1 / m.density);
    side_.assign(s.id_bound(), 0);
    // Downstream is the side away from where the flow starts: the side most of the flow is not on, when
    // most of it lies within the line's ends; otherwise (a release beside or beyond a short line) the side
    // of the line, extended, opposite the flow's centroid. The order of the line's points does not matter.
    long pos = 0, neg = 0;
    real volume = 0;
    std::array<double, 2> centroid{0, 0};
    // A scene whose flow all comes from inlets: their buffers say where it starts.
    size_t n_flow = 0;
    const bool inlets_only = std::all_of(f.tag.begin(), f.tag.end(), Solver<D>::is_inlet_buffer);
    for (size_t i = 0; i < f.size(); ++i) {
      if (Solver<D>::is_inlet_buffer(f.tag[i]) && !inlets_only) continue;
      ++n_flow;
      const int raw = raw_side(f, i);
      pos += raw > 0;
      neg += raw < 0;
      if (!inlets_only) volume += f.mass[i] * inv_rho0_[f.material[i]];
      for (int d = 0; d < 2 && d < D; ++d) centroid[d] += f.pos[d][i];
    }
    if (2 * (pos + neg) > static_cast<long>(n_flow) && pos != neg) {
      downstream_ = pos > neg ? -1 : 1;
    } else if (n_flow > 0) {
      for (auto& c : centroid) c /= static_cast<double>(n_flow);
      downstream_ = -side_of_extended_line(centroid[0], centroid[1]);
    }
    for (size_t i = 0; i < f.size(); ++i) side_[f.id[i]] = static_cast<int8_t>(raw_side(f, i) * downstream_);
    const real arrival = spec.number("arrival_volume"), window = spec.number("window");
    arrival_volume_ = arrival > 0 ? arrival : 0.005 * volume;
    hydrograph_ = LoadFilter(window > 0 ? window : release_time(s, inlets_only), 0);
    hydrograph_.add(s.time(), 0, 0);
  }

  std::vector<std::string> columns() const override {
    return {"discharge_m3_s", "volume_passed_m3", "discharge_unfiltered_m3_s"};
  }

  void after_step(const Solver<D>& s) override {
    const auto& f = s.fluid();
    if (side_.size() < s.id_bound()) side_.resize(s.id_bound(), 0);  // particles an inlet added
    const real dv = ordered_sum(f.size(), [&](size_t i) -> real {  // repeats to the bit (ordered_sum.hpp)
      if (Solver<D>::is_inlet_buffer(f.tag[i])) return 0;  // not flow yet
      const int now = raw_side(f, i) * downstream_;
      if (now == 0) return 0;
      int8_t& before = side_[f.id[i]];
      real d = 0;
      if (before == -1 && now == 1) d = f.mass[i] * inv_rho0_[f.material[i]];
      if (before == 1 && now == -1) d = -f.mass[i] * inv_rho0_[f.material[i]];
      before = static_cast<int8_t>(now);
      return d;
    });
    passed_ += dv;
    if (arrival_time_ < 0 && passed_ > 0 && passed_ >= arrival_volume_) arrival_time_ = s.time();
    if (s.time() > hydrograph_.latest_time()) hydrograph_.add(s.time(), dv / (s.time() - hydrograph_.latest_time()), 0);
  }

  std::vector<real> sample(const Solver<D>& s) override {
    const real t = s.time();
    real q = 0;
    if (t > last_t_) q = (passed_ - last_passed_) / (t - last_t_);
    if (q > peak_unfiltered_) peak_unfiltered_ = q;
    last_t_ = t;
    last_passed_ = passed_;
    return {hydrograph_.reading().force, passed_, q};
  }

  std::vector<std::pair<std::string, real>> summary() const override {
    return {{"peak_discharge_m3_s", hydrograph_.peak_force()},
            {"time_of_peak_s", hydrograph_.time_of_peak_force()},
            {"arrival_time_s", arrival_time_},
            {"volume_passed_m3", passed_},
            {"peak_discharge_unfiltered_m3_s", peak_unfiltered_},
            {"discharge_window_s", hydrograph_.window()}};
  }

  // The orientation, the arrival volume and the hydrograph's window came from the flow at the start, which a
  // resumed run's constructor no longer sees: they are saved with the counts.
  void save_state(StateWriter& out) const override {
    out.label("section:" + this->name());
    out.values(side_);
    out.value(downstream_), out.value(arrival_volume_);
    out.value(passed_), out.value(last_passed_), out.value(last_t_);
    out.value(peak_unfiltered_), out.value(arrival_time_);
    hydrograph_.save_state(out);
  }

  void load_state(StateReader& in) override {
    in.expect("section:" + this->name());
    in.values(side_);
    in.value(downstream_), in.value(arrival_volume_);
    in.value(passed_), in.value(last_passed_), in.value(last_t_);
    in.value(peak_unfiltered_), in.value(arrival_time_);
    hydrograph_.load_state(in);
  }

 private:
  std::vector<std::array<real, 2>> pts_;
  std::vector<int8_t> side_;  // by particle id
  std::vector<real> inv_rho0_;  // by material
  int downstream_ = 1;
  real arrival_volume_ = 0, passed_ = 0, last_passed_ = 0, last_t_ = 0;
  real peak_unfiltered_ = 0, arrival_time_ = -1;
  // The hydrograph as a gauge reads it: the load cell's sliding window (load_filter.hpp) on the discharge, each
  // step's volume over its dt, so the window's mean is exactly the volume passed in it over its length.
  LoadFilter hydrograph_{1, 0};

  // The default window: sqrt(2 d / g), d the flow's mean depth at the start (its volume over its plan area, in
  // dp cells): the time the released column takes to fall its own depth, the dam break's unit of time. A surge's
  // discharge changes over this time at any resolution, while a single particle crossing lasts ~dp / v.
  static real release_time(const Solver<D>& s, bool inlets_only) {
    const auto& f = s.fluid();
    const real dp = s.config().dp;
    CellCount columns(dp);
    size_t n = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      if (Solver<D>::is_inlet_buffer(f.tag[i]) && !inlets_only) continue;
      ++n;
      columns.add(f.pos[0][i], D == 3 ? f.pos[1][i] : real(0));
    }
    real g = 0;
    for (int d = 0; d < D; ++d) g += s.config().gravity[d] * s.config().gravity[d];
    g = g > 0 ? std::sqrt(g) : real(9.81);
    const real depth = columns.size() == 0 ? dp : n * dp / columns.size();
    return std::sqrt(2 * depth / g);
  }

  // +1/-1 by the side of the segment nearest to (x, y) (distance to the segment, ends included), its line
  // extended; in 2D by x against the section. Never 0 (a point exactly on the line counts as +1). A repeated
  // point's zero-length segment is left out, as this loop always did.
  int side_of_extended_line(real x, real y) const {
    if constexpr (D == 2) {
      (void)y;
      return x >= pts_[0][0] ? 1 : -1;
    } else {
      SegmentRules rules;
      rules.on_line_side = 1;
      rules.skip_zero_length = true;
      return nearest_segment(pts_, x, y, rules).side < 0 ? -1 : 1;
    }
  }

  // +1/-1 by the side of the nearest segment whose extent the particle is in, 0 if none.
  int raw_side(const ParticleArrays<D>& f, size_t i) const {
    if constexpr (D == 2) {
      return f.pos[0][i] >= pts_[0][0] ? 1 : -1;
    } else {
      const real x = f.pos[0][i], y = f.pos[1][i];
      real best = std::numeric_limits<real>::infinity();
      int side = 0;
      for (size_t k = 0; k + 1 < pts_.size(); ++k) {
        const real ax = pts_[k][0], ay = pts_[k][1];
        const real ex = pts_[k + 1][0] - ax, ey = pts_[k + 1][1] - ay;
        const real len2 = ex * ex + ey * ey;
        const real t = ((x - ax) * ex + (y - ay) * ey) / len2;
        if (t < 0 || t > 1) continue;
        const real cross = ex * (y - ay) - ey * (x - ax);
        const real d = std::abs(cross) / std::sqrt(len2);
        if (d < best) best = d, side = cross > 0 ? 1 : -1;
      }
      return side;
    }
  }
};

// The line (3D: in plan, the run's frame) or, in 2D, the declared x.
void read_section(const MonitorInput& in, MonitorSpec& spec) {
  if (in.dimensions() == 3)
    spec.points = in.line(field_spec(section_type().fields, "line"));
  else
    spec.points.push_back({spec.number("x"), 0.0});
}

}  // namespace

const MonitorType& section_type() {
  static const MonitorType type = monitor_type_of<SectionGauge>(
      "section", "discharge and volume through a cross-section line; the front's arrival",
      {shaped_field("line", "polyline", "the gauge line: at least 2 [x, y] points (map coordinates on terrain, m)", true,
                    3, 2),
       number_field({"x", "m", 0.0, -1e7, 1e7, false, false, true, "the section's x"}, 2),
       number_field({"arrival_volume", "m3", 0.0, 0.0, 1e12, false, false, false,
                     "flow volume past the section that marks the front's arrival (m2 in 2D)"},
                    0, "0.5% of the flow volume at the start"),
       number_field({"window", "s", 0.0, 0.0, 1e4, false, false, false,
                     "the hydrograph's averaging window: the reported discharge is the volume passed in it over its length"},
                    0, "sqrt(2d/g), d the flow's mean depth at the start")},
      read_section);
  return type;
}

}  // namespace runout::monitor_detail
