// The predicted cost of a run (sweep_cost.hpp).
#include "sweep_cost.hpp"

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/scene.hpp"

namespace runout::service {

double predicted_run_cost(const std::string& resolved_json, const std::filesystem::path& base_dir) {
  const Scene scene = parse_scene(resolved_json, base_dir);
  return CostModel::calibrated().predict(cost_features(scene), 1).seconds;
}

}  // namespace runout::service
