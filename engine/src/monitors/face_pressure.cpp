// A pressure transducer on a structure's face: it reads the force on its membrane. The SPH analogue is the
// normal component of the pair forces the momentum equation puts between the flow and the structure's particles
// (the structure_load formula: a wall pushes and never pulls),
//   F_b = sum_i m_i m_b max(p_i / rho_i^2 + p_b / rho_b^2, 0) grad_i W_ib . n,
// read as a pressure on the face around the sensor's point x_s: each column of the structure's particles (a
// dp x dp cell of the face, dp along the face in 2D, to the kernel's reach 2 h behind it) carries the load of its
// cell, and the sensor weights the columns by the kernel of their distance across the face from x_s,
//   p = sum_b W(|x_b - x_s|_face) F_b / sum_cells W(|x_c - x_s|_face) dp^(D-1).
// Summed over a whole face the column loads are the structure load. The kernel's weights, not a hard disc, so
// that a linear pressure is read at the point whatever the lattice's offset (a disc whose edge fell on a row of
// wall particles read the 2D hydrostatic tank 3-9 % high). A fluid probe next to a DBC wall reads the row of flow
// the wall holds off, which can be in tension while the wall is pushed (docs/validation.md section 7.1); the
// transducer does not.
#include <algorithm>
#include <cmath>
#include <array>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "monitor_types.hpp"

namespace runout::monitor_detail {
namespace {

template <int D>
class FacePressure final : public Monitor<D> {
 public:
  FacePressure(const MonitorSpec& spec, const Solver<D>& s) : Monitor<D>(spec.name), tag_(spec.tag) {
    if (spec.probe_points.size() != 1)
      throw std::invalid_argument("monitor '" + spec.name + "': a face pressure sensor needs exactly one point");
    point_ = probe_point<D>(spec, 0);
    for (int d = 0; d < D; ++d) normal_[d] = spec.normal[d];
    if (!(normal_.norm() > 0))
      throw std::invalid_argument("monitor '" + spec.name + "': a face pressure sensor needs the face's normal");
    normal_.normalize();
    collect_members(s);
    if (members_.empty())
      throw std::invalid_argument("monitor '" + spec.name + "': no particle of the structure lies within 2 h of the "
                                  "point across its face and 2 h behind it");
  }

  std::vector<std::string> columns() const override { return {"pressure_pa"}; }

  std::vector<real> sample(const Solver<D>& s) override {
    if (s.boundary_generation() != generation_) collect_members(s);
    const real weighted_force = normal_force(s);
    const real p = weighted_area_ > 0 ? weighted_force / weighted_area_ : 0.0;
    if (p > peak_ || peak_time_ < 0) peak_ = p, peak_time_ = s.time();
    if (arrival_ < 0 && p > 0) arrival_ = s.time();
    sum_p_ += p, ++samples_;
    return {p};
  }

  std::vector<std::pair<std::string, real>> summary() const override {
    return {{"peak_pressure_pa", peak_},
            {"time_of_peak_s", peak_time_},
            {"mean_pressure_pa", samples_ ? sum_p_ / samples_ : 0.0},
            {"arrival_time_s", arrival_}};
  }

  void save_state(StateWriter& out) const override {
    out.label("face_pressure:" + this->name());
    out.value(samples_), out.value(peak_), out.value(peak_time_), out.value(sum_p_), out.value(arrival_);
  }

  void load_state(StateReader& in) override {
    in.expect("face_pressure:" + this->name());
    in.value(samples_), in.value(peak_), in.value(peak_time_), in.value(sum_p_), in.value(arrival_);
    generation_ = kNoGeneration;
  }

 private:
  // The structure's particles within the kernel's reach of the sensor across the face and behind it, their
  // weights, and the weighted face their columns stand for.
  void collect_members(const Solver<D>& s) {
    const auto& b = s.boundary();
    const auto& cfg = s.config();
    const real reach = 2 * cfg.smoothing_length, dp = cfg.dp;
    Vec<D> first, second = Vec<D>::Zero();  // the face's axes
    if constexpr (D == 2) {
      first = Vec<D>(-normal_[1], normal_[0]);
    } else {
      const Vec<D> e = std::abs(normal_.dot(Vec<D>::UnitX())) < 0.9 ? Vec<D>::UnitX() : Vec<D>::UnitY();
      first = normal_.cross(e).normalized();
      second = normal_.cross(first);
    }
    members_.clear(), weights_.clear();
    // The columns: members whose places on the face lie within dp / 2 of each other (a column's layers share
    // one; neighbouring columns are dp apart), each with its weight.
    std::vector<std::array<real, 3>> columns;  // place across the face (2), weight
    with_kernel<D>(cfg.kernel, cfg.smoothing_length, [&](auto kernel) {
      for (size_t j = 0; j < b.size(); ++j) {
        if (b.tag[j] != tag_) continue;
        const Vec<D> dx = b.position(j) - point_;
        const real depth = dx.dot(normal_);  // the structure lies along the push, behind its face
        const real across = (dx - depth * normal_).norm();
        if (across >= reach || depth < -0.5 * dp || depth > reach) continue;
        const real w = kernel.W(across);
        if (w <= 0) continue;
        members_.push_back(j), weights_.push_back(w);
        const real a = dx.dot(first), c = D == 3 ? dx.dot(second) : real(0);
        const bool known = std::any_of(columns.begin(), columns.end(), [&](const auto& col) {
          return std::hypot(col[0] - a, col[1] - c) < 0.5 * dp;
        });
        if (!known) columns.push_back({a, c, w});
      }
    });
    weighted_area_ = 0;
    for (const auto& col : columns) weighted_area_ += col[2] * std::pow(dp, D - 1);
    generation_ = s.boundary_generation();
  }

  // The flow's push on the members along the normal, each weighted, with the last force evaluation's pressures.
  real normal_force(const Solver<D>& s) const {
    const auto& cfg = s.config();
    const auto& f = s.fluid();
    const auto& b = s.boundary();
    const auto& pf = s.fluid_pressure();
    const auto& pb = s.boundary_pressure();
    const real support = 2.0 * cfg.smoothing_length;
    Vec<D> lo = point_, hi = point_;
    for (size_t j : members_) lo = lo.cwiseMin(b.position(j)), hi = hi.cwiseMax(b.position(j));
    real force = 0;
    with_kernel<D>(cfg.kernel, cfg.smoothing_length, [&](auto kernel) {
      for (size_t i = 0; i < f.size() && i < pf.size(); ++i) {
        const Vec<D> xi = f.position(i);
        bool near = true;
        for (int d = 0; d < D; ++d) near = near && xi[d] > lo[d] - support && xi[d] < hi[d] + support;
        if (!near || Solver<D>::is_inlet_buffer(f.tag[i])) continue;
        const real pi = pf[i] / (f.rho[i] * f.rho[i]);
        for (size_t q = 0; q < members_.size(); ++q) {
          const size_t j = members_[q];
          const Vec<D> dx = xi - b.position(j);
          const real r = dx.norm();
          if (r >= support || r < 1e-12) continue;
          const real push = std::max(pi + pb[j] / (b.rho[j] * b.rho[j]), real(0));
          force += weights_[q] * f.mass[i] * b.mass[j] * push * kernel.grad_factor(r) * dx.dot(normal_);
        }
      }
    });
    return force;
  }

  static constexpr uint64_t kNoGeneration = std::numeric_limits<uint64_t>::max();
  uint32_t tag_;
  uint64_t generation_ = 0;
  Vec<D> point_, normal_ = Vec<D>::Zero();
  std::vector<size_t> members_;
  std::vector<real> weights_;  // by member: the kernel of its distance from the point across the face
  real weighted_area_ = 0;     // sum over the members' cells of weight x dp^(D-1)
  long samples_ = 0;
  real peak_ = 0, peak_time_ = -1, sum_p_ = 0, arrival_ = -1;
};

// The structure, the sensor's centre on its face (map coordinates on terrain, the elevation last) and the
// face's normal.
void read_face_pressure(const MonitorInput& in, MonitorSpec& spec) {
  const auto& fields = face_pressure_type().fields;
  spec.tag = in.structure_tag("structure");
  const FieldSpec& key = field_spec(fields, "point");
  const int D = in.dimensions();
  const auto c = in.coordinates(key, {static_cast<size_t>(D)});
  std::array<real, 3> p{0, 0, 0};
  for (int d = 0; d < D; ++d) p[d] = c[d];
  if (in.on_terrain()) p[0] -= in.origin()[0], p[1] -= in.origin()[1];
  in.check_in_domain(in.at(key.key), p, true);
  spec.probe_points = {p};
  read_normal(in, field_spec(fields, "normal"), spec);
}

}  // namespace

const MonitorType& face_pressure_type() {
  static const MonitorType type = [] {
    FieldSpec point = shaped_field("point", "vector",
                                   "the sensor's centre on the structure's face: [x, y] in 2D, [x, y, z] in 3D");
    point.parameters = {point_component()};
    FieldSpec normal = shaped_field("normal", "vector",
                                    "the direction the flow pushes the face, into the structure (one number per "
                                    "axis, not all zero)");
    normal.parameters = {{"normal", "", 0.0, -1.0, 1.0, false, false, false, "a component of the normal"}};
    return monitor_type_of<FacePressure>(
        "face_pressure",
        "pressure on a structure's face as a transducer reads it: the flow's push on the structure's particles "
        "within 2 h of the point across the face and 2 h behind it, kernel-weighted, over the face they stand for",
        {shaped_field("structure", "string", "a boundary's tag or a terrain structure's name"), point, normal},
        read_face_pressure);
  }();
  return type;
}

}  // namespace runout::monitor_detail
