#pragma once
// The predicted cost of one run of a sweep, used to hand out the runs of a distributed sweep largest first
// (mpi_sweep.cpp) so that the longest run does not start last: the calibrated cost model's run time
// (runout/scenarios/cost_model.hpp, docs/tradeoff.md) on one thread.
#include <filesystem>
#include <string>

namespace runout::service {

// Seconds on one thread of the resolved scene (JSON text). Builds the scene (parse_scene), so it throws
// SceneError for a scene that would be refused anyway.
double predicted_run_cost(const std::string& resolved_json, const std::filesystem::path& base_dir);

}  // namespace runout::service
