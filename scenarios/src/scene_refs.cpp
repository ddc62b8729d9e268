#include "runout/scenarios/scene_refs.hpp"

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"

namespace runout {
namespace {

using json = nlohmann::json;

std::string at(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

void layer_files(const json& j, const std::string& field, std::vector<SceneFileField>& out) {
  if (j.is_object()) {
    if (j.contains("layer")) out.push_back({field + ".layer", &j["layer"]});
    for (auto it = j.begin(); it != j.end(); ++it) layer_files(it.value(), at(field, it.key()), out);
  } else if (j.is_array()) {
    for (size_t k = 0; k < j.size(); ++k) layer_files(j[k], field + "[" + std::to_string(k) + "]", out);
  }
}

}  // namespace

std::vector<SceneFileField> scene_file_fields(const json& scene, const std::string& path) {
  std::vector<SceneFileField> out;
  if (scene.contains("terrain") && scene["terrain"].is_object() && scene["terrain"].contains("dem"))
    out.push_back({at(path, "terrain.dem"), &scene["terrain"]["dem"]});
  for (const char* key : {"terrain", "release", "structures", "protected_zones", "monitors"})
    if (scene.contains(key)) layer_files(scene[key], at(path, key), out);
  return out;
}

std::vector<std::string> structure_names(const json& scene) {
  std::vector<std::string> out;
  if (scene.contains("structures") && scene["structures"].is_array())
    for (const auto& s : scene["structures"])
      if (s.is_object() && s.contains("name") && s["name"].is_string()) out.push_back(s["name"].get<std::string>());
  return out;
}

void check_scene_shapes(const json& scene, const std::string& path) {
  for (const char* key : {"structures", "monitors"}) {
    if (!scene.contains(key)) continue;
    const json& a = scene[key];
    if (!a.is_array()) throw SceneError(at(path, key), "must be an array of objects");
    for (size_t k = 0; k < a.size(); ++k) {
      const std::string f = at(path, key) + "[" + std::to_string(k) + "]";
      if (!a[k].is_object()) throw SceneError(f, "must be an object");
      for (const char* name : {"name", "type", "structure"})
        if (a[k].contains(name) && !a[k][name].is_string()) throw SceneError(f + "." + name, "must be a string");
    }
  }
  if (scene.contains("numerics") && !scene["numerics"].is_object())
    throw SceneError(at(path, "numerics"), "must be an object of numerics fields");
  if (!scene.contains("fidelity")) return;
  const json& f = scene["fidelity"];
  if (!f.is_object()) throw SceneError(at(path, "fidelity"), "must be an object with draft, standard, fine presets");
  for (auto it = f.begin(); it != f.end(); ++it) {
    if (!it.value().is_object())
      throw SceneError(at(path, "fidelity") + "." + it.key(), "must be an object {dp, numerics}");
    if (it.value().contains("numerics") && !it.value()["numerics"].is_object())
      throw SceneError(at(path, "fidelity") + "." + it.key() + ".numerics", "must be an object of numerics fields");
  }
}

bool apply_particle_budget(json& scene, long budget) {
  long own = kDefaultMaxParticles;
  if (scene.contains("limits")) {
    const json& l = scene["limits"];
    if (!l.is_object()) return false;
    if (l.contains("max_particles")) {
      if (!l["max_particles"].is_number_integer()) return false;
      own = l["max_particles"].get<long>();
    }
  }
  if (budget >= own) return false;
  scene["limits"]["max_particles"] = budget;
  return true;
}

}  // namespace runout
