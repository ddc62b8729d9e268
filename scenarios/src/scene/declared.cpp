// Every error of a scene's declared fields at once, before anything is built: each key of the sections whose
// keys are declared (the top level, materials, boundaries, fluid blocks, inlets, domain, limits, output,
// numerics, monitors, and the terrain scene's sections) is checked on its own, so
// one refusal lists them all and costs no terrain build. The section readers read the same keys again, with the
// scene's defaults and the rules across keys, when the scene is built.
#include "boundary_types.hpp"
#include "readers.hpp"
#include "runout/engine/kernels.hpp"
#include "runout/engine/rheology.hpp"

namespace runout::scene_reader {
namespace {

using Errors = std::vector<std::pair<std::string, std::string>>;

// Runs a check; the SceneError it throws is recorded as {field, message}.
struct Collect {
  Errors& out;
  template <class Check>
  bool operator()(Check&& check) const {
    try {
      check();
      return true;
    } catch (const SceneError& e) {
      const std::string what = e.what();
      out.emplace_back(e.field, what.substr(std::min(what.size(), e.field.size() + 2)));
      return false;
    }
  }
};

bool in_dimension(const FieldSpec& f, int D) { return f.dimensions == 0 || f.dimensions == D; }

// The keys of object `o` at `path`, each on its own (an unknown one refused as Fields refuses it; `extra` are
// accepted too), then each declared number and object of numbers.
void check_section(const Collect& c, const json& o, const std::string& path, const std::vector<FieldSpec>& fields,
                   int D, std::set<std::string> keys = {}) {
  for (const auto& f : fields)
    if (in_dimension(f, D)) keys.insert(f.key);
  if (!o.is_object()) {
    c([&] { Fields(o, path, keys); });
    return;
  }
  for (auto it = o.begin(); it != o.end(); ++it) c([&] { Fields(json{{it.key(), it.value()}}, path, keys); });
  const Fields f(o, path, keys, true);
  for (const auto& field : fields) {
    if (!in_dimension(field, D)) continue;
    if (field.shape == "number") c([&] { (void)read_parameter(f, field.parameters.front()); });
    if (field.shape != "object" || field.parameters.empty() || !f.has(field.key)) continue;
    std::vector<FieldSpec> members;
    for (const auto& p : field.parameters) members.push_back(number_field(p));
    check_section(c, f.raw(field.key), f.at(field.key), members, D);
  }
}

void check_numerics(const Collect& c, const json& j, int D) {
  if (!j.contains("numerics")) return;
  std::vector<FieldSpec> fields;
  for (const auto& p : numerics_parameters()) fields.push_back(number_field(p));
  std::set<std::string> keys;
  for (const auto& f : scene_numerics_fields()) {
    keys.insert(f.key);
    if (f.key != "viscosity_cap") fields.push_back(f);  // "auto" or a number: checked below
  }
  for (const auto& f : numerics_choice_fields()) keys.insert(f.key);
  const json& n = j["numerics"];
  check_section(c, n, "numerics", fields, D, keys);
  if (!n.is_object()) return;
  const Fields num(n, "numerics", {}, true);
  SolverConfig scratch;
  c([&] {
    if (!num.has("viscosity_cap")) return;
    const json& cap = num.raw("viscosity_cap");
    const ParameterSpec& p = field_spec(scene_numerics_fields(), "viscosity_cap").parameters.front();
    if (cap.is_string()) Fields::check_choice(num.at("viscosity_cap"), cap.get<std::string>(), {"auto"});
    else (void)Fields::check_number(cap, num.at("viscosity_cap"), p.lo, p.hi, p.lo_open, p.hi_open);
  });
  const std::pair<const char*, std::vector<std::string>> choices[] = {
      {"kernel", kernel_names()},
      {"integrator", integrator_names()},
      {"density_diffusion", density_diffusion_names()},
      {"viscosity", viscous_step_names()},
      {"boundary_pressure", boundary_pressure_names()},
      {"particle_shifting", particle_shifting_names()}};
  for (const auto& choice : choices) c([&] { (void)num.string_or(choice.first, "", choice.second); });
  c([&] { (void)num.boolean_or("density_floor", false); });
}

void check_monitors(const Collect& c, const json& j, int D) {
  if (!j.contains("monitors") || j["monitors"].is_null()) return;
  const json& ms = j["monitors"];
  if (!c([&] {
        if (!ms.is_array()) throw SceneError("monitors", "must be an array of monitors");
      }))
    return;
  std::vector<std::string> type_names;
  for (const auto* t : monitor_types()) type_names.push_back(t->name);
  std::set<std::string> names;
  for (size_t k = 0; k < ms.size(); ++k) {
    const std::string path = item("monitors", k);
    const MonitorType* type = nullptr;
    if (!c([&] { type = &monitor_type(Fields(ms[k], path, monitor_keys(monitor_types(), 0)).string("type", type_names)); }))
      continue;
    check_section(c, ms[k], path, type->fields, D, {"type", "name"});
    c([&] {
      const Fields f(ms[k], path, {}, true);
      const std::string name = f.string("name");
      if (!names.insert(name).second) throw SceneError(f.at("name"), "duplicate monitor name '" + name + "'");
    });
  }
}

// Each material: its name and rheology, then the density and the rheology's own parameters (declared by the
// model, engine/src/rheology/; a required one missing is refused as the reader words it); names unique. Rules
// across a model's parameters (make_rheology) are the reader's.
void check_materials(const Collect& c, const json& j) {
  if (!j.contains("materials")) return;  // the reader says it is missing
  const json& ms = j["materials"];
  if (!c([&] {
        if (!ms.is_array() || ms.empty() || ms.size() > 16)
          throw SceneError("materials", "must be an array of 1 to 16 materials");
      }))
    return;
  std::set<std::string> names;
  for (size_t k = 0; k < ms.size(); ++k) {
    const std::string path = item("materials", k);
    const RheologyModel* model = nullptr;
    if (!c([&] {
          if (!ms[k].is_object()) throw SceneError(path, "must be a JSON object");
          const Fields head(ms[k], path, {"name", "rheology"}, true);
          const std::string name = head.string("name");
          if (!names.insert(name).second) throw SceneError(head.at("name"), "duplicate material name '" + name + "'");
          model = &rheology_model(head.string("rheology", rheology_names()));
        }))
      continue;
    std::vector<FieldSpec> fields = {number_field(material_density_spec())};
    std::set<std::string> keys = {"name", "rheology"};
    for (const auto& p : model->parameters) {
      keys.insert(p.key);
      if (ms[k].contains(p.key) || !p.required) fields.push_back(number_field(p));
    }
    check_section(c, ms[k], path, fields, 0, keys);
    for (const auto& p : model->parameters)  // as the reader words it: the rheology and the range
      if (p.required && !ms[k].contains(p.key))
        c([&] {
          throw SceneError(path + "." + p.key,
                           "missing (required for rheology '" + model->name + "', in " + p.range_text() + ")");
        });
  }
}

// Each boundary: its type, then the keys every boundary has and its type's own.
void check_boundaries(const Collect& c, const json& j, int D) {
  if (!j.contains("boundaries")) return;
  const json& bs = j["boundaries"];
  if (!c([&] {
        if (!bs.is_array()) throw SceneError("boundaries", "must be an array of boundary objects");
      }))
    return;
  std::vector<std::string> names;
  for (const auto* t : boundary_types()) names.push_back(t->name);
  for (size_t k = 0; k < bs.size(); ++k) {
    const std::string path = item("boundaries", k);
    const BoundaryType* type = nullptr;
    if (!c([&] {
          if (!bs[k].is_object()) throw SceneError(path, "must be a JSON object");
          const std::string name = Fields(bs[k], path, {"type"}, true).string("type", names);
          type = &find_model(boundary_types(), name, "boundary type");
        }))
      continue;
    std::vector<FieldSpec> fields = boundary_common_fields();
    fields.insert(fields.end(), type->fields.begin(), type->fields.end());
    check_section(c, bs[k], path, fields, D, {"type"});
  }
}

void check_terrain_sections(const Collect& c, const json& j) {
  if (j.contains("terrain")) {
    check_section(c, j["terrain"], "terrain", terrain_fields(), 3);
    if (j["terrain"].is_object()) {
      const Fields t(j["terrain"], "terrain", {}, true);
      c([&] { (void)t.string_or("walls", "", terrain_wall_choices()); });
      if (t.has("corridor")) check_section(c, t.raw("corridor"), "terrain.corridor", corridor_fields(), 3);
    }
  }
  if (j.contains("release")) {
    check_section(c, j["release"], "release", release_fields(), 3);
    if (j["release"].is_object() && j["release"].contains("hydrograph"))
      check_section(c, j["release"]["hydrograph"], "release.hydrograph", hydrograph_fields(), 3);
  }
  if (j.contains("protected_zones") && j["protected_zones"].is_array())
    for (size_t k = 0; k < j["protected_zones"].size(); ++k)
      check_section(c, j["protected_zones"][k], item("protected_zones", k), protected_zone_fields(), 3);
}

// The sections whose keys are plain lists (fluid blocks, inlets, the domain, the limits): each key on its own.
void check_listed_sections(const Collect& c, const json& j, int D) {
  for (const auto& [key, keys] : {std::pair{"fluid", &fluid_block_keys()}, std::pair{"inlets", &inlet_keys()}})
    if (j.contains(key) && j[key].is_array())  // an array of the wrong shape: its reader says so
      for (size_t k = 0; k < j[key].size(); ++k) check_section(c, j[key][k], item(key, k), {}, D, *keys);
  for (const auto& [key, keys] : {std::pair{"domain", &domain_keys()}, std::pair{"limits", &limits_keys()}})
    if (j.contains(key)) check_section(c, j[key], key, {}, D, *keys);
}

}  // namespace

void check_declared_fields(const json& j, int D) {
  Errors errors;
  const Collect c{errors};
  check_section(c, j, "", top_fields(), D, top_keys());  // each top-level key, then dp and duration
  check_materials(c, j);
  check_boundaries(c, j, D);
  check_listed_sections(c, j, D);
  if (j.contains("output")) check_section(c, j["output"], "output", output_fields(), D);
  check_numerics(c, j, D);
  check_monitors(c, j, D);
  check_terrain_sections(c, j);
  if (errors.empty()) return;
  SceneError first(errors.front().first, errors.front().second);
  first.errors = std::move(errors);
  throw first;
}

}  // namespace runout::scene_reader
