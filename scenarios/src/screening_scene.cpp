// The scene's "model" key and "screening" section (docs/scene-format.md, "The screening rung"): read and
// checked at parse time, so a sweep refuses a bad screening field before anything runs.
#include <algorithm>
#include <cmath>

#include "runout/engine/rheology.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "scene/readers.hpp"
#include "screening_run.hpp"

namespace runout {
namespace {

using namespace scene_reader;

// The release material's bed friction: the 3D engine's bed coefficient (friction-HBP: sin phi, docs/design.md,
// "Thin sheets, walls and basal friction"), so the two rungs stop a block alike.
void material_friction(const Scene& scene, const std::string& name, ScreeningSettings& s) {
  const auto& materials = std::get<SceneSetup<3>>(scene.setup).materials;
  const auto it = std::find_if(materials.begin(), materials.end(), [&](const auto& m) { return m.name == name; });
  if (it == materials.end()) throw SceneError("release.material", "no material named '" + name + "'");
  s.density = it->density;
  if (!s.friction.empty()) return;
  const real mu = make_rheology(*it)->wall_friction_coefficient();
  if (!(mu > 0))
    throw SceneError("screening.friction", "material '" + name + "' (" + it->rheology +
                                               ") has no bed friction coefficient: give screening.friction "
                                               "{\"law\": \"coulomb\" or \"voellmy\", ...}");
  s.friction = "coulomb";
  s.friction_parameters = {{"mu", mu}};
  s.friction_source = "material '" + name + "' (" + it->rheology + ": sin phi)";
}

// screening.friction: {"law": NAME, and that law's parameters (ranges declared by the law)}.
void read_friction(const Fields& f, ScreeningSettings& s, real gravity) {
  if (!f.has("friction")) return;
  std::vector<std::string> laws;
  for (const auto* m : depth_averaged::friction_models()) laws.push_back(m->name);
  const std::string law = Fields(f.raw("friction"), f.at("friction"), {}, true).string("law", laws);
  std::set<std::string> keys = {"law"};
  for (const auto& p : depth_averaged::friction_model(law).parameters) keys.insert(p.key);
  Fields fr(f.raw("friction"), f.at("friction"), keys);
  for (const auto& p : depth_averaged::friction_model(law).parameters) s.friction_parameters[p.key] = read_parameter(fr, p);
  try {
    (void)depth_averaged::make_friction(law, s.friction_parameters, gravity, "screening.friction");
  } catch (const std::invalid_argument& e) {
    throw SceneError("screening.friction", e.what());
  }
  s.friction = law;
  s.friction_source = "screening.friction";
}

// screening.earth_pressure_rule: "isotropic" (k = earth_pressure) or "savage_hutter" (active and passive
// coefficients from internal_friction_angle, required then, and the bed's delta = atan mu of the friction law).
void read_earth_pressure_rule(const Fields& f, ScreeningSettings& s) {
  s.earth_pressure_rule = f.string_or("earth_pressure_rule", "isotropic", {"isotropic", "savage_hutter"});
  if (s.earth_pressure_rule != "savage_hutter") {
    if (f.has("internal_friction_angle"))
      throw SceneError("screening.internal_friction_angle", "is used with earth_pressure_rule \"savage_hutter\" only");
    return;
  }
  if (!f.has("internal_friction_angle"))
    throw SceneError("screening.internal_friction_angle",
                     "required with earth_pressure_rule \"savage_hutter\" (the material's internal friction angle, deg)");
  if (!s.friction_parameters.count("mu"))
    throw SceneError("screening.earth_pressure_rule",
                     "\"savage_hutter\" needs a friction law with a Coulomb part mu (coulomb, voellmy)");
  const real delta = std::atan(s.friction_parameters.at("mu")) * 180 / kPi;
  char lo[32];
  std::snprintf(lo, sizeof lo, "%.4g", delta);
  s.internal_friction_angle = f.number_or("internal_friction_angle", 0.0, 0.0, 90.0, false, true);
  if (s.internal_friction_angle < delta)
    throw SceneError("screening.internal_friction_angle",
                     "must be at least the bed friction angle atan(mu) = " + std::string(lo) +
                         " deg (accepted range [" + lo + ", 90))");
}

}  // namespace

const std::vector<std::string>& scene_model_names() {
  static const std::vector<std::string> names = {"sph3d", "screening"};
  return names;
}

real ScreeningSettings::kernel_ratio() const {
  if (kernel_rule == "fixed" || spacing >= reference_spacing) return smoothing_ratio;
  return smoothing_ratio * std::sqrt(reference_spacing / spacing);
}

depth_averaged::Config ScreeningSettings::config(real gravity) const {
  depth_averaged::Config c;
  c.gravity = gravity;
  c.earth_pressure = earth_pressure;
  c.savage_hutter = earth_pressure_rule == "savage_hutter";
  if (c.savage_hutter) {
    c.internal_friction_angle = internal_friction_angle;
    c.bed_friction_angle = std::atan(friction_parameters.at("mu")) * 180 / kPi;
  }
  c.spacing = spacing;
  c.smoothing_ratio = kernel_ratio();
  c.cfl = cfl;
  c.dt_max = dt_max;
  c.friction = friction;
  c.friction_parameters = friction_parameters;
  c.curvature = curvature;
  return c;
}

ScreeningSettings screening_settings(const json& j, const Scene& scene) {
  Fields f(j.contains("screening") ? j.at("screening") : json::object(), "screening",
           {"spacing", "smoothing_ratio", "reference_spacing", "kernel_rule", "earth_pressure", "earth_pressure_rule",
            "internal_friction_angle", "cfl", "dt_max", "output_interval", "friction", "curvature"});
  ScreeningSettings s;
  s.spacing = f.number_or("spacing", scene.dp, 1e-3, 100.0);
  const auto& engine = depth_averaged::config_parameters();  // the engine's declared ranges and defaults
  s.earth_pressure = read_parameter(f, parameter_spec(engine, "earth_pressure"));
  s.smoothing_ratio = read_parameter(f, parameter_spec(engine, "smoothing_ratio"));
  s.cfl = read_parameter(f, parameter_spec(engine, "cfl"));
  s.dt_max = read_parameter(f, parameter_spec(engine, "dt_max"));
  s.reference_spacing = f.number_or("reference_spacing", 0.5, 0.0, 100.0, true);
  s.kernel_rule = f.string_or("kernel_rule", "sqrt", {"sqrt", "fixed"});
  s.output_interval = f.number_or("output_interval", std::max<real>(0.1, scene.output.series_interval), 0.0, 1e4, true);
  s.curvature = f.boolean_or("curvature", true);
  const auto& g = std::get<SceneSetup<3>>(scene.setup).config.gravity;
  const real gravity = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  read_friction(f, s, gravity);
  s.release_material = Fields(j.at("release"), "release", {}, true).string("material");
  material_friction(scene, s.release_material, s);
  read_earth_pressure_rule(f, s);
  return s;
}

bool is_screening(const Scene& scene) {
  const json& j = *scene.document;
  return j.value("model", scene_model_names().front()) == "screening";
}

void check_scene_model(const json& j, const Scene& scene) {
  const Fields top(j, "", {}, true);
  const std::string model = top.string_or("model", scene_model_names().front(), scene_model_names());
  if (model != "screening") {  // a section a sweep's --fidelity screening would use is checked now
    if (top.has("screening") && !scene.terrain) throw SceneError("screening", "needs a terrain section");
    if (top.has("screening")) (void)screening_settings(j, scene);
    return;
  }
  if (!scene.terrain) throw SceneError("model", "'screening' runs terrain scenes only (a terrain section and a release)");
  for (const char* key : {"fluid", "inlets", "boundaries"})
    if (top.has(key) && !(top.raw(key).is_array() && top.raw(key).empty()))
      throw SceneError(key, "the screening model runs the terrain's release only (remove it, or run \"model\": \"sph3d\")");
  const ScreeningSettings s = screening_settings(j, scene);
  // The limit counts what runs: the rung's own particles (the release's lattice at its spacing, and what a
  // hydrograph brings over the run), not the 3D lattice the scene would make at dp.
  const double peak = cost_features(scene).fluid_peak;
  if (peak > static_cast<double>(scene.max_particles))
    throw SceneError("screening.spacing", "the screening rung makes about " + std::to_string(std::llround(peak)) +
                                              " particles at spacing " + fmt(s.spacing) +
                                              " m, over limits.max_particles = " + std::to_string(scene.max_particles) +
                                              " (raise screening.spacing or the limit)");
}

}  // namespace runout
