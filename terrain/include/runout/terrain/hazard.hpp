#pragma once
// Debris-flow intensity classes from the maximum flow depth h and the maximum h v of a run (docs/terrain.md,
// "Hazard outputs"). An inundated cell (h >= the inundation threshold) is high where h >= high_depth or
// h v >= high_hv, else medium where h >= medium_depth or h v >= medium_hv, else low; other cells none.
#include <string>
#include <vector>

#include "runout/engine/parameters.hpp"
#include "runout/terrain/raster.hpp"

namespace runout::terrain {

struct IntensityThresholds {
  double high_depth = 1.0;    // [m]
  double high_hv = 1.0;       // [m2/s]
  double medium_depth = 0.2;  // [m]
  double medium_hv = 0.2;     // [m2/s]
};

// The thresholds as the scene declares them (output.intensity): key, unit, default, range, doc; defaults
// those of IntensityThresholds.
const std::vector<ParameterSpec>& intensity_parameters();

enum IntensityClass : int { intensity_none = 0, intensity_low = 1, intensity_medium = 2, intensity_high = 3 };
// Labels of classes 1..3 ("low", "medium", "high").
const std::vector<std::string>& intensity_labels();

// Per cell of max_depth (max_hv on the same placement; NaN counts as 0).
Grid intensity_classes(const Grid& max_depth, const Grid& max_hv, const IntensityThresholds& t,
                       double inundation_threshold);

}  // namespace runout::terrain
