#pragma once
// Material calibration as a command (`runout calibrate-material`, docs/study.md "Calibration as a command"): one
// number of a scene (a JSON pointer: the friction angle) run over a list of values at a fidelity (the screening
// rung by default), each run stored as a member of a sweep's ensemble (so a calibration resumes), and fitted to an
// observation: a runout distance with its scatter, and/or an affected-area polygon scored by the critical success
// index (CSI = hits / (hits + misses + false alarms) over the DEM's cells, as r.avaflow's evaluation does).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout {

// What the runs are fitted to. At least one of runout_m and area.
struct CalibrationTarget {
  std::optional<double> runout_m;             // [m] the observed (or a relation's) runout, as terrain.inundation.runout_m
  std::optional<double> runout_tolerance_m;   // [m] its scatter: the band is where the runout lies within ±this
  std::filesystem::path area;                 // an affected-area polygon layer (GeoPackage, GeoJSON, Shapefile, ...)
  std::string area_layer;                     // its layer ("" when the file has one)
  std::optional<double> min_csi;              // the band for the area: values whose CSI reaches this
};

// The sweep that runs the calibration: the scene file (every structure it has built), or one layout of a sweep
// file (`variant`), with `pointer` set to each of `values` (ascending, 2 to 64 values) as an ensemble's grid.
// Named "calibrate-<scene or sweep>-<variant>"; throws SceneError naming --parameter, --values or --variant.
Sweep calibration_sweep(const std::filesystem::path& file, const std::string& variant, const std::string& pointer,
                        const std::vector<double>& values);

// A fit along the values: the best value and the band, each with how it was found (for people).
struct CalibrationFit {
  std::optional<double> best;
  std::string best_how;
  std::optional<double> band_lo, band_hi;
  std::string band_how;
};

// The runout's fit: the best value where the runout crosses the target, linear between the two values that
// bracket it (the first crossing, said when there are several: not monotone over the range); the band between
// where it crosses target - tolerance and target + tolerance (an end the range does not reach is the range's
// edge, said so). No best when the target is not crossed. `points`: (value, runout) ascending by value.
CalibrationFit fit_runout(const std::vector<std::pair<double, double>>& points, double target,
                          std::optional<double> tolerance);
// The area's fit: the value of the highest CSI (the first of equals); the band from the least to the greatest
// value whose CSI reaches min_csi. `points`: (value, CSI) ascending by value.
CalibrationFit fit_area(const std::vector<std::pair<double, double>>& points, std::optional<double> min_csi);

// CSI of a run's max-depth raster (affected where depth >= threshold) against the observed polygon (a cell is
// observed when its centre is inside), over the raster's cells and those of its lattice under the polygon's
// bounding box (an observed cell outside the raster's window is a miss). 0 when neither has a cell.
struct AreaScore {
  long hits = 0, misses = 0, false_alarms = 0;
  double csi = 0;
};
AreaScore critical_success_index(const terrain::Grid& max_depth, double threshold, const terrain::Polyline& observed);

struct CalibrationPoint {
  double value = 0;
  std::string variant, status, error;
  int64_t run_id = 0;
  std::optional<double> runout_m;
  std::optional<AreaScore> area;
};
struct CalibrationResult {
  std::string sweep, pointer;
  std::vector<CalibrationPoint> points;
  std::optional<CalibrationFit> runout_fit, area_fit;
};

// Runs (or finds in the store) every value's run and fits them. The observed area is read in each run's CRS
// (throws TerrainError naming --area when it cannot be read).
CalibrationResult calibrate_material(RunStore& store, const Sweep& sweep, const CalibrationTarget& target,
                                     const SweepOptions& options);

}  // namespace runout
