// The monitors section: gauges and loads by name, their types and keys from the engine's monitor_types().
// On terrain every walled structure gets a load monitor anyway.
#include "readers.hpp"

#include <algorithm>

namespace runout::scene_reader {
namespace {

// The keys a monitor of `types` accepts in a scene of dimension D (0: whatever the dimension).
std::set<std::string> monitor_keys(const std::vector<const MonitorType*>& types, int D) {
  std::set<std::string> keys = {"type", "name"};
  for (const auto* t : types)
    for (const auto& f : t->fields)
      if (D == 0 || f.dimensions == 0 || f.dimensions == D) keys.insert(f.key);
  return keys;
}

template <int D>
void read_section(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  if constexpr (D == 3) {
    const real ox = b.tmodel ? b.tmodel->origin_x : 0.0, oy = b.tmodel ? b.tmodel->origin_y : 0.0;
    const FieldSpec& line = field_spec(type.fields, "line");
    ShapeSource src{b.base_dir, {}};
    if (b.tmodel) src.working_crs = [&b] { return b.tmodel->dem.crs_wkt; };
    for (const auto& p : read_shape(f.raw(line.key), f.at(line.key), line.min_points, terrain::ShapeKind::line, src))
      spec.points.push_back({p[0] - ox, p[1] - oy});
  } else {
    spec.points.push_back({read_parameter(f, field_spec(type.fields, "x").parameters.front()), 0.0});
  }
  spec.arrival_volume = read_parameter(f, field_spec(type.fields, "arrival_volume").parameters.front());
  spec.window = read_parameter(f, field_spec(type.fields, "window").parameters.front());
}

template <int D>
void read_normal(const Fields& f, const ParameterSpec& component, MonitorSpec& spec) {
  const auto n = f.vector("normal", D, component.lo, component.hi);
  real n2 = 0;
  for (int d = 0; d < D; ++d) spec.normal[d] = n[d], n2 += n[d] * n[d];
  if (!(n2 > 1e-12)) throw SceneError(f.at("normal"), "must not be zero");
}

// The boundary tag a monitor's "structure" names.
template <int D>
uint32_t read_structure_tag(const Build<D>& b, const Fields& f) {
  const std::vector<std::string>& tags = b.scene.boundary_tags;
  const std::string target = f.string("structure");
  auto it = std::find(tags.begin() + 1, tags.end(), target);
  if (it == tags.end())
    throw SceneError(f.at("structure"), "no boundary or structure named '" + target +
                                            "' (named: " + Fields::join({tags.begin() + 1, tags.end()}) + ")");
  return static_cast<uint32_t>(it - tags.begin());
}

template <int D>
void read_structure_load(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  spec.tag = read_structure_tag(b, f);
  const std::string target = f.string("structure");
  if (f.has("normal")) {
    read_normal<D>(f, field_spec(type.fields, "normal").parameters.front(), spec);
  } else if (b.tmodel) {
    for (const auto& st : b.tmodel->structures)
      if (st.name == target) spec.normal = {st.flow_normal[0], st.flow_normal[1], 0.0};
  }
  spec.window = read_parameter(f, field_spec(type.fields, "window").parameters.front());
  spec.min_wetted_area = read_parameter(f, field_spec(type.fields, "min_wetted_area").parameters.front());
}

// face_pressure: a structure, a point on its face (the run's frame) and the face's normal.
template <int D>
void read_face_pressure(const Build<D>& b, const Fields& f, const MonitorType& type, MonitorSpec& spec) {
  spec.tag = read_structure_tag(b, f);
  read_face_point(b, f, type, spec);
  read_normal<D>(f, field_spec(type.fields, "normal").parameters.front(), spec);
}

// The scene side of each monitor type: its keys into a MonitorSpec (positions in the run's frame).
template <int D>
using MonitorReader = void (*)(const Build<D>&, const Fields&, const MonitorType&, MonitorSpec&);
template <int D>
MonitorReader<D> monitor_reader(const std::string& type) {
  static const std::map<std::string, MonitorReader<D>> readers = {
      {"section", read_section<D>},
      {"structure_load", read_structure_load<D>},
      {"pressure_probe", read_pressure_probe<D>},
      {"depth_gauge", read_depth_gauge<D>},
      {"face_pressure", read_face_pressure<D>},
  };
  const auto it = readers.find(type);
  if (it == readers.end()) throw std::logic_error("monitor type '" + type + "' has no scene reader");
  return it->second;
}

template <int D>
MonitorSpec read_monitor(const Build<D>& b, const json& m, const std::string& path, std::set<std::string>& names) {
  std::vector<std::string> type_names;
  for (const auto* t : monitor_types()) type_names.push_back(t->name);
  MonitorSpec spec;
  spec.type = Fields(m, path, monitor_keys(monitor_types(), 0)).string("type", type_names);
  const MonitorType& type = monitor_type(spec.type);
  Fields f(m, path, monitor_keys({&type}, D));
  spec.name = f.string("name");
  if (!names.insert(spec.name).second) throw SceneError(f.at("name"), "duplicate monitor name '" + spec.name + "'");
  monitor_reader<D>(spec.type)(b, f, type, spec);
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
