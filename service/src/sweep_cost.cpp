// The predicted cost of a run (sweep_cost.hpp).
#include "sweep_cost.hpp"

#include <nlohmann/json.hpp>

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/scene.hpp"

namespace runout::service {

double predicted_run_cost(const std::string& resolved_json, const std::filesystem::path& base_dir) {
  const SceneEstimate e = estimate_scene(read_scene(parse_scene_document(resolved_json), base_dir));
  return CostModel::calibrated().predict(e.cost, 1).seconds;
}

}  // namespace runout::service
