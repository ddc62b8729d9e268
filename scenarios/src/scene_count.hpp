#pragma once
// A scene built to be priced, not run (estimate_scene, cost_model.hpp).
#include "runout/scenarios/scene.hpp"

namespace runout {

// build_scene's terrain, checks and refusals (the particle limit included), with the 3D particles counted
// (Scene::counts) and not made: no particle arrays, no bed laid. What it returns cannot run.
Scene count_scene(const SceneSpec& spec);

}  // namespace runout
