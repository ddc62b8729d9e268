// The terrain, release, structures and protected_zones sections (docs/scene-format.md, "Terrain scenes").
// Structure types come from terrain's registry (structure_types()): their keys, ranges and docs.
#include "readers.hpp"

#include <algorithm>

namespace runout::scene_reader {
namespace {

using terrain::StructureSpec;
using terrain::StructureType;

using terrain::ShapeKind;

// A declared number of a section.
real number_of(const Fields& f, const std::vector<FieldSpec>& fields, const std::string& key) {
  return read_parameter(f, field_spec(fields, key).parameters.front());
}

// A declared geometry of a section: polygons (several parts, holes) or a line, as its field says.
terrain::Polyline shape_of(const Fields& f, const std::vector<FieldSpec>& fields, const std::string& key,
                           const ShapeSource& src) {
  const FieldSpec& field = field_spec(fields, key);
  return read_shape(f.raw(key), f.at(key), field.min_points,
                    field.min_points < 3 ? ShapeKind::line : ShapeKind::multipolygon, src);
}

void read_corridor(const Fields& t, terrain::CorridorSpec& corridor, const ShapeSource& src) {
  const auto& fields = corridor_fields();
  Fields c(t.raw("corridor"), "terrain.corridor", field_keys(fields));
  corridor.travel_angle_deg = number_of(c, fields, "travel_angle");
  corridor.buffer_m = number_of(c, fields, "buffer");
  if (c.has("polygon")) corridor.polygon = shape_of(c, fields, "polygon", src);
  corridor.max_outflow = number_of(c, fields, "max_outflow");
}

void read_terrain_section(const json& j, const std::filesystem::path& base_dir, terrain::TerrainSpec& spec,
                          ShapeSource& src) {
  const auto& fields = terrain_fields();
  Fields t(j.at("terrain"), "terrain", field_keys(fields));
  if (t.has("walls")) t.string("walls", terrain_wall_choices());
  std::filesystem::path dem = t.string("dem");
  if (dem.is_relative() && !base_dir.empty()) dem = base_dir / dem;
  spec.dem_path = dem.string();
  spec.dem.target_crs = t.string_or("crs", "");
  spec.dem.resolution = number_of(t, fields, "resolution");
  spec.layers = static_cast<int>(number_of(t, fields, "layers"));
  src.base_dir = base_dir;
  src.working_crs = [path = spec.dem_path, options = spec.dem, wkt = std::make_shared<std::string>()]() {
    if (wkt->empty()) *wkt = terrain::working_crs_wkt(path, options);  // the DEM's header, once
    return *wkt;
  };
  if (t.has("corridor")) read_corridor(t, spec.corridor, src);
}

void read_release(const json& j, terrain::ReleaseSpec& release, const ShapeSource& src) {
  if (!j.contains("release"))
    throw SceneError("release", "missing (required in a terrain scene: polygon, depth or volume, material; or a hydrograph)");
  const auto& fields = release_fields();
  Fields r(j.at("release"), "release", field_keys(fields));
  if (r.has("hydrograph")) {
    if (r.has("polygon") || r.has("depth") || r.has("volume"))
      throw SceneError("release", "give either a hydrograph or a polygon with depth or volume, not both");
    Fields h(r.raw("hydrograph"), "release.hydrograph", field_keys(hydrograph_fields()));
    release.inflow_line = shape_of(h, hydrograph_fields(), "line", src);
    release.depth = number_of(h, hydrograph_fields(), "depth");
    return;
  }
  release.polygon = shape_of(r, fields, "polygon", src);
  if (r.has("depth") == r.has("volume"))
    throw SceneError("release", "give exactly one of depth (" + field_spec(fields, "depth").parameters.front().range_text() +
                                    ") or volume (" + field_spec(fields, "volume").parameters.front().range_text() + ")");
  release.depth = number_of(r, fields, "depth");
  release.volume = number_of(r, fields, "volume");
}

// A structure's geometry: an axis is one line, an area one ring (a deposition area's plane and a basin's
// walls on its edges have no meaning for holes or several parts).
terrain::Polyline read_line(const Fields& f, const FieldSpec& field, const ShapeSource& src) {
  return read_shape(f.raw(field.key), f.at(field.key), field.min_points,
                    field.min_points < 3 ? ShapeKind::line : ShapeKind::polygon, src);
}

// Indices of the geometry's edges (edge k joins vertex k to vertex k+1).
std::vector<int> read_edge_indices(const Fields& f, const std::string& key, size_t vertices) {
  const json& oe = f.raw(key);
  if (!oe.is_array()) throw SceneError(f.at(key), "must be an array of edge indices");
  std::vector<int> edges;
  for (size_t q = 0; q < oe.size(); ++q) {
    const std::string ef = f.at(key) + "[" + std::to_string(q) + "]";
    if (!oe[q].is_number_integer() || oe[q].get<long>() < 0 || oe[q].get<long>() >= static_cast<long>(vertices))
      throw SceneError(ef, "must be an edge index in [0, " + std::to_string(vertices - 1) +
                               "] (edge k joins vertex k to vertex k+1)");
    edges.push_back(oe[q].get<int>());
  }
  return edges;
}

// The keys a structure type declares into its StructureSpec, by their shapes; then its rules across keys.
void read_structure_fields(const Fields& f, const StructureType& type, StructureSpec& st, const ShapeSource& src) {
  for (const FieldSpec& field : type.fields) {
    if (field.shape == "polyline") {
      st.line = read_line(f, field, src);
    } else if (field.shape == "number") {
      const ParameterSpec& p = field.parameters.front();
      if (field.default_text.empty() || f.has(p.key)) st.numbers[p.key] = read_parameter(f, p);
    } else if (field.shape == "object") {
      if (!f.has(field.key)) continue;
      std::set<std::string> members;
      for (const auto& p : field.parameters) members.insert(p.key);
      Fields o(f.raw(field.key), f.at(field.key), members);
      for (const auto& p : field.parameters) st.numbers[field.key + "." + p.key] = read_parameter(o, p);
    } else if (field.shape == "indices") {
      if (f.has(field.key)) st.indices[field.key] = read_edge_indices(f, field.key, st.line.size());
    } else {
      throw std::logic_error("structure field '" + field.key + "' of a shape the scene reader does not read");
    }
  }
  if (const auto problem = type.check(st))
    throw SceneError(problem->key.empty() ? f.path() : f.at(problem->key), problem->message);
}

// Keys of an object describing one of `types` (each type's fields, and "type" and "name").
template <class Types>
std::set<std::string> keys_of(const Types& types) {
  std::set<std::string> keys = {"type", "name"};
  for (const auto* t : types)
    for (const auto& f : t->fields) keys.insert(f.key);
  return keys;
}

StructureSpec read_structure(const json& s, const std::string& path, std::set<std::string>& names,
                             const ShapeSource& src) {
  std::vector<std::string> type_names;
  for (const auto* t : terrain::structure_types()) type_names.push_back(t->name);
  const StructureType& type =
      terrain::structure_type(Fields(s, path, keys_of(terrain::structure_types())).string("type", type_names));
  Fields f(s, path, keys_of(std::vector<const StructureType*>{&type}));
  StructureSpec st;
  st.name = f.string("name");
  if (!names.insert(st.name).second) throw SceneError(f.at("name"), "duplicate structure name '" + st.name + "'");
  st.type = &type;
  read_structure_fields(f, type, st, src);
  return st;
}

void read_structures(const json& j, std::vector<StructureSpec>& out, const ShapeSource& src) {
  if (!j.contains("structures")) return;
  const json& ss = j.at("structures");
  if (!ss.is_array()) throw SceneError("structures", "must be an array of structures");
  std::set<std::string> names;
  for (size_t k = 0; k < ss.size(); ++k) out.push_back(read_structure(ss[k], item("structures", k), names, src));
}

void read_protected_zones(const json& j, std::vector<terrain::ProtectedZone>& out, const ShapeSource& src) {
  if (!j.contains("protected_zones")) return;
  const json& zs = j.at("protected_zones");
  if (!zs.is_array()) throw SceneError("protected_zones", "must be an array of {name, polygon}");
  for (size_t k = 0; k < zs.size(); ++k) {
    Fields z(zs[k], item("protected_zones", k), field_keys(protected_zone_fields()));
    out.push_back({z.string("name"), shape_of(z, protected_zone_fields(), "polygon", src)});
  }
}

}  // namespace

terrain::TerrainSpec parse_terrain_spec(const json& j, const std::filesystem::path& base_dir) {
  terrain::TerrainSpec spec;
  ShapeSource src;
  read_terrain_section(j, base_dir, spec, src);
  read_release(j, spec.release, src);
  read_structures(j, spec.structures, src);
  read_protected_zones(j, spec.protected_zones, src);
  return spec;
}

// Terrain: built first (it validates the DEM, release and structures), its release joins the fluid (a
// hydrograph release becomes an inlet: inlets.cpp).
template <int D>
void read_terrain(Build<D>& b) {
  for (const char* key : {"release", "structures", "protected_zones"})
    if (b.top.has(key) && !b.top.has("terrain")) throw SceneError(key, "needs a terrain section");
  if (!b.top.has("terrain")) return;
  if (D != 3) throw SceneError("dimensions", "a terrain scene must have dimensions = 3");
  terrain::TerrainSpec spec = parse_terrain_spec(b.j, b.base_dir);
  spec.release.inflow_length = kInflowStripLayers * b.dp;
  b.release_material = Fields(b.j.at("release"), "release", field_keys(release_fields())).string("material");
  if (!b.material_index.count(b.release_material))
    throw SceneError("release.material", "no material named '" + b.release_material + "'");
  const Fields t(b.j.at("terrain"), "terrain", {}, true);
  b.walls_near_flow = !t.has("walls") || t.string("walls") == "near_flow";
  try {
    b.tmodel = std::make_shared<terrain::TerrainModel>(terrain::build_terrain(spec, b.dp, b.scene.max_particles));
  } catch (const terrain::TerrainError& e) {
    const std::string what = e.what();
    throw SceneError(e.field, what.substr(std::min(what.size(), e.field.size() + 2)));
  }
}

template void read_terrain<2>(Build<2>&);
template void read_terrain<3>(Build<3>&);

}  // namespace runout::scene_reader
