#pragma once
// The scene format (JSON): materials, numerics, fluid blocks, boundary objects, domain and output.
// docs/scene-format.md describes every field. Parsing validates everything before any particle is made:
// a bad scene throws SceneError naming the field (a JSON path) and the accepted range.
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "runout/engine/monitors.hpp"
#include "runout/engine/solver.hpp"
#include "runout/terrain/hazard.hpp"

namespace runout {
namespace terrain {
struct TerrainModel;
}

struct SceneError : std::invalid_argument {
  std::string field;
  // Every error, {field, message}, when several fields were checked together (the first is `field` and the
  // message of what()); empty when the parser stopped at this one.
  std::vector<std::pair<std::string, std::string>> errors;
  SceneError(std::string field_path, const std::string& message)
      : std::invalid_argument(field_path + ": " + message), field(std::move(field_path)) {}
};

struct OutputSettings {
  real series_interval = 0.01;    // [s] of simulated time between rows of series/run.csv
  real snapshot_interval = 0.0;   // [s]; 0 = only when snapshots are requested, then 20 over the run
  real inundation_threshold = 0.1; // [m] depth above which a terrain cell counts as inundated
  // The run may end before its duration once the flow is at rest: a share rest_quantile of the flow particles
  // (1: every one) slower than rest_speed for rest_time of simulated time. rest_speed 0: run the whole duration.
  real rest_speed = 0.0;     // [m/s]
  real rest_time = 1.0;      // [s]
  real rest_quantile = 1.0;  // [-], (0, 1]
  terrain::IntensityThresholds intensity;  // output.intensity: the intensity.tif classes (terrain/hazard.hpp)
};

// A parsed, validated scene: run settings plus the engine setup for its dimension.
// The 3D particles a scene starts with, as its build counts them (the same whether it makes them or prices the
// scene, estimate_scene): flow particles, walls alive from the start (a terrain's bed laid whole included), and
// the bed a terrain's wall source can lay near the flow. A screening scene counts none: its rung makes its own.
struct ParticleCounts {
  int64_t fluid = 0;
  int64_t walls = 0;
  int64_t bed = 0;
};

// A scene's particle limit where its limits section sets none.
constexpr long kDefaultMaxParticles = 5'000'000;

struct Scene {
  std::string name;
  int dimensions = 2;
  real duration = 1.0;
  real dp = 0.01;
  long max_particles = kDefaultMaxParticles;  // limits.max_particles
  OutputSettings output;
  std::vector<std::string> boundary_tags;  // tag index -> name (index 0 unused)
  std::vector<MonitorSpec> monitors;       // in the run's frame (terrain: local coordinates)
  std::variant<SceneSetup<2>, SceneSetup<3>> setup;
  ParticleCounts counts;
  // Terrain scenes: the built terrain (DEM, corridor, structures, zones), in the run's local frame.
  std::shared_ptr<const terrain::TerrainModel> terrain;
  // The scene as given (canonical JSON text), kept for manifests, and the same document as read, so that what
  // reads a scene's sections after the build (the screening rung, the cost features, checkpoints) parses nothing.
  std::string canonical_json;
  std::shared_ptr<const nlohmann::json> document;
};

// A scene read and checked without building anything: the run settings every caller needs (name, dimension,
// spacing, duration, output) and the document the builder reads its sections from. read_scene checks the
// whole document's declared fields (every key of the sections whose keys are declared, each number against
// its range; SceneError lists every error at once); what needs the terrain or the particles (a release off
// the DEM, a probe off the corridor, a rheology's rules across keys) is checked by build_scene.
struct SceneSpec {
  std::string name;
  int dimensions = 2;
  real dp = 0.01;
  real duration = 1.0;
  OutputSettings output;
  // The flow model that runs it ("model": sph3d, or screening). A screening scene is built without the 3D
  // particles (fluid, walls, the bed's wall source): its rung makes its own on the terrain's grid.
  std::string model = "sph3d";
  std::shared_ptr<const nlohmann::json> document;
  std::filesystem::path base_dir;  // relative file names in the scene (terrain.dem) resolve here
};

// The numbers of the numerics section whose defaults the scene computes (speed of sound, depth scale, viscosity
// cap, boundary density), declared once for the parser, the schema and docs/scene-format.md; the plain-number
// numerics are the engine's numerics_parameters().
const std::vector<FieldSpec>& scene_numerics_fields();
// The choices of the numerics section (kernel, integrator, density_diffusion, boundary_pressure, density_floor).
const std::vector<FieldSpec>& numerics_choice_fields();

// A scene with a granular material (a rheology with traits.granular) defaults to these numerics: a material
// that carries no tension drifts far under rho0 where it thins and clumps without the floor, and DBC walls
// build a pressure cushion under a thin frictional layer that stops it on a slope (docs/design.md,
// "Granular defaults"). The floor's dilatancy: loose against dense random packing. Shifting: a sheared layer
// opens voids its continuity density does not see, and its pressure then reads high ("Particle shifting").
struct GranularDefaults {
  static constexpr const char* boundary_pressure = "extrapolated";
  static constexpr bool density_floor = true;
  static constexpr double max_dilatancy = 0.1;
  static constexpr const char* particle_shifting = "fickian";
};

// A scene's JSON text parsed: malformed JSON (or a number beyond a double) is a SceneError on "(json)".
nlohmann::json parse_scene_document(const std::string& json_text);
// `base_dir` resolves relative file names in the scene (terrain.dem); load_scene uses the file's folder.
SceneSpec read_scene(const nlohmann::json& document, const std::filesystem::path& base_dir = {});
// The particles, the terrain and the engine setup of a read scene: what a run needs, built once.
Scene build_scene(const SceneSpec& spec);
// read_scene and build_scene of a JSON text (malformed JSON is a SceneError on "(json)").
Scene parse_scene(const std::string& json_text, const std::filesystem::path& base_dir = {});
Scene load_scene(const std::filesystem::path& path);

}  // namespace runout
