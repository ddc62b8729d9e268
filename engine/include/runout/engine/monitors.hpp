#pragma once
// Monitors: what a run measures while it runs. One small interface; each kind is one class plus one line in
// monitor_registry(), chosen by name from the scene. Monitors read the solver's state through its public
// accessors after a step; none of them touches the force loops.
#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "runout/engine/parameters.hpp"
#include "runout/engine/solver.hpp"
#include "runout/engine/state_io.hpp"

namespace runout {

// What a scene says about one monitor (already validated by the scene layer; positions in the run's frame).
struct MonitorSpec {
  std::string type;  // a key of monitor_registry()
  std::string name;
  // section: the gauge line in plan, (x, y) per point (3D); in 2D one point whose x is the section.
  std::vector<std::array<real, 2>> points;
  // pressure_probe, depth_gauge, face_pressure: positions in the run's frame, the vertical last ((x, y, z) in 3D,
  // (x, y, unused) in 2D). pressure_probe: its one point; depth_gauge: each station's foot, the floor or bed it
  // measures from; face_pressure: the sensor's centre on the structure's face.
  std::vector<std::array<real, 3>> probe_points;
  // depth_gauge along a line: each station's distance along it [m] (empty for a gauge at one point).
  std::vector<real> probe_stations;
  // pressure_probe, depth_gauge: the kernel sum sum_j V_j W (the interpolated fluid fraction) at or above which
  // a point is wet.
  real wet_kernel_sum = 0.5;
  // section: the flow volume that must have passed for the front to have arrived [m3, or m2 in 2D];
  // 0 = 0.5% of the fluid volume at the start.
  real arrival_volume = 0.0;
  // structure_load, face_pressure: the boundary tag of the structure, and the direction the flow pushes it (unit
  // vector, components beyond the dimension ignored); structure_load: a zero normal reports the force's magnitude.
  uint32_t tag = 0;
  std::array<real, 3> normal{0, 0, 0};
  // section and structure_load: the averaging window of the reported discharge or load [s]; structure_load: the
  // least wetted area a mean pressure is taken over [m2, m in 2D]; 0 = derived from the flow or the structure
  // (engine/src/monitors/section.cpp, structure_load.cpp, load_filter.hpp).
  real window = 0;
  real min_wetted_area = 0;
};

template <int D>
class Monitor {
 public:
  explicit Monitor(std::string name) : name_(std::move(name)) {}
  virtual ~Monitor() = default;
  const std::string& name() const { return name_; }
  // Columns this monitor adds to its time series (the time column is the caller's).
  virtual std::vector<std::string> columns() const = 0;
  // After every step (cheap bookkeeping, e.g. particles crossing a section).
  virtual void after_step(const Solver<D>&) {}
  // One row of the time series, at the caller's sample times.
  virtual std::vector<real> sample(const Solver<D>& solver) = 0;
  // The reduced metrics (name -> value, SI units in the name's suffix).
  virtual std::vector<std::pair<std::string, real>> summary() const = 0;
  // The running state, for a checkpoint: load_state on a monitor made from the same spec, on a solver that was
  // itself restored to the saved state, continues exactly as the saved one would have.
  virtual void save_state(StateWriter& out) const = 0;
  virtual void load_state(StateReader& in) = 0;

 private:
  std::string name_;
};

template <int D>
using MonitorFactory = std::function<std::unique_ptr<Monitor<D>>(const MonitorSpec&, const Solver<D>&)>;

// A monitor type as a scene names it: its name, one line of doc, its keys (geometry and numbers, each declared
// once: the scene parser, `runout schema` and docs/scene-format.md read them) and its factories. One
// descriptor per type beside its class (src/monitors/*.cpp), listed once in monitor_types() (src/monitors.cpp).
struct MonitorType {
  std::string name;
  std::string doc;
  std::vector<FieldSpec> fields;  // besides "type" and "name"
  MonitorFactory<2> make_2d;
  MonitorFactory<3> make_3d;
};
const std::vector<const MonitorType*>& monitor_types();
// Throws std::invalid_argument for an unknown name.
const MonitorType& monitor_type(const std::string& name);

// Monitor types by name (from monitor_types()): "section" (cross-section gauge), "structure_load" (force and
// pressure on a tagged structure), "pressure_probe" (pressure at a point), "depth_gauge" (flow depth at a
// point or along a line).
template <int D>
const std::map<std::string, MonitorFactory<D>>& monitor_registry();

// Throws std::invalid_argument naming the monitor for an unknown type or a spec it cannot use.
template <int D>
std::unique_ptr<Monitor<D>> make_monitor(const MonitorSpec& spec, const Solver<D>& solver);

}  // namespace runout
