#pragma once
// A terrain run's hazard maps (docs/terrain.md, "Hazard outputs"): OUT/rasters/*.tif with band description,
// unit, nodata and the run's metadata, a QGIS style (.qml) beside each, and hazard.gpkg with the inundated
// area and the intensity classes as polygons. Private to scenarios (run.cpp writes them).
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout {

// What every raster of a run says about the run.
struct RunLabel {
  std::string scene;
  double dp = 0.0;
  double simulated_time = 0.0;  // [s] at the end of the run
  std::string status;           // completed, failed, stopped
};

// Writes the rasters, styles and polygons into `rasters_dir`; returns the metrics they add to
// terrain.inundation (max h v, max pressure, the area of each intensity class, the files).
nlohmann::json write_hazard_outputs(const terrain::InundationGrid& g, const OutputSettings& out,
                                    const std::filesystem::path& rasters_dir, const RunLabel& label);

// The rasters the sweep's difference maps are made of (relative to a run's folder) and their units.
struct DifferenceRaster {
  const char* name;  // "max_depth", "max_hv"
  const char* unit;
  const char* description;
};
const std::vector<DifferenceRaster>& difference_rasters();

}  // namespace runout
