#pragma once
// What a scene document names outside itself and what a layout picks from it, for callers that handle scenes
// as documents (the service's requests, `runout tradeoff`) and should not know the scene format's keys.
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace runout {

// A field of a scene that names a file it reads: terrain.dem and every vector layer reference's "layer"
// (docs/scene-format.md), wherever it stands; `field` is prefixed with `path` ("scene.terrain.dem").
struct SceneFileField {
  std::string field;
  const nlohmann::json* value;  // into the scene passed in
};
std::vector<SceneFileField> scene_file_fields(const nlohmann::json& scene, const std::string& path);

// The names of a scene's structures, in order: the candidates a layout picks from (entries without a string
// name are left out; the scene validator names them).
std::vector<std::string> structure_names(const nlohmann::json& scene);

// The shapes resolve_variant reads, checked so that it cannot throw on a wrong type before the scene validator
// runs: structures and monitors arrays of objects whose name, type and structure are strings, numerics an
// object, fidelity an object of {dp, numerics} objects. Throws SceneError naming the field (prefixed with path).
void check_scene_shapes(const nlohmann::json& scene, const std::string& path);

// Puts a particle budget into the scene's limits.max_particles where it is tighter than the scene's own limit
// (kDefaultMaxParticles where the scene sets none), so that the validator refuses a scene over it before building;
// true when it did. A limits section of the wrong shape is left as it is, for the validator to refuse.
bool apply_particle_budget(nlohmann::json& scene, long budget);

}  // namespace runout
