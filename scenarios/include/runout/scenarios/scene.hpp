#pragma once
// The scene format (JSON): materials, numerics, fluid blocks, boundary objects, domain and output.
// docs/scene-format.md describes every field. Parsing validates everything before any particle is made:
// a bad scene throws SceneError naming the field (a JSON path) and the accepted range.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "runout/engine/solver.hpp"

namespace runout {

struct SceneError : std::invalid_argument {
  std::string field;
  SceneError(std::string field_path, const std::string& message)
      : std::invalid_argument(field_path + ": " + message), field(std::move(field_path)) {}
};

struct OutputSettings {
  real series_interval = 0.01;    // [s] of simulated time between rows of series/run.csv
  real snapshot_interval = 0.0;   // [s]; 0 = only when snapshots are requested, then 20 over the run
};

// A parsed, validated scene: run settings plus the engine setup for its dimension.
struct Scene {
  std::string name;
  int dimensions = 2;
  real duration = 1.0;
  real dp = 0.01;
  long max_particles = 5'000'000;
  OutputSettings output;
  std::vector<std::string> boundary_tags;  // tag index -> name (index 0 unused)
  std::variant<SceneSetup<2>, SceneSetup<3>> setup;
  // The scene as given (canonical JSON text), kept for manifests.
  std::string canonical_json;
};

Scene parse_scene(const std::string& json_text);
Scene load_scene(const std::filesystem::path& path);

}  // namespace runout
