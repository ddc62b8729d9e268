#pragma once
// A run's hazard rasters as pictures for a web map: each raster of OUT/rasters coloured by the same colour scale
// its QGIS style (.qml) uses, one pixel per cell, transparent where there is nothing to show, as an RGBA PNG.
// The service asks for these instead of reading GeoTIFFs itself (docs/web.md, "The map").
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace runout {

struct ColourStop {
  double value;        // in the raster's unit
  std::string colour;  // "#rrggbb"
  std::string label;   // for a legend ("0.5 m", "12 kPa", "high")
};

struct ColourScale {
  std::string layer;        // the raster's name: "max_depth"
  std::string title;        // what it shows, for a legend: "maximum flow depth"
  std::string unit;         // the raster's unit: "m", "m/s", "Pa", "class"
  bool classes = false;     // one colour per class value (no ramp between them)
  double min = 0, max = 0;  // the first and last stop's values
  std::vector<ColourStop> stops;  // ascending values; a ramp interpolates linearly in RGB between them
  // Cells left transparent: nodata always; below `min`; zero too when zero means "nothing here" (every layer
  // but the arrival time, where 0 s is the release).
  bool zero_transparent = true;
  double data_max = 0;      // the largest value the scale was made for (a shared scale: the largest of several runs)
};

// The rasters a map offers, in the order a legend or a layer control lists them: max_depth, max_speed,
// max_pressure, intensity, arrival_time, max_hv, deposit_depth.
const std::vector<std::string>& map_layers();

// The colour scale of `layer` (one of map_layers()) for a raster whose largest value is `max_value`
// (ramps run from 0, or from the inundation threshold for depths, to it). Throws std::invalid_argument for
// another name.
ColourScale hazard_colour_scale(const std::string& layer, double max_value, double inundation_threshold);

// A rendered raster: PNG bytes (RGBA, one pixel per cell, north up) and the scale it was coloured with.
struct RasterPicture {
  std::string png;
  int width = 0, height = 0;
  ColourScale scale;
};

// The raster OUT/rasters/<layer>.tif of the run in `out_dir`, coloured. The inundation threshold is the run's
// (OUT/metrics.json, terrain.inundation.threshold_m). nullopt when the run has no such raster (not a terrain
// run); throws std::invalid_argument for a layer not in map_layers(), std::runtime_error for an unreadable file.
// `top`: the ramp's largest value instead of the raster's own (maps of several runs on one shared scale).
std::optional<RasterPicture> render_run_raster(const std::filesystem::path& out_dir, const std::string& layer,
                                               std::optional<double> top = std::nullopt);

// The colour scales of the run's rasters (map_layers() order, those the run has), without rendering; each
// scale's data_max is the raster's largest value.
std::vector<ColourScale> run_raster_scales(const std::filesystem::path& out_dir);
// The inundation threshold the run's depth scales start from (OUT/metrics.json; 0 without it).
double run_inundation_threshold(const std::filesystem::path& out_dir);

// A sweep's difference raster OUT/rasters/diff_<name>.tif (name "max_depth" or "max_hv": the layout's raster
// minus the baseline layout's, docs/terrain.md): a diverging scale symmetric about 0 to the largest |d|, blue
// where the layout lowers the value, white where unchanged, red where it raises it. Its .qml uses the same.
ColourScale difference_colour_scale(const std::string& name, const std::string& unit, double max_abs);
// The run's diff_<name>.tif coloured by difference_colour_scale (nodata transparent, 0 white); nullopt when
// the run has none (a baseline, a service run, a single run).
std::optional<RasterPicture> render_difference_raster(const std::filesystem::path& out_dir, const std::string& name);

// An ensemble's exceedance map (ensemble_summary.hpp, p_<raster>_<level>.tif): a probability from 0 to 1, pale
// yellow to dark red; its .qml uses the same stops. `title` says what it is the probability of.
ColourScale probability_colour_scale(const std::string& title);
// The exceedance map in `tif` coloured by probability_colour_scale, titled by its band description; nullopt
// when there is no such file.
std::optional<RasterPicture> render_exceedance_raster(const std::filesystem::path& tif);

// The grey hillshade of the run's terrain (OUT/rasters/hillshade.png, written with the rasters), if any.
std::filesystem::path run_hillshade(const std::filesystem::path& out_dir);

}  // namespace runout
