#include "runout/scenarios/schema.hpp"

#include <nlohmann/json.hpp>
#include <sstream>

#include "runout/engine/kernels.hpp"
#include "runout/engine/rheology.hpp"
#include "runout/engine/solver.hpp"

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
  json numerics_props = {{"kernel", {{"enum", kernel_names()}, {"default", kernel_names().front()}}},
                         {"integrator", {{"enum", integrator_names()}, {"default", "symplectic"}}},
                         {"density_diffusion", {{"enum", density_diffusion_names()}, {"default", "fourtakas"}}},
                         {"boundary_pressure", {{"enum", boundary_pressure_names()}}}};
  for (const auto& p : numerics_parameters()) {
    numerics_props[p.key] = number_schema(p);
    if (p.integer) numerics_props[p.key]["type"] = "integer";
  }
  json numerics = {{"type", "object"}, {"properties", numerics_props}};
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
            {"dp", {{"type", "number"}}},
            {"duration", {{"type", "number"}}},
            {"gravity", {{"type", "array"}, {"items", {{"type", "number"}}}}},
            {"materials", {{"type", "array"}, {"minItems", 1}, {"maxItems", 16}, {"items", {{"oneOf", materials}}}}},
            {"numerics", numerics},
            {"fluid", array_of_objects},
            {"inlets", array_of_objects},
            {"boundaries", array_of_objects},
            {"domain", object},
            {"output", object},
            {"limits", object},
            {"monitors", array_of_objects},
            {"terrain", object},
            {"release", object},
            {"structures", array_of_objects},
            {"protected_zones", array_of_objects},
            {"fidelity", object}}}};
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
      const std::string range = std::string(p.lo_open ? "(" : "[") + format_number(p.lo) + ", " +
                                format_number(p.hi) + (p.hi_open ? ")" : "]");
      s << "| `" << p.key << "` | " << (p.required ? std::string("**required**") : "`" + format_number(p.default_value) + "`")
        << " | " << (p.unit.empty() ? "–" : p.unit) << " | " << range << " | " << cell(p.doc) << " |\n";
    }
    s << "\n";
  }
  return s.str();
}

}  // namespace runout
