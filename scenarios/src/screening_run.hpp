#pragma once
// The screening rung (docs/design.md, "The screening rung"): a terrain scene run with the thickness-integrated
// SPH model (runout/engine/depth_averaged.hpp) instead of the 3D solver, on the same terrain (the DEM over the
// corridor, the structures built into it), writing the same outputs where they mean the same.
// A scene selects it with "model": "screening" (`runout run/sweep --fidelity screening` sets it); its numbers
// come from the scene's "screening" section (docs/scene-format.md, "The screening rung").
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "runout/engine/depth_averaged.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace runout {

// The models a scene's "model" key accepts; the first is the default.
const std::vector<std::string>& scene_model_names();

// The screening section as resolved: declared defaults filled in, every field checked.
struct ScreeningSettings {
  real spacing = 0;             // [m] particles' initial plan spacing; default: the scene's dp
  real smoothing_ratio = 1.5;   // h_k0 / spacing at and above reference_spacing
  real reference_spacing = 0.5; // [m] the spacing the ratio holds at (the validated dam break's coarsest)
  std::string kernel_rule = "sqrt";  // "sqrt": h_k0 = ratio spacing (reference / spacing)^1/2 below it; "fixed"
  real earth_pressure = 1.0;
  std::string earth_pressure_rule = "isotropic";  // or "savage_hutter" (engine Config::savage_hutter)
  real internal_friction_angle = 0;  // [deg] phi, with savage_hutter; delta is atan of the friction law's mu
  real cfl = 0.2;
  real dt_max = 0.1;            // [s]
  real output_interval = 0.1;   // [s] between samples of the inundation grid and the rest test
  bool curvature = true;        // the bend's centripetal load in the basal normal stress (engine Config)
  std::string friction;         // "coulomb" or "voellmy" (depth_averaged::friction_models())
  ParameterValues friction_parameters;
  std::string friction_source;  // "material '<name>' (sin phi)" or "screening.friction"
  std::string release_material;
  real density = 0;             // [kg/m^3] the release material's bulk density
  // h_k0 / spacing by the kernel rule.
  real kernel_ratio() const;
  // The engine's settings for a bed of gravity g.
  depth_averaged::Config config(real gravity) const;
};

// Throws SceneError naming the field and its accepted range. `scene` holds the parsed terrain scene (materials,
// dp, output); `scene_json` is the scene as given.
ScreeningSettings screening_settings(const nlohmann::json& scene_json, const Scene& scene);

// Whether the scene runs the screening model (its "model" key).
bool is_screening(const Scene& scene);

// Checks a scene's "model" and "screening" at parse time (parse_scene): SceneError for a bad value, for a
// screening model on a scene that is not a terrain scene, or for what the screening model does not run
// (fluid blocks, inlets, extra boundaries), each naming its field.
void check_scene_model(const nlohmann::json& scene_json, const Scene& scene);

// What the screening run starts with: a block release's particles (its lattice at `spacing` inside
// release.polygon), or for a hydrograph none, and the volume each particle of its inflow carries.
struct ScreeningParticles {
  size_t release = 0;
  double inflow_particle_volume = 0;  // [m3]; 0 for a block release
};
ScreeningParticles screening_particles(const nlohmann::json& scene_json, const terrain::TerrainModel& tm, real spacing);

// Runs a screening scene and writes OUT/metrics.json, OUT/series/run.csv and OUT/rasters as run_scene does.
RunSummary run_screening(const Scene& scene, const RunOptions& options);

}  // namespace runout
