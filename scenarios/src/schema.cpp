#include "runout/scenarios/schema.hpp"

#include <nlohmann/json.hpp>
#include <algorithm>
#include <sstream>

#include "runout/engine/kernels.hpp"
#include "runout/engine/monitors.hpp"
#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/hazard.hpp"
#include "runout/terrain/terrain.hpp"
#include "scene/boundary_types.hpp"

namespace runout {
namespace {

using json = nlohmann::json;

json number_schema(const ParameterSpec& p) {
  json s = {{"type", "number"}, {"description", p.doc + (p.unit.empty() ? "" : " [" + p.unit + "]")}};
  if (std::isfinite(p.lo)) s[p.lo_open ? "exclusiveMinimum" : "minimum"] = p.lo;
  if (std::isfinite(p.hi)) s[p.hi_open ? "exclusiveMaximum" : "maximum"] = p.hi;
  if (!p.required) s["default"] = p.default_value;
  return s;
}

std::string dimensions_note(int dimensions) {
  return dimensions ? " (only in " + std::to_string(dimensions) + "D scenes)" : "";
}

json point_array(size_t min_points) {
  json point = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2}, {"maxItems", 2}};
  return {{"type", "array"}, {"items", point}, {"minItems", min_points}};
}

// {"layer", "name", "where", "crs"}: a feature of a vector file in place of a list of points.
json layer_ref_schema() {
  return {{"type", "object"},
          {"description", "features of an OGR vector layer (GeoPackage, GeoJSON, Shapefile, ...), reprojected to the "
                          "working CRS (docs/scene-format.md, \"Geometry from vector files\")"},
          {"properties",
           {{"layer", {{"type", "string"}, {"description", "the file, relative to the scene file"}}},
            {"name", {{"type", "string"}, {"description", "the layer; optional when the file has one layer"}}},
            {"where", {{"type", "string"}, {"description", "OGR SQL attribute filter, e.g. id = 'Dam1'"}}},
            {"crs", {{"type", "string"},
                     {"description", "the coordinates' CRS when the file has none (or to override it), e.g. EPSG:4326"}}}}},
          {"required", {"layer"}},
          {"additionalProperties", false}};
}

// One declared key: its JSON shape, range and doc (a computed default said in the description).
json field_schema(const FieldSpec& f) {
  json s;
  if (f.shape == "number") {
    s = number_schema(f.parameters.front());
    if (!f.default_text.empty()) s.erase("default");
  } else if (f.shape == "polyline") {  // a line or polygon in map coordinates: [x, y] points or a layer
    s = {{"anyOf", {point_array(f.min_points), layer_ref_schema()}}};
  } else if (f.shape == "vector") {
    json item = number_schema(f.parameters.front());
    item.erase("default");
    s = {{"type", "array"}, {"items", item}};
  } else if (f.shape == "object") {
    json props = json::object(), required = json::array();
    for (const auto& p : f.parameters) {
      props[p.key] = number_schema(p);
      if (p.required) required.push_back(p.key);
    }
    s = {{"type", "object"}, {"properties", props}, {"required", required}, {"additionalProperties", false}};
  } else if (f.shape == "indices") {
    s = {{"type", "array"}, {"items", {{"type", "integer"}, {"minimum", 0}}}};
  } else if (f.shape == "series") {  // a number, or [t, value] pairs
    json value = number_schema(f.parameters.front());
    value.erase("default");
    json pair = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2}, {"maxItems", 2}};
    s = {{"oneOf", {value, {{"type", "array"}, {"items", pair}, {"minItems", 1}}}}};
  } else if (f.shape == "faces") {
    s = {{"type", "array"}, {"items", {{"enum", {"x-", "x+", "y-", "y+", "z-", "z+", "top", "bottom"}}}}};
  } else {
    s = {{"type", f.shape}};
  }
  s["description"] = f.doc + dimensions_note(f.dimensions) +
                     (f.default_text.empty() ? "" : "; default: " + f.default_text);
  return s;
}

// A model chosen by "type": the type's name, a unique name, and its declared keys.
json typed_schema(const std::string& name, const std::string& doc, const std::vector<FieldSpec>& fields) {
  json props = {{"type", {{"const", name}, {"description", doc}}}, {"name", {{"type", "string"}}}};
  json required = {"type", "name"};
  for (const auto& f : fields) {
    props[f.key] = field_schema(f);
    if (f.required && f.dimensions == 0) required.push_back(f.key);
  }
  return {{"type", "object"}, {"properties", props}, {"required", required}, {"additionalProperties", false}};
}

// A section's declared keys as an object (the required ones required, no others).
json section_schema(const std::vector<FieldSpec>& fields) {
  json props = json::object(), required = json::array();
  for (const auto& f : fields) {
    props[f.key] = field_schema(f);
    if (f.required) required.push_back(f.key);
  }
  return {{"type", "object"}, {"properties", props}, {"required", required}, {"additionalProperties", false}};
}

json terrain_schema() {
  json s = section_schema(scene_reader::terrain_fields());
  s["properties"]["walls"]["enum"] = scene_reader::terrain_wall_choices();
  const std::string doc = s["properties"]["corridor"]["description"];
  s["properties"]["corridor"] = section_schema(scene_reader::corridor_fields());
  s["properties"]["corridor"]["description"] = doc;
  return s;
}

json release_schema() {
  json s = section_schema(scene_reader::release_fields());
  const std::string doc = s["properties"]["hydrograph"]["description"];
  s["properties"]["hydrograph"] = section_schema(scene_reader::hydrograph_fields());
  s["properties"]["hydrograph"]["description"] = doc;
  return s;
}

json protected_zones_schema() {
  return {{"type", "array"}, {"items", section_schema(scene_reader::protected_zone_fields())}};
}

json output_schema() {
  json props = json::object();
  for (const auto& f : scene_reader::output_fields()) props[f.key] = field_schema(f);
  return {{"type", "object"}, {"properties", props}, {"additionalProperties", false}};
}

json monitors_schema() {
  json alts = json::array();
  for (const auto* t : monitor_types()) alts.push_back(typed_schema(t->name, t->doc, t->fields));
  return {{"type", "array"}, {"items", {{"oneOf", alts}}}};
}

// A boundary is not named: it has a tag and a layer count besides its type's keys.
json boundaries_schema() {
  json alts = json::array();
  for (const auto* t : scene_reader::boundary_types()) {
    std::vector<FieldSpec> fields = scene_reader::boundary_common_fields();
    fields.insert(fields.end(), t->fields.begin(), t->fields.end());
    json alt = typed_schema(t->name, t->doc, fields);
    alt["properties"].erase("name");
    alt["required"].erase(std::find(alt["required"].begin(), alt["required"].end(), "name"));
    alts.push_back(alt);
  }
  return {{"type", "array"}, {"items", {{"oneOf", alts}}}};
}

json structures_schema() {
  json alts = json::array();
  for (const auto* t : terrain::structure_types()) alts.push_back(typed_schema(t->name, t->doc, t->fields));
  return {{"type", "array"}, {"items", {{"oneOf", alts}}}};
}

json numerics_schema() {
  json props = {{"kernel", {{"enum", kernel_names()}}},
                {"integrator", {{"enum", integrator_names()}}},
                {"density_diffusion", {{"enum", density_diffusion_names()}}},
                {"viscosity", {{"enum", viscous_step_names()}}},
                {"boundary_pressure", {{"enum", boundary_pressure_names()}}},
                {"density_floor", {{"type", "boolean"}}},
                {"particle_shifting", {{"enum", particle_shifting_names()}}}};
  // A default that depends on the scene (text with a ';') is stated in the description, not as "default".
  for (const auto& f : numerics_choice_fields()) {
    const bool conditional = f.default_text.find(';') != std::string::npos;
    props[f.key]["description"] = conditional ? f.doc + "; default: " + f.default_text : f.doc;
    if (!conditional) props[f.key]["default"] = f.default_text == "false" ? json(false) : json(f.default_text);
  }
  for (const auto& p : numerics_parameters()) {
    props[p.key] = number_schema(p);
    if (p.integer) props[p.key]["type"] = "integer";
  }
  props["max_dilatancy"].erase("default");
  props["max_dilatancy"]["description"] =
      props["max_dilatancy"]["description"].get<std::string>() + "; default: " +
      format_number(GranularDefaults::max_dilatancy) + " in a scene with a granular material, else 0";
  for (const auto& f : scene_numerics_fields()) props[f.key] = field_schema(f);
  props["viscosity_cap"] = {{"anyOf", {field_schema(field_spec(scene_numerics_fields(), "viscosity_cap")), {{"const", "auto"}}}}};
  return {{"type", "object"}, {"properties", props}, {"additionalProperties", false}};
}

json material_schema(const RheologyModel& m) {
  json props = {{"name", {{"type", "string"}}},
                {"rheology", {{"const", m.name}, {"description", m.doc}}},
                {"density", number_schema(material_density_spec())}};
  json required = {"name", "rheology", "density"};
  for (const auto& p : m.parameters) {
    props[p.key] = number_schema(p);
    if (p.required) required.push_back(p.key);
  }
  return {{"type", "object"}, {"properties", props}, {"required", required}, {"additionalProperties", false}};
}

}  // namespace

json scene_schema() {
  json materials = json::array();
  for (const auto* m : rheology_models()) materials.push_back(material_schema(*m));
  auto object = json{{"type", "object"}};
  auto array_of_objects = json{{"type", "array"}, {"items", object}};
  return {{"$schema", "https://json-schema.org/draft/2020-12/schema"},
          {"$id", "https://runout.example/schema/scene.json"},
          {"title", "Runout scene"},
          {"description", "docs/scene-format.md describes every field; the scene parser is the reference."},
          {"type", "object"},
          {"required", {"dimensions", "dp", "duration", "materials"}},
          {"properties",
           {{"name", {{"type", "string"}}},
            {"description", {{"type", "string"}}},
            {"dimensions", {{"enum", {2, 3}}}},
            {"dp", field_schema(field_spec(scene_reader::top_fields(), "dp"))},
            {"duration", field_schema(field_spec(scene_reader::top_fields(), "duration"))},
            {"gravity", {{"type", "array"}, {"items", {{"type", "number"}}}}},
            {"materials", {{"type", "array"}, {"minItems", 1}, {"maxItems", 16}, {"items", {{"oneOf", materials}}}}},
            {"numerics", numerics_schema()},
            {"fluid", array_of_objects},
            {"inlets", array_of_objects},
            {"boundaries", boundaries_schema()},
            {"domain", object},
            {"output", output_schema()},
            {"limits", object},
            {"monitors", monitors_schema()},
            {"terrain", terrain_schema()},
            {"release", release_schema()},
            {"structures", structures_schema()},
            {"protected_zones", protected_zones_schema()},
            {"fidelity", object},
            {"model", {{"enum", {"sph3d", "screening"}}}},
            {"screening", object}}}};
}

// "[0, 90)", "(0, 1e8]": a range as the docs write it.
std::string range_text(const ParameterSpec& p) {
  return std::string(p.lo_open ? "(" : "[") + format_number(p.lo) + ", " + format_number(p.hi) + (p.hi_open ? ")" : "]");
}

// Markdown table cells: a '|' (|gamma_dot|) would end the cell.
std::string cell(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string material_parameter_tables() {
  std::ostringstream s;
  for (const auto* m : rheology_models()) {
    s << "`" << m->name << "`: " << cell(m->doc) << ".\n\n";
    if (m->parameters.empty()) {
      s << "No parameters besides `density`.\n\n";
      continue;
    }
    s << "| field | default | unit | accepted | meaning |\n|---|---|---|---|---|\n";
    for (const auto& p : m->parameters) {
      const std::string range = range_text(p);
      s << "| `" << p.key << "` | " << (p.required ? std::string("**required**") : "`" + format_number(p.default_value) + "`")
        << " | " << (p.unit.empty() ? "–" : p.unit) << " | " << range << " | " << cell(p.doc) << " |\n";
    }
    s << "\n";
  }
  return s.str();
}

namespace {

std::string shape_text(const FieldSpec& f) {
  if (f.shape == "polyline") return "array of ≥ " + std::to_string(f.min_points) + " `[x, y]`, or a layer";
  if (f.shape == "vector") return "array of `dimensions` numbers";
  if (f.shape == "indices") return "array of integers";
  if (f.shape == "faces") return "array of face names";
  if (f.shape == "series") return "number or `[[t, value], …]`";
  if (f.shape == "number" && !f.parameters.empty() && f.parameters.front().integer) return "integer";
  return f.shape;
}

// One row per declared key (an object's members as `key.member`).
void field_rows(std::ostringstream& s, const FieldSpec& f) {
  const std::string dims = f.dimensions ? " (" + std::to_string(f.dimensions) + "D)" : "";
  std::string def = f.required ? "**required**" : f.default_text.empty() ? "–" : cell(f.default_text);
  std::string unit = "–", range = "–";
  if (f.shape == "number" || f.shape == "vector" || f.shape == "series") {
    const ParameterSpec& p = f.parameters.front();
    if (f.shape == "number" && !f.required && f.default_text.empty()) def = "`" + format_number(p.default_value) + "`";
    unit = p.unit.empty() ? "–" : p.unit;
    range = range_text(p);
  }
  s << "| `" << f.key << "`" << dims << " | " << shape_text(f) << " | " << def << " | " << unit << " | " << range
    << " | " << cell(f.doc) << " |\n";
  if (f.shape != "object") return;
  for (const auto& p : f.parameters)
    s << "| `" << f.key << "." << p.key << "` | number | "
      << (p.required ? std::string("**required**") : "`" + format_number(p.default_value) + "`") << " | "
      << (p.unit.empty() ? "–" : p.unit) << " | " << range_text(p) << " | " << cell(p.doc) << " |\n";
}

template <class Types>
std::string type_tables(const Types& types) {
  std::ostringstream s;
  for (const auto* t : types) {
    s << "`" << t->name << "`: " << cell(t->doc) << ".\n\n";
    s << "| field | shape | default | unit | accepted | meaning |\n|---|---|---|---|---|---|\n";
    for (const auto& f : t->fields) field_rows(s, f);
    s << "\n";
  }
  return s.str();
}

}  // namespace

std::string monitor_type_tables() { return type_tables(monitor_types()); }

std::string output_field_table() {
  std::ostringstream s;
  s << "| field | shape | default | unit | accepted | meaning |\n|---|---|---|---|---|---|\n";
  for (const auto& f : scene_reader::output_fields()) field_rows(s, f);
  return s.str();
}
std::string structure_type_tables() { return type_tables(terrain::structure_types()); }

std::string terrain_field_tables() {
  const std::pair<const char*, const std::vector<FieldSpec>*> sections[] = {
      {"terrain", &scene_reader::terrain_fields()},
      {"terrain.corridor", &scene_reader::corridor_fields()},
      {"release", &scene_reader::release_fields()},
      {"release.hydrograph", &scene_reader::hydrograph_fields()},
      {"protected_zones[k]", &scene_reader::protected_zone_fields()}};
  std::ostringstream s;
  for (const auto& [name, fields] : sections) {
    s << "`" << name << "`:\n\n| field | shape | default | unit | accepted | meaning |\n|---|---|---|---|---|---|\n";
    for (const auto& f : *fields) field_rows(s, f);
    s << "\n";
  }
  return s.str();
}

std::string boundary_type_tables() {
  std::ostringstream s;
  s << "Every boundary:\n\n| field | shape | default | unit | accepted | meaning |\n|---|---|---|---|---|---|\n";
  s << "| `type` | string | **required** | – | ";
  for (const auto* t : scene_reader::boundary_types()) s << "`" << t->name << "`" << (t == scene_reader::boundary_types().back() ? "" : ", ");
  s << " | the boundary type (below) |\n";
  for (const auto& f : scene_reader::boundary_common_fields()) field_rows(s, f);
  return s.str() + "\n" + type_tables(scene_reader::boundary_types());
}

}  // namespace runout
