// The scene parser: parse_scene reads the run settings, then build<D> calls one reader per section
// (scenarios/src/scene/, readers.hpp) in an order where each finds what it needs from the ones before.
#include "runout/scenarios/scene.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "scene/readers.hpp"
#include "scene_count.hpp"
#include "screening_run.hpp"

namespace runout {
namespace {

using namespace scene_reader;

// Fidelity presets used by sweeps (scenarios/sweep.hpp); a plain run is "standard".
void check_fidelity(const Fields& top, real dp) {
  Fields fid(top.raw("fidelity"), "fidelity", {"draft", "standard", "fine", "screening"});
  for (const char* level : {"draft", "standard", "fine", "screening"}) {
    if (!fid.has(level)) continue;
    Fields p(fid.raw(level), fid.at(level), {"dp", "numerics"});
    (void)p.number_or("dp", dp, 1e-4, 100.0);
    if (p.has("numerics") && !p.raw("numerics").is_object())
      throw SceneError(p.at("numerics"), "must be an object of numerics fields");
  }
}

template <int D>
Scene build(const json& j, Scene scene, const std::filesystem::path& base_dir, Make make) {
  Build<D> b(j, scene, base_dir);
  b.make = make;
  read_gravity(b);
  read_materials(b);
  read_limits(b);
  read_terrain(b);
  read_fluid(b);
  read_inlets(b);
  read_boundaries(b);
  check_fluid_placement(b);
  read_numerics(b);
  make_particles(b);
  read_domain(b);
  read_monitors(b);
  scene.terrain = std::move(b.tmodel);
  scene.setup = std::move(b.setup);
  return scene;
}

}  // namespace

SceneSpec read_scene(const json& j, const std::filesystem::path& base_dir) {
  if (!j.is_object()) throw SceneError("(root)", "a scene must be a JSON object");
  Fields top(j, "", top_keys(), /*partial=*/true);  // an unknown key is listed by check_declared_fields
  SceneSpec spec;
  spec.name = top.string_or("name", "scene");
  (void)top.string_or("description", "");
  spec.dimensions = static_cast<int>(top.integer("dimensions", 0, 2, 3));
  if (!top.has("dimensions")) throw SceneError("dimensions", "missing (required: 2 or 3)");
  check_declared_fields(j, spec.dimensions);
  spec.dp = read_parameter(top, field_spec(top_fields(), "dp").parameters.front());
  if (top.has("fidelity")) check_fidelity(top, spec.dp);
  spec.duration = read_parameter(top, field_spec(top_fields(), "duration").parameters.front());
  spec.output = read_output(j, spec.duration);
  spec.model = top.string_or("model", scene_model_names().front(), scene_model_names());
  spec.document = std::make_shared<const json>(j);
  spec.base_dir = base_dir;
  return spec;
}

namespace {

Scene build_as(const SceneSpec& spec, bool count_only) {
  const json& j = *spec.document;
  Scene scene;
  scene.name = spec.name;
  scene.dimensions = spec.dimensions;
  scene.dp = spec.dp;
  scene.duration = spec.duration;
  scene.output = spec.output;
  scene.canonical_json = j.dump();
  scene.document = spec.document;
  const Make make = spec.model == "screening" ? Make::nothing : count_only ? Make::counts : Make::particles;
  scene = scene.dimensions == 2 ? build<2>(j, std::move(scene), spec.base_dir, make)
                                : build<3>(j, std::move(scene), spec.base_dir, make);
  check_scene_model(j, scene);  // "model" and "screening" (screening_scene.cpp)
  return scene;
}

}  // namespace

Scene build_scene(const SceneSpec& spec) { return build_as(spec, false); }

Scene count_scene(const SceneSpec& spec) { return build_as(spec, true); }

json parse_scene_document(const std::string& json_text) {
  try {
    return json::parse(json_text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for numbers beyond a double (1e400)
    throw SceneError("(json)", std::string("malformed JSON: ") + e.what());
  }
}

Scene parse_scene(const std::string& json_text, const std::filesystem::path& base_dir) {
  return build_scene(read_scene(parse_scene_document(json_text), base_dir));
}

Scene load_scene(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw SceneError("(file)", "cannot read scene file '" + path.string() + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), path.parent_path());
}

}  // namespace runout
