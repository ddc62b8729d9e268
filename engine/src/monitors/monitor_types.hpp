#pragma once
// What the monitor sources share (engine-internal): the descriptor maker, the descriptors each source defines
// for monitor_types(), and the keys the point probes share.
#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>
#include <unordered_set>
#include <string>
#include <utility>
#include <vector>

#include "runout/engine/kernels.hpp"
#include "runout/engine/monitors.hpp"

namespace runout::monitor_detail {

// A monitor type whose class M<D> is built from (spec, solver) in 2D and 3D.
template <template <int> class M>
MonitorType monitor_type_of(std::string name, std::string doc, std::vector<FieldSpec> fields,
                            void (*read)(const MonitorInput&, MonitorSpec&)) {
  return {std::move(name), std::move(doc), std::move(fields), read,
          [](const MonitorSpec& s, const Solver<2>& v) { return std::make_unique<M<2>>(s, v); },
          [](const MonitorSpec& s, const Solver<3>& v) { return std::make_unique<M<3>>(s, v); }};
}

// A footprint counted in particle spacings: the distinct dp x dp cells (dp cells along `a` alone when `b` is
// not given) of the points added. The section's release depth and the structure load's wetted face use it.
class CellCount {
 public:
  explicit CellCount(real dp) : dp_(dp) {}
  void add(real a, real b = 0) {
    const auto cell = [this](real x) { return static_cast<int64_t>(std::floor(x / dp_)) + (int64_t(1) << 30); };
    cells_.insert((cell(a) << 32) + cell(b));
  }
  size_t size() const { return cells_.size(); }

 private:
  real dp_;
  std::unordered_set<int64_t> cells_;
};

// Descriptors defined in their own sources (function-local statics: monitor_types() may be asked before
// another source's globals are built).
const MonitorType& section_type();         // monitors/section.cpp
const MonitorType& structure_load_type();  // monitors/structure_load.cpp
const MonitorType& pressure_probe_type();  // monitors/pressure_probe.cpp
const MonitorType& face_pressure_type();   // monitors/face_pressure.cpp
const MonitorType& depth_gauge_type();     // monitors/depth_gauge.cpp

// The keys the probes share, declared once (monitors/pressure_probe.cpp).
ParameterSpec point_component();           // one coordinate of a `point` [m]
FieldSpec wet_kernel_sum_field(real lo, bool lo_open, real hi, bool hi_open, const std::string& doc);

// A number in a refusal, printed as the scene parser prints them (ostream's default: 6 significant digits).
inline std::string fmt(real v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A "vector" field of D components, not all zero (a face's or a load's normal), into spec.normal.
void read_normal(const MonitorInput& in, const FieldSpec& key, MonitorSpec& spec);  // monitors/structure_load.cpp

// A gauge point of a spec: its first D coordinates (the vertical last).
template <int D>
Vec<D> probe_point(const MonitorSpec& spec, size_t k) {
  Vec<D> p;
  for (int d = 0; d < D; ++d) p[d] = spec.probe_points.at(k)[d];
  return p;
}

}  // namespace runout::monitor_detail
