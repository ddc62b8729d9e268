// The structure load: force and mean pressure of the flow on a tagged structure, as a load cell reads them.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Geometry>

#include "runout/engine/kernels.hpp"
#include "runout/engine/load_filter.hpp"
#include "monitor_types.hpp"

namespace runout::monitor_detail {
namespace {

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
    const real window = spec.number("window"), min_area = spec.number("min_wetted_area");
    filter_ = LoadFilter(window > 0 ? window : std::sqrt(2 * face.height / face.g),
                         min_area > 0 ? min_area : 0.1 * face.area);
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

  // The members are indices into the boundary as it was laid out when saved: not saved, found again at the next
  // evaluation. The filter carries the window and minimum area derived from the flow at the start.
  void save_state(StateWriter& out) const override {
    out.label("structure_load:" + this->name());
    out.value(evaluated_);
    out.value(instant_force_), out.value(instant_peak_pressure_), out.value(peak_particle_pressure_);
    out.values(history_);
    filter_.save_state(out);
  }

  void load_state(StateReader& in) override {
    in.expect("structure_load:" + this->name());
    in.value(evaluated_);
    in.value(instant_force_), in.value(instant_peak_pressure_), in.value(peak_particle_pressure_);
    in.values(history_);
    filter_.load_state(in);
    generation_ = kNoGeneration;
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
    const Vec<D>& up = up_;
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
    CellCount cells(dp);
    const auto& f = s.fluid();
    for (size_t i = 0; i < loading_.size(); ++i) {
      if (!loading_[i]) continue;
      const Vec<D> p = f.position(i);
      cells.add(p.dot(first), D == 3 ? p.dot(second) : real(0));
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

  // No solver's boundary_generation(): members_ is collected again at the next evaluation. lo_ and hi_ need not
  // be: the structure's particles are always alive and never move, only their indices change.
  static constexpr uint64_t kNoGeneration = std::numeric_limits<uint64_t>::max();
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

FieldSpec normal_field() {
  FieldSpec f = shaped_field("normal", "vector", "the direction the flow pushes the structure (one number per axis, not all zero)",
                             false);
  f.parameters = {{"normal", "", 0.0, -1.0, 1.0, false, false, false, "a component of the normal"}};
  f.default_text = "on terrain the structure's downstream normal, otherwise the force magnitude";
  return f;
}

// The structure's tag; the normal as given, else (on terrain) the structure's downstream one.
void read_structure_load(const MonitorInput& in, MonitorSpec& spec) {
  spec.tag = in.structure_tag("structure");
  if (in.has("normal"))
    read_normal(in, field_spec(structure_load_type().fields, "normal"), spec);
  else
    spec.normal = in.structure_normal(in.text("structure"));
}

}  // namespace

void read_normal(const MonitorInput& in, const FieldSpec& key, MonitorSpec& spec) {
  const int D = in.dimensions();
  const auto n = in.vector(key, D);
  real n2 = 0;
  for (int d = 0; d < D; ++d) spec.normal[d] = n[d], n2 += n[d] * n[d];
  if (!(n2 > 1e-12)) in.refuse(in.at(key.key), "must not be zero");
}

const MonitorType& structure_load_type() {
  static const MonitorType type = monitor_type_of<StructureLoad>(
      "structure_load", "force and pressure of the flow on a tagged boundary or terrain structure",
      {shaped_field("structure", "string", "a boundary's tag or a terrain structure's name"), normal_field(),
       number_field({"window", "s", 0.0, 0.0, 1e4, false, false, false,
                     "the load cell's averaging window: reported force and mean pressure are means over it"},
                    0, "sqrt(2H/g), H the structure's height: the time a run-up takes to climb it and stall"),
       number_field({"min_wetted_area", "m2", 0.0, 0.0, 1e8, false, false, false,
                     "the least wetted area (window mean) a mean pressure is reported over (m in 2D)"},
                    0, "10% of the structure's face (height x width across the flow; its height in 2D)")},
      read_structure_load);
  return type;
}

}  // namespace runout::monitor_detail
