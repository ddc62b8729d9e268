// Pressure at a point, as SPH pressure gauges measure it (DualSPHysics' MeasureTool, the SPHERIC benchmarks'
// gauges): the flow particles' pressures kernel-interpolated and Shepard-normalised,
//   p(x) = sum_j p_j V_j W(x - x_j) / sum_j V_j W(x - x_j),   V_j = m_j / rho_j,
// flow particles only (a wall particle's pressure is the wall model's, not the flow's). Where the
// denominator, the kernel-interpolated fluid fraction, is under wet_kernel_sum the point is dry: the
// normalisation would blow a lone splash particle's pressure up to a reading, so the probe reports 0.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "../ordered_sum.hpp"
#include "monitor_types.hpp"
#include "runout/engine/eos.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::monitor_detail {
namespace {

template <int D>
class PressureProbe final : public Monitor<D> {
 public:
  PressureProbe(const MonitorSpec& spec, const Solver<D>& s) : Monitor<D>(spec.name), wet_(spec.number("wet_kernel_sum")) {
    if (spec.probe_points.size() != 1)
      throw std::invalid_argument("monitor '" + spec.name + "': a pressure probe needs exactly one point");
    point_ = probe_point<D>(spec, 0);
    // Each particle's pressure from its density, as the force loop computes it (the equation of state and the
    // material's tension floor): always the current state, whatever re-sorting or removal happened since the
    // last force evaluation, and defined before the first step.
    for (const auto& m : s.materials()) {
      eos_.emplace_back(s.config().speed_of_sound, m.density, s.config().eos_gamma);
      p_min_.push_back(-make_rheology(m)->tensile_strength());
    }
  }

  std::vector<std::string> columns() const override { return {"pressure_pa", "kernel_sum", "wet"}; }

  std::vector<real> sample(const Solver<D>& s) override {
    const auto& cfg = s.config();
    const auto& f = s.fluid();
    const real support = 2.0 * cfg.smoothing_length;
    const Vec<D> x = point_;
    const TaitEOS* eos = eos_.data();
    const real* p_min = p_min_.data();
    std::array<real, 2> sums{};  // volume, pressure-weighted volume; repeat to the bit (ordered_sum.hpp)
    with_kernel<D>(cfg.kernel, cfg.smoothing_length, [&](auto kernel) {
      sums = ordered_sums<2>(f.size(), [&](size_t j, std::array<real, 2>& s) {
        bool near = true;  // box test first: most particles are far
        for (int d = 0; d < D; ++d) near = near && std::abs(f.pos[d][j] - x[d]) < support;
        if (!near || Solver<D>::is_inlet_buffer(f.tag[j])) return;
        const real w = kernel.W((f.position(j) - x).norm());
        if (w <= 0) return;
        const int k = f.material[j];
        const real vw = f.mass[j] / f.rho[j] * w;
        s[0] += vw;
        s[1] += std::max(eos[k].pressure(f.rho[j]), p_min[k]) * vw;
      });
    });
    const real volume = sums[0], weighted = sums[1];
    const bool wet = volume >= wet_;
    const real p = wet ? weighted / volume : 0.0;
    const real t = s.time();
    ++samples_;
    if (wet) {
      if (arrival_ < 0) arrival_ = t;
      ++wet_samples_;
      sum_p_ += p;
      if (p > peak_ || peak_time_ < 0) peak_ = p, peak_time_ = t;
    }
    return {p, volume, wet ? 1.0 : 0.0};
  }

  std::vector<std::pair<std::string, real>> summary() const override {
    return {{"peak_pressure_pa", peak_},
            {"time_of_peak_s", peak_time_},
            {"mean_wet_pressure_pa", wet_samples_ ? sum_p_ / wet_samples_ : 0.0},
            {"arrival_time_s", arrival_},
            {"wet_fraction", samples_ ? static_cast<real>(wet_samples_) / samples_ : 0.0}};
  }

  void save_state(StateWriter& out) const override {
    out.label("pressure_probe:" + this->name());
    out.value(samples_), out.value(wet_samples_);
    out.value(peak_), out.value(peak_time_), out.value(sum_p_), out.value(arrival_);
  }

  void load_state(StateReader& in) override {
    in.expect("pressure_probe:" + this->name());
    in.value(samples_), in.value(wet_samples_);
    in.value(peak_), in.value(peak_time_), in.value(sum_p_), in.value(arrival_);
  }

 private:
  Vec<D> point_;
  real wet_;
  std::vector<TaitEOS> eos_;  // by material
  std::vector<real> p_min_;   // by material
  long samples_ = 0, wet_samples_ = 0;
  real peak_ = 0, peak_time_ = -1, sum_p_ = 0, arrival_ = -1;
};

// On terrain [x, y] map coordinates and an optional height above the bed there (default h); elsewhere the
// scene's own coordinates, the vertical last.
void read_pressure_probe(const MonitorInput& in, MonitorSpec& spec) {
  const FieldSpec& key = field_spec(pressure_probe_type().fields, "point");
  std::array<real, 3> p{0, 0, 0};
  if (in.on_terrain()) {
    const auto c = in.coordinates(key, {2, 3});
    const real height = c.size() == 3 ? c[2] : in.smoothing_length();
    if (height < 0)
      in.refuse(in.at(key.key) + "[2]", "the height above the bed must be at least 0 m (got " + fmt(height) + ")");
    p = {c[0] - in.origin()[0], c[1] - in.origin()[1], 0.0};
    p[2] = in.bed_under(in.at(key.key), p[0], p[1]) + height;
  } else {
    const auto c = in.coordinates(key, {static_cast<size_t>(in.dimensions())});
    for (int d = 0; d < in.dimensions(); ++d) p[d] = c[d];
  }
  in.check_in_domain(in.at(key.key), p, true);
  spec.probe_points = {p};
}

}  // namespace

ParameterSpec point_component() {
  return {"point", "m", 0.0, -1e7, 1e7, false, false, false, "a coordinate of the point"};
}

FieldSpec wet_kernel_sum_field(real lo, bool lo_open, real hi, bool hi_open, const std::string& doc) {
  return number_field({"wet_kernel_sum", "", 0.5, lo, hi, lo_open, hi_open, false, doc});
}

const MonitorType& pressure_probe_type() {
  static const MonitorType type = [] {
    FieldSpec point = shaped_field(
        "point", "vector",
        "the probe: [x, y] in 2D, [x, y, z] in 3D; on terrain [x, y] map coordinates and z, optional, the height "
        "above the bed there (default h)");
    point.parameters = {point_component()};
    return monitor_type_of<PressureProbe>(
        "pressure_probe",
        "pressure at a point: the flow particles' pressures kernel-interpolated and Shepard-normalised, 0 where dry",
        {point, wet_kernel_sum_field(0.0, true, 1.0, false,
                                     "kernel-interpolated fluid fraction sum V W under which the point is dry "
                                     "(reported as 0)")},
        read_pressure_probe);
  }();
  return type;
}

}  // namespace runout::monitor_detail
