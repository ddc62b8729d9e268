// The monitors section: gauges and loads by name, their types and keys from the engine's monitor_types(). The
// scene checks the keys and reads each declared number; the type's own `read` (engine/src/monitors/) makes its
// geometry through SceneMonitorInput, which knows the run's frame: on terrain a point is [x, y] in map
// coordinates and its height comes from the bed under it; elsewhere it is in the scene's own coordinates, the
// vertical last. Every point must lie in the run's domain (the plan axes within it, the vertical above its
// bottom: the top is open), and on terrain over the modelled bed. On terrain every walled structure gets a load
// monitor anyway.
#include "readers.hpp"

#include <algorithm>
#include <cmath>

namespace runout::scene_reader {
namespace {

// One monitor's keys and the run's frame, as a monitor type's reader asks for them.
template <int D>
class SceneMonitorInput final : public MonitorInput {
 public:
  SceneMonitorInput(const Build<D>& b, const Fields& f) : b_(b), f_(f) {}

  int dimensions() const override { return D; }
  bool has(const std::string& key) const override { return f_.has(key); }
  std::string at(const std::string& key) const override { return f_.at(key); }
  [[noreturn]] void refuse(const std::string& field, const std::string& message) const override {
    throw SceneError(field, message);
  }
  std::string text(const std::string& key) const override { return f_.string(key); }
  std::vector<real> vector(const FieldSpec& key, int n) const override {
    const ParameterSpec& c = key.parameters.front();
    return f_.vector(key.key, n, c.lo, c.hi);
  }
  std::vector<real> coordinates(const FieldSpec& key, const std::vector<size_t>& lengths) const override {
    const ParameterSpec& c = key.parameters.front();
    const json& v = f_.raw(key.key);
    if (!v.is_array() || std::find(lengths.begin(), lengths.end(), v.size()) == lengths.end()) {
      std::string which;
      for (size_t n : lengths) which += (which.empty() ? "" : " or ") + std::to_string(n);
      throw SceneError(f_.at(key.key), "must be an array of " + which + " numbers (m)");
    }
    std::vector<real> out;
    for (size_t k = 0; k < v.size(); ++k)
      out.push_back(Fields::check_number(v[k], f_.at(key.key) + "[" + std::to_string(k) + "]", c.lo, c.hi, c.lo_open,
                                         c.hi_open));
    return out;
  }
  std::vector<std::array<real, 2>> line(const FieldSpec& key) const override {
    ShapeSource src{b_.base_dir, {}};
    if (b_.tmodel) src.working_crs = [this] { return b_.tmodel->dem->crs_wkt; };
    const std::array<real, 2> o = origin();
    std::vector<std::array<real, 2>> out;
    for (const auto& p : read_shape(f_.raw(key.key), f_.at(key.key), key.min_points, terrain::ShapeKind::line, src))
      out.push_back({p[0] - o[0], p[1] - o[1]});
    return out;
  }

  bool on_terrain() const override { return b_.tmodel != nullptr; }
  std::array<real, 2> origin() const override {
    return {b_.tmodel ? b_.tmodel->origin_x : 0.0, b_.tmodel ? b_.tmodel->origin_y : 0.0};
  }
  real bed_under(const std::string& field, real x, real y) const override {
    const double z = b_.tmodel->bed_at(x, y);
    if (std::isnan(z))
      throw SceneError(field, "(" + fmt(x + b_.tmodel->origin_x) + ", " + fmt(y + b_.tmodel->origin_y) +
                                  ") is off the modelled corridor: no bed under it");
    return z;
  }
  // The message gives the scene's coordinates (map ones on terrain).
  void check_in_domain(const std::string& field, const std::array<real, 3>& p, bool per_coordinate) const override {
    const std::array<real, 2> shift = origin();
    for (int d = 0; d < D; ++d) {
      const real lo = b_.cfg.domain_min[d], hi = b_.cfg.domain_max[d];
      const bool vertical = d == D - 1;
      if (p[d] >= lo && (vertical || p[d] <= hi)) continue;
      const real s = d < 2 ? shift[d] : 0.0;
      const std::string axis = std::string(1, "xyz"[d]);
      const std::string range = vertical ? "at least " + fmt(lo + s) : "in [" + fmt(lo + s) + ", " + fmt(hi + s) + "]";
      const bool name_coordinate = per_coordinate && !(b_.tmodel && vertical);  // terrain: the height is the bed's
      throw SceneError(name_coordinate ? field + "[" + std::to_string(d) + "]" : field,
                       axis + " must be " + range + " m, in the domain (got " + fmt(p[d] + s) + ")");
    }
  }
  uint32_t structure_tag(const std::string& key) const override {
    const std::vector<std::string>& tags = b_.scene.boundary_tags;
    const std::string target = f_.string(key);
    auto it = std::find(tags.begin() + 1, tags.end(), target);
    if (it == tags.end())
      throw SceneError(f_.at(key), "no boundary or structure named '" + target +
                                       "' (named: " + Fields::join({tags.begin() + 1, tags.end()}) + ")");
    return static_cast<uint32_t>(it - tags.begin());
  }
  std::array<real, 3> structure_normal(const std::string& name) const override {
    std::array<real, 3> n{0, 0, 0};
    if (b_.tmodel)
      for (const auto& st : b_.tmodel->structures)
        if (st.name == name) n = {st.flow_normal[0], st.flow_normal[1], 0.0};
    return n;
  }
  real dp() const override { return b_.dp; }
  real smoothing_length() const override { return b_.cfg.smoothing_length; }

 private:
  const Build<D>& b_;
  const Fields& f_;
};

// A monitor's type, keys, name and declared numbers: all of it but its geometry, which needs the run's frame.
MonitorSpec read_monitor_keys(const json& m, const std::string& path, int D, std::set<std::string>& names) {
  std::vector<std::string> type_names;
  for (const auto* t : monitor_types()) type_names.push_back(t->name);
  MonitorSpec spec;
  spec.type = Fields(m, path, monitor_keys(monitor_types(), 0)).string("type", type_names);
  const MonitorType& type = monitor_type(spec.type);
  Fields f(m, path, monitor_keys({&type}, D));
  spec.name = f.string("name");
  if (!names.insert(spec.name).second) throw SceneError(f.at("name"), "duplicate monitor name '" + spec.name + "'");
  for (const auto& field : type.fields)
    if (field.shape == "number" && (field.dimensions == 0 || field.dimensions == D))
      spec.numbers[field.key] = read_parameter(f, field.parameters.front());
  return spec;
}

template <int D>
MonitorSpec read_monitor(const Build<D>& b, const json& m, const std::string& path, std::set<std::string>& names) {
  MonitorSpec spec = read_monitor_keys(m, path, D, names);
  const MonitorType& type = monitor_type(spec.type);
  const Fields f(m, path, monitor_keys({&type}, D));
  type.read(SceneMonitorInput<D>(b, f), spec);
  return spec;
}

// A structure_load monitor for every walled terrain structure that no monitor covers or names.
template <int D>
void add_structure_loads(Build<D>& b, const std::set<std::string>& names) {
  for (const auto& st : b.tmodel->structures) {
    if (!st.tag) continue;
    bool covered = false;
    for (const auto& m : b.scene.monitors) covered = covered || (m.type == "structure_load" && m.tag == st.tag);
    if (covered || names.count(st.name)) continue;
    MonitorSpec spec;
    spec.type = "structure_load";
    spec.name = st.name;
    spec.tag = st.tag;
    spec.normal = {st.flow_normal[0], st.flow_normal[1], 0.0};
    b.scene.monitors.push_back(spec);
  }
}

}  // namespace

std::set<std::string> monitor_keys(const std::vector<const MonitorType*>& types, int D) {
  std::set<std::string> keys = {"type", "name"};
  for (const auto* t : types)
    for (const auto& f : t->fields)
      if (D == 0 || f.dimensions == 0 || f.dimensions == D) keys.insert(f.key);
  return keys;
}

template <int D>
void read_monitors(Build<D>& b) {
  std::set<std::string> names;
  if (b.top.has("monitors")) {
    const json& ms = b.top.raw("monitors");
    if (!ms.is_array()) throw SceneError("monitors", "must be an array of monitors");
    for (size_t k = 0; k < ms.size(); ++k) b.scene.monitors.push_back(read_monitor(b, ms[k], item("monitors", k), names));
  }
  if (b.tmodel) add_structure_loads(b, names);
}

template void read_monitors<2>(Build<2>&);
template void read_monitors<3>(Build<3>&);

}  // namespace runout::scene_reader
