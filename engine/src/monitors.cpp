// Cross-section gauges and structure loads, and the registration list (the point probes: src/monitors/).
#include "runout/engine/monitors.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Geometry>

#include "runout/engine/geometry.hpp"
#include "runout/engine/kernels.hpp"
#include "runout/engine/load_filter.hpp"
#include "monitors/monitor_types.hpp"

namespace runout {
namespace {

// Flow through a section: each particle's side (upstream -1, downstream +1, 0 beyond the section's ends)
// is remembered by id; a particle crossing upstream -> downstream adds its volume to the volume passed, one
// crossing back subtracts it. Q is the volume passed between two samples over their interval. A particle's
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
    arrival_volume_ = spec.arrival_volume > 0 ? spec.arrival_volume : 0.005 * volume;
    hydrograph_ = LoadFilter(spec.window > 0 ? spec.window : release_time(s, inlets_only), 0);
    hydrograph_.add(s.time(), 0, 0);
  }

  std::vector<std::string> columns() const override {
    return {"discharge_m3_s", "volume_passed_m3", "discharge_unfiltered_m3_s"};
  }

  void after_step(const Solver<D>& s) override {
    const auto& f = s.fluid();
    if (side_.size() < s.id_bound()) side_.resize(s.id_bound(), 0);  // particles an inlet added
    real dv = 0;
#pragma omp parallel for reduction(+ : dv) schedule(static)
    for (size_t i = 0; i < f.size(); ++i) {
      if (Solver<D>::is_inlet_buffer(f.tag[i])) continue;  // not flow yet
      const int now = raw_side(f, i) * downstream_;
      if (now == 0) continue;
      int8_t& before = side_[f.id[i]];
      if (before == -1 && now == 1) dv += f.mass[i] * inv_rho0_[f.material[i]];
      if (before == 1 && now == -1) dv -= f.mass[i] * inv_rho0_[f.material[i]];
      before = static_cast<int8_t>(now);
    }
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
    std::unordered_set<int64_t> columns;
    size_t n = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      if (Solver<D>::is_inlet_buffer(f.tag[i]) && !inlets_only) continue;
      ++n;
      int64_t key = static_cast<int64_t>(std::floor(f.pos[0][i] / dp)) + (int64_t(1) << 30);
      if constexpr (D == 3) key = (key << 32) + static_cast<int64_t>(std::floor(f.pos[1][i] / dp)) + (int64_t(1) << 30);
      columns.insert(key);
    }
    real g = 0;
    for (int d = 0; d < D; ++d) g += s.config().gravity[d] * s.config().gravity[d];
    g = g > 0 ? std::sqrt(g) : real(9.81);
    const real depth = columns.empty() ? dp : n * dp / columns.size();
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

// Force of the flow on a tagged structure: the reaction to the pressure force the engine's momentum
// equation puts on each fluid particle from the structure's particles,
//   F = sum_i sum_j m_i m_j max(p_i / rho_i^2 + p_j / rho_j^2, 0) grad_i W_ij,
// with the same kernel, pressures and densities as the last force evaluation; the wetted face is the footprint
// on the structure's face of the fluid pushing it (wetted_face). Both are evaluated at least 50 times a load-cell
// window and filtered as a load cell reads them (load_filter.hpp): the reported force and mean pressure are
// window means, the largest single-particle boundary pressure a diagnostic.
template <int D>
class StructureLoad final : public Monitor<D> {
 public:
  StructureLoad(const MonitorSpec& spec, const Solver<D>& s)
      : Monitor<D>(spec.name), tag_(spec.tag), filter_(1, 0) {
    const auto& b = s.boundary();
    collect_members(s);
    if (spec.tag == 0 || members_.empty())
      throw std::invalid_argument("monitor '" + spec.name + "': no boundary particle carries tag " +
                                  std::to_string(spec.tag));
    real n2 = 0;
    for (int d = 0; d < D; ++d) normal_[d] = spec.normal[d], n2 += normal_[d] * normal_[d];
    has_normal_ = n2 > 0;
    if (has_normal_) normal_ /= std::sqrt(n2);
    lo_ = Vec<D>::Constant(std::numeric_limits<real>::infinity());
    hi_ = -lo_;
    for (size_t j : members_) lo_ = lo_.cwiseMin(b.position(j)), hi_ = hi_.cwiseMax(b.position(j));
    for (int d = 0; d < D; ++d) up_[d] = -s.config().gravity[d];
    if (up_.norm() > 0) up_.normalize(); else up_ = Vec<D>::Unit(D - 1);
    const Face face = loaded_face(s);
    filter_ = LoadFilter(spec.window > 0 ? spec.window : std::sqrt(2 * face.height / face.g),
                         spec.min_wetted_area > 0 ? spec.min_wetted_area : 0.1 * face.area);
  }

  std::vector<std::string> columns() const override {
    return {"force_n", "mean_pressure_pa", "peak_pressure_pa", "wetted_area_m2", "force_unfiltered_n"};
  }

  void after_step(const Solver<D>& s) override {
    if (s.time() - filter_.latest_time() >= filter_.window() / 50) evaluate(s);
  }

  std::vector<real> sample(const Solver<D>& s) override {
    if (!evaluated_ || s.time() > filter_.latest_time()) evaluate(s);
    const LoadReading& r = filter_.reading();
    history_.push_back({s.time(), r.force, r.mean_pressure});
    return {r.force, r.mean_pressure, instant_peak_pressure_, r.wetted_area, instant_force_};
  }

  std::vector<std::pair<std::string, real>> summary() const override {
    // Late stable value: the mean over the last 10% of the samples (at least one).
    real late_f = 0, late_p = 0;
    const size_t n = history_.size(), k = std::max<size_t>(1, n / 10);
    for (size_t q = n - std::min(n, k); q < n; ++q) late_f += history_[q][1], late_p += history_[q][2];
    if (n) late_f /= std::min(n, k), late_p /= std::min(n, k);
    return {{"peak_force_n", filter_.peak_force()},
            {"time_of_peak_force_s", filter_.time_of_peak_force()},
            {"peak_mean_pressure_pa", filter_.peak_mean_pressure()},
            {"time_of_peak_pressure_s", filter_.time_of_peak_pressure()},
            {"peak_force_unfiltered_n", filter_.peak_instant_force()},
            {"peak_particle_pressure_pa", peak_particle_pressure_},
            {"late_force_n", late_f},
            {"late_mean_pressure_pa", late_p},
            {"load_window_s", filter_.window()},
            {"min_wetted_area_m2", filter_.min_wetted_area()}};
  }

 private:
  struct Face {
    real height, area, g;  // along gravity [m]; height x width across the flow [m2, m in 2D]; |g| [m/s2]
  };
  // The structure's loaded face from its particles' extent: its height along gravity and (3D) its width across
  // the flow (horizontal, normal to the flow direction; the larger horizontal extent with no direction given).
  Face loaded_face(const Solver<D>& s) const {
    Vec<D> g;
    for (int d = 0; d < D; ++d) g[d] = s.config().gravity[d];
    const real g_norm = g.norm() > 0 ? g.norm() : real(9.81);
    const Vec<D> up = g.norm() > 0 ? Vec<D>(-g / g.norm()) : Vec<D>(Vec<D>::Unit(D - 1));
    const auto extent = [&](const Vec<D>& dir) {
      real a = std::numeric_limits<real>::infinity(), z = -a;
      for (size_t j : members_) {
        const real x = s.boundary().position(j).dot(dir);
        a = std::min(a, x), z = std::max(z, x);
      }
      return z - a;
    };
    const real height = std::max(extent(up), s.config().dp);
    if constexpr (D == 2) {
      return {height, height, g_norm};
    } else {
      Vec<D> across = has_normal_ ? Vec<D>(up.cross(normal_)) : Vec<D>::Zero();
      real width = 0;
      if (across.norm() > 1e-9) {
        width = extent(across / across.norm());
      } else {
        const Vec<D> e0 = up.cross(Vec<D>::UnitX()).norm() > 1e-9 ? Vec<D>(up.cross(Vec<D>::UnitX()).normalized())
                                                                   : Vec<D>(up.cross(Vec<D>::UnitY()).normalized());
        width = std::max(extent(e0), extent(up.cross(e0).normalized()));
      }
      return {height, height * std::max(width, s.config().dp), g_norm};
    }
  }

  // The instantaneous force (along the normal, or its magnitude), wetted face and largest loaded boundary
  // pressure, fed to the filter.
  void evaluate(const Solver<D>& s) {
    if (s.boundary_generation() != generation_) collect_members(s);
    Vec<D> force = Vec<D>::Zero();
    real peak_p = 0;
    loading_.assign(s.fluid().size(), 0);
    sum_contacts(s, force, peak_p);
    // The fluid feels -sum m_i m_j (...) grad_i W; the wall the opposite, which is the sum as written
    // (fluid resting on a floor: dx points up, the gradient factor is negative, the floor is pushed down).
    instant_force_ = has_normal_ ? force.dot(normal_) : force.norm();
    instant_peak_pressure_ = peak_p;
    peak_particle_pressure_ = std::max(peak_particle_pressure_, peak_p);
    filter_.add(s.time(), instant_force_, wetted_face(s, has_normal_ ? normal_ : force));
    evaluated_ = true;
  }

  // The face the flow loads: the loading fluid particles (those within a kernel support of the structure)
  // projected on the structure's face, counted in cells of dp x dp (dp in 2D). Counting the fluid's footprint,
  // not the wall particles it reaches, makes the area independent of how many wall layers lie within the
  // support and of the gap a wall treatment keeps between flow and wall.
  real wetted_face(const Solver<D>& s, const Vec<D>& direction) const {
    const real dp = s.config().dp;
    // The face's axes: up and (3D) across the push; a push along gravity (a floor) loads a face in plan.
    const bool floor = !(direction.norm() > 0) || std::abs(direction.dot(up_)) > 0.9 * direction.norm();
    Vec<D> first = up_, second = Vec<D>::Zero();
    if constexpr (D == 2) {
      if (floor) first = Vec<D>(up_[1], -up_[0]);
    } else {
      const Vec<D> e = std::abs(up_.dot(Vec<D>::UnitX())) < 0.9 ? Vec<D>::UnitX() : Vec<D>::UnitY();
      second = floor ? Vec<D>(up_.cross(e).normalized()) : Vec<D>(up_.cross(direction).normalized());
      if (floor) first = up_.cross(second);
    }
    std::unordered_set<int64_t> cells;
    const auto& f = s.fluid();
    for (size_t i = 0; i < loading_.size(); ++i) {
      if (!loading_[i]) continue;
      const Vec<D> p = f.position(i);
      int64_t key = static_cast<int64_t>(std::floor(p.dot(first) / dp)) + (int64_t(1) << 30);
      if constexpr (D == 3) key = (key << 32) + static_cast<int64_t>(std::floor(p.dot(second) / dp)) + (int64_t(1) << 30);
      cells.insert(key);
    }
    return cells.size() * std::pow(dp, D - 1);
  }

  // Sums the pair forces of the fluid on the structure's particles; marks the loading fluid particles and
  // finds the largest pressure of a structure particle they reach.
  void sum_contacts(const Solver<D>& s, Vec<D>& force, real& peak_p) {
    const auto& cfg = s.config();
    const auto& f = s.fluid();
    const auto& b = s.boundary();
    const auto& pf = s.fluid_pressure();
    const auto& pb = s.boundary_pressure();
    const real support = 2.0 * cfg.smoothing_length;
    // Fluid near the structure, hashed in cells of the kernel support.
    std::unordered_map<uint64_t, std::vector<uint32_t>> cells;
    auto key = [&](const Vec<D>& p) {
      uint64_t k = 0;
      for (int d = 0; d < D; ++d)
        k = k * 2097143u + static_cast<uint64_t>(static_cast<int64_t>(std::floor((p[d] - lo_[d]) / support)) + 1048576);
      return k;
    };
    for (size_t i = 0; i < f.size() && i < pf.size(); ++i) {
      const Vec<D> p = f.position(i);
      bool near = true;
      for (int d = 0; d < D; ++d) near = near && p[d] > lo_[d] - support && p[d] < hi_[d] + support;
      if (near) cells[key(p)].push_back(static_cast<uint32_t>(i));
    }
    if (cells.empty()) return;
    with_kernel<D>(cfg.kernel, cfg.smoothing_length, [&](auto kernel) {
      for (size_t j : members_) {
        const Vec<D> xj = b.position(j);
        const real pj = pb[j] / (b.rho[j] * b.rho[j]);
        bool reached = false;
        std::array<int64_t, D> c;
        for (int d = 0; d < D; ++d) c[d] = static_cast<int64_t>(std::floor((xj[d] - lo_[d]) / support));
        for (int o = 0; o < (D == 2 ? 9 : 27); ++o) {
          uint64_t k = 0;
          int rem = o;
          for (int d = 0; d < D; ++d, rem /= 3) k = k * 2097143u + static_cast<uint64_t>(c[d] + rem % 3 - 1 + 1048576);
          auto it = cells.find(k);
          if (it == cells.end()) continue;
          for (uint32_t i : it->second) {
            const Vec<D> dx = f.position(i) - xj;
            const real r = dx.norm();
            if (r >= support || r < 1e-12) continue;
            // a wall pushes and never pulls, as in the momentum equation
            const real push = std::max(pf[i] / (f.rho[i] * f.rho[i]) + pj, real(0));
            force += f.mass[i] * b.mass[j] * push * kernel.grad_factor(r) * dx;
            if (push > 0) loading_[i] = 1, reached = true;
          }
        }
        if (reached) peak_p = std::max(peak_p, pb[j]);
      }
    });
  }

  // The structure's particles: indices into the boundary, found again whenever the solver rebuilds it (wall
  // tiles laid or dropped); the structure's own particles are always alive.
  void collect_members(const Solver<D>& s) {
    const auto& b = s.boundary();
    members_.clear();
    for (size_t j = 0; j < b.size(); ++j)
      if (b.tag[j] == tag_) members_.push_back(j);
    generation_ = s.boundary_generation();
  }

  uint32_t tag_;
  uint64_t generation_ = 0;
  std::vector<size_t> members_;
  Vec<D> normal_ = Vec<D>::Zero(), lo_, hi_;
  bool has_normal_ = false, evaluated_ = false;
  Vec<D> up_ = Vec<D>::Unit(D - 1);  // against gravity
  std::vector<uint8_t> loading_;  // by fluid index: within a support of the structure, pushing it
  LoadFilter filter_;
  real instant_force_ = 0, instant_peak_pressure_ = 0, peak_particle_pressure_ = 0;
  std::vector<std::array<real, 3>> history_;  // samples: t, filtered force, filtered mean pressure
};

// The descriptors: what a scene writes for each type (docs/scene-format.md, "Monitors").
using monitor_detail::monitor_type_of;

FieldSpec normal_field() {
  FieldSpec f = shaped_field("normal", "vector", "the direction the flow pushes the structure (one number per axis, not all zero)",
                             false);
  f.parameters = {{"normal", "", 0.0, -1.0, 1.0, false, false, false, "a component of the normal"}};
  f.default_text = "on terrain the structure's downstream normal, otherwise the force magnitude";
  return f;
}

const MonitorType section_type = monitor_type_of<SectionGauge>(
    "section", "discharge and volume through a cross-section line; the front's arrival",
    {shaped_field("line", "polyline", "the gauge line: at least 2 [x, y] points (map coordinates on terrain, m)", true,
                  3, 2),
     number_field({"x", "m", 0.0, -1e7, 1e7, false, false, true, "the section's x"}, 2),
     number_field({"arrival_volume", "m3", 0.0, 0.0, 1e12, false, false, false,
                   "flow volume past the section that marks the front's arrival (m2 in 2D)"},
                  0, "0.5% of the flow volume at the start"),
     number_field({"window", "s", 0.0, 0.0, 1e4, false, false, false,
                   "the hydrograph's averaging window: the reported discharge is the volume passed in it over its length"},
                  0, "sqrt(2d/g), d the flow's mean depth at the start")});

const MonitorType structure_load_type = monitor_type_of<StructureLoad>(
    "structure_load", "force and pressure of the flow on a tagged boundary or terrain structure",
    {shaped_field("structure", "string", "a boundary's tag or a terrain structure's name"), normal_field(),
     number_field({"window", "s", 0.0, 0.0, 1e4, false, false, false,
                   "the load cell's averaging window: reported force and mean pressure are means over it"},
                  0, "sqrt(2H/g), H the structure's height: the time a run-up takes to climb it and stall"),
     number_field({"min_wetted_area", "m2", 0.0, 0.0, 1e8, false, false, false,
                   "the least wetted area (window mean) a mean pressure is reported over (m in 2D)"},
                  0, "10% of the structure's face (height x width across the flow; its height in 2D)")});

}  // namespace

// The registration list: one line per monitor type, in the order scenes and docs list them.
const std::vector<const MonitorType*>& monitor_types() {
  static const std::vector<const MonitorType*> types = {
      &section_type,
      &structure_load_type,
      &monitor_detail::pressure_probe_type(),
      &monitor_detail::depth_gauge_type(),
  };
  return types;
}

const MonitorType& monitor_type(const std::string& name) { return find_model(monitor_types(), name, "monitor type"); }

template <int D>
const std::map<std::string, MonitorFactory<D>>& monitor_registry() {
  static const std::map<std::string, MonitorFactory<D>> registry = [] {
    std::map<std::string, MonitorFactory<D>> r;
    for (const auto* t : monitor_types()) {
      if constexpr (D == 2) r[t->name] = t->make_2d;
      else r[t->name] = t->make_3d;
    }
    return r;
  }();
  return registry;
}

template <int D>
std::unique_ptr<Monitor<D>> make_monitor(const MonitorSpec& spec, const Solver<D>& solver) {
  const auto& reg = monitor_registry<D>();
  auto it = reg.find(spec.type);
  if (it == reg.end()) {
    std::string names;
    for (const auto& [n, f] : reg) names += (names.empty() ? "" : ", ") + n;
    throw std::invalid_argument("monitor '" + spec.name + "': unknown type '" + spec.type + "' (accepted: " + names + ")");
  }
  return it->second(spec, solver);
}

template const std::map<std::string, MonitorFactory<2>>& monitor_registry<2>();
template const std::map<std::string, MonitorFactory<3>>& monitor_registry<3>();
template std::unique_ptr<Monitor<2>> make_monitor<2>(const MonitorSpec&, const Solver<2>&);
template std::unique_ptr<Monitor<3>> make_monitor<3>(const MonitorSpec&, const Solver<3>&);

}  // namespace runout
