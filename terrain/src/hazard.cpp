// Debris-flow intensity classes (hazard.hpp) and their declared thresholds.
#include "runout/terrain/hazard.hpp"

#include <cmath>
#include <stdexcept>

namespace runout::terrain {

const std::vector<ParameterSpec>& intensity_parameters() {
  static const IntensityThresholds d;
  static const std::vector<ParameterSpec> specs = {
      {"high_depth", "m", d.high_depth, 0.0, 100.0, true, false, false,
       "high intensity where the max flow depth reaches this (or h v reaches high_hv)"},
      {"high_hv", "m2/s", d.high_hv, 0.0, 1000.0, true, false, false,
       "high intensity where the max of depth x speed reaches this (or h reaches high_depth)"},
      {"medium_depth", "m", d.medium_depth, 0.0, 100.0, true, false, false,
       "medium intensity where the max flow depth reaches this (below high_depth)"},
      {"medium_hv", "m2/s", d.medium_hv, 0.0, 1000.0, true, false, false,
       "medium intensity where the max of depth x speed reaches this (below high_hv)"},
  };
  return specs;
}

const std::vector<std::string>& intensity_labels() {
  static const std::vector<std::string> labels = {"low", "medium", "high"};
  return labels;
}

Grid intensity_classes(const Grid& max_depth, const Grid& max_hv, const IntensityThresholds& t,
                       double inundation_threshold) {
  if (max_hv.nx != max_depth.nx || max_hv.ny != max_depth.ny)
    throw std::invalid_argument("intensity_classes: max_hv and max_depth differ in size");
  Grid out = max_depth.like(0.0f);
  for (size_t c = 0; c < out.values.size(); ++c) {
    const double h = std::isnan(max_depth.values[c]) ? 0.0 : max_depth.values[c];
    const double q = std::isnan(max_hv.values[c]) ? 0.0 : max_hv.values[c];
    IntensityClass k = intensity_none;  // only inundated cells get a class: their union is the inundated area
    if (h >= inundation_threshold) {
      if (h >= t.high_depth || q >= t.high_hv) k = intensity_high;
      else if (h >= t.medium_depth || q >= t.medium_hv) k = intensity_medium;
      else k = intensity_low;
    }
    out.values[c] = static_cast<float>(k);
  }
  return out;
}

}  // namespace runout::terrain
