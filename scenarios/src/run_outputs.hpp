#pragma once
// The pieces of a terrain run's output (run.cpp) another rung's run writes the same way: the screening run
// (screening_run.cpp) reports its rasters, structures and zones through these, so the two rungs' metrics.json
// keys mean the same.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"
#include "hazard_outputs.hpp"

namespace runout::run_outputs {

// Writes to a temporary name and renames, so a killed run never leaves a half-written file.
void write_file_atomically(const std::filesystem::path& path, const std::string& text);

// OUT/rasters and metrics.json's terrain section (inundation, runout, structures, protected zones), from the
// inundation grid and the flow at the end (local positions, volumes).
nlohmann::json terrain_outputs(const terrain::TerrainModel& tm, const terrain::InundationGrid& g,
                               const OutputSettings& out, const std::filesystem::path& dir,
                               const std::vector<Vec<3>>& final_pos, const std::vector<real>& final_vol,
                               const RunLabel& label);

}  // namespace runout::run_outputs
