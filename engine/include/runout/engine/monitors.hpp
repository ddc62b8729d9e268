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

// What a scene says about one monitor, in the run's frame: where it measures (what its type's `read` made of
// the scene's geometry) and the numbers its type declares.
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
  // structure_load, face_pressure: the boundary tag of the structure, and the direction the flow pushes it (unit
  // vector, components beyond the dimension ignored); structure_load: a zero normal reports the force's magnitude.
  uint32_t tag = 0;
  std::array<real, 3> normal{0, 0, 0};
  // The numbers the type declares (its fields of shape "number": a window, a wet fraction, ...) as the scene
  // gave them, by key.
  ParameterValues numbers;
  // A declared number: as given, else the type's declared default. Throws std::invalid_argument for a key the
  // type does not declare.
  real number(const std::string& key) const;
};

// What a monitor type's `read` asks of the scene it is read from (the scene parser implements it): the keys of
// one monitor, already checked against the type's declared fields, and the run's frame (terrain scenes work in
// local coordinates: map minus origin). Every refusal names the field and the accepted range.
class MonitorInput {
 public:
  virtual ~MonitorInput() = default;
  virtual int dimensions() const = 0;
  virtual bool has(const std::string& key) const = 0;
  virtual std::string at(const std::string& key) const = 0;  // the field's path, for messages
  [[noreturn]] virtual void refuse(const std::string& field, const std::string& message) const = 0;
  virtual std::string text(const std::string& key) const = 0;
  // `key` (a "vector" field) as exactly n numbers, each in the range of the field's one parameter.
  virtual std::vector<real> vector(const FieldSpec& key, int n) const = 0;
  // `key` (a "vector" field of coordinates, m) as numbers in that range, of one of the accepted counts.
  virtual std::vector<real> coordinates(const FieldSpec& key, const std::vector<size_t>& lengths) const = 0;
  // `key` (a "polyline" field: points, or on terrain a vector layer's line) in plan, in the run's frame.
  virtual std::vector<std::array<real, 2>> line(const FieldSpec& key) const = 0;

  virtual bool on_terrain() const = 0;
  virtual std::array<real, 2> origin() const = 0;  // map coordinates of the run frame's origin (0 off terrain)
  // The bed's height under a plan point of the run's frame; refused (naming `field`) off the modelled corridor.
  virtual real bed_under(const std::string& field, real x, real y) const = 0;
  // Refuses a point of the run's frame outside the domain (the vertical's top is open); with `per_coordinate`
  // the message names the coordinate (field[1]).
  virtual void check_in_domain(const std::string& field, const std::array<real, 3>& p, bool per_coordinate) const = 0;
  // The boundary tag of the boundary or terrain structure `key` names; refused when none has that name.
  virtual uint32_t structure_tag(const std::string& key) const = 0;
  // A terrain structure's downstream normal in plan, {0, 0, 0} for another name or off terrain.
  virtual std::array<real, 3> structure_normal(const std::string& name) const = 0;
  virtual real dp() const = 0;
  virtual real smoothing_length() const = 0;
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
  // Reads the type's geometry (points, lines, the structure) into `spec`, in the run's frame; the scene parser
  // has put the declared numbers in spec.numbers before.
  void (*read)(const MonitorInput& in, MonitorSpec& spec) = nullptr;
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
