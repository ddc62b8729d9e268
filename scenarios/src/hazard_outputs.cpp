// A terrain run's hazard maps: rasters with their descriptions, units and run metadata, QGIS styles, and the
// inundated area and intensity classes as polygons (hazard_outputs.hpp, docs/terrain.md "Hazard outputs").
#include "hazard_outputs.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <sstream>

#include "runout/scenarios/raster_map.hpp"
#include "runout/terrain/hazard.hpp"

#ifndef RUNOUT_VERSION
#define RUNOUT_VERSION "unknown"
#endif

namespace runout {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string text(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

float grid_max(const terrain::Grid& g) {
  float m = 0.0f;
  for (float v : g.values)
    if (!std::isnan(v)) m = std::max(m, v);
  return m;
}

// `g` with nodata where the flow never wet the cell (`wet` under `least`): QGIS and GDAL then leave those
// cells out (no paint over the basemap, no statistics of zeros), and 0 keeps meaning "wet, nothing recorded".
terrain::Grid wet_only(const terrain::Grid& g, const terrain::Grid& wet, float least) {
  terrain::Grid out = g;
  for (size_t c = 0; c < out.values.size(); ++c)
    if (!(wet.values[c] >= least)) out.values[c] = terrain::Grid::nodata;
  return out;
}

// The colour scale of a raster (raster_map.hpp: the web map colours it the same way) as QGIS style stops.
std::vector<terrain::StyleStop> style(const std::string& layer, double max_value, double threshold) {
  std::vector<terrain::StyleStop> stops;
  for (const auto& st : hazard_colour_scale(layer, max_value, threshold).stops)
    stops.push_back({st.value, st.colour, st.label});
  return stops;
}

struct Writer {
  fs::path dir;
  std::vector<std::pair<std::string, std::string>> run;  // the run's metadata, on every raster
  json files = json::array();

  void raster(const std::string& name, const terrain::Grid& g, const std::string& description, const std::string& unit,
              const std::vector<terrain::StyleStop>& style) {
    terrain::write_geotiff((dir / (name + ".tif")).string(), g, {description, unit, run});
    terrain::write_qml((dir / (name + ".qml")).string(), style, false);
    files.push_back("rasters/" + name + ".tif");
  }
};

}  // namespace

const std::vector<DifferenceRaster>& difference_rasters() {
  static const std::vector<DifferenceRaster> list = {
      {"max_depth", "m", "maximum flow depth of this layout minus the baseline's"},
      {"max_hv", "m2/s", "maximum depth x speed of this layout minus the baseline's"}};
  return list;
}

json write_hazard_outputs(const terrain::InundationGrid& g, const OutputSettings& out, const fs::path& dir,
                          const RunLabel& label) {
  fs::create_directories(dir);
  const double threshold = out.inundation_threshold;
  const terrain::IntensityThresholds& it = out.intensity;
  Writer w{dir,
           {{"RUNOUT_SCENE", label.scene},
            {"RUNOUT_DP_M", text(label.dp)},
            {"RUNOUT_SIMULATED_TIME_S", text(label.simulated_time)},
            {"RUNOUT_STATUS", label.status},
            {"RUNOUT_INUNDATION_THRESHOLD_M", text(threshold)},
            {"RUNOUT_CREATED_UTC", utc_now()},
            {"RUNOUT_VERSION", RUNOUT_VERSION}}};
  const float hmax = grid_max(g.max_depth()), vmax = grid_max(g.max_speed()), qmax = grid_max(g.max_hv()),
              pmax = grid_max(g.max_pressure());
  // Dry cells are nodata (docs/terrain.md, "Hazard outputs"): never touched by the flow for the maxima, no
  // deposit at the end for the deposit, never at the inundation threshold for the pressure (recorded only there)
  // and the arrival. The least positive float: any depth the flow left counts as wet.
  const terrain::Grid& depth = g.max_depth();
  const float touched = std::numeric_limits<float>::denorm_min();
  w.raster("max_depth", wet_only(depth, depth, touched), "maximum flow depth over the run (nodata: never reached)", "m",
           style("max_depth", hmax, threshold));
  w.raster("max_speed", wet_only(g.max_speed(), depth, touched), "maximum particle speed over the run (nodata: never reached)",
           "m/s", style("max_speed", vmax, threshold));
  w.raster("deposit_depth", wet_only(g.depth(), g.depth(), touched), "flow depth at the end of the run (nodata: none)",
           "m", style("deposit_depth", grid_max(g.depth()), threshold));
  w.raster("max_hv", wet_only(g.max_hv(), depth, touched),
           "maximum over time of depth x depth-averaged speed (nodata: never reached)", "m2/s", style("max_hv", qmax, threshold));
  w.raster("arrival_time", g.arrival_time(), "first time the depth reached the inundation threshold (nodata: never)",
           "s", style("arrival_time", grid_max(g.arrival_time()), threshold));
  w.raster("max_pressure", wet_only(g.max_pressure(), depth, std::max(static_cast<float>(threshold), touched)),
           "maximum hydrodynamic impact pressure rho v^2 (nodata: never at the inundation threshold)", "Pa",
           style("max_pressure", pmax, threshold));

  const terrain::Grid classes = terrain::intensity_classes(g.max_depth(), g.max_hv(), it, threshold);
  auto meta = w.run;
  meta.push_back({"RUNOUT_INTENSITY_CLASSES", "1 low, 2 medium, 3 high; 0 not inundated (nodata)"});
  meta.push_back({"RUNOUT_INTENSITY_HIGH", "h >= " + text(it.high_depth) + " m or h v >= " + text(it.high_hv) + " m2/s"});
  meta.push_back({"RUNOUT_INTENSITY_MEDIUM",
                  "h >= " + text(it.medium_depth) + " m or h v >= " + text(it.medium_hv) + " m2/s"});
  terrain::write_class_geotiff((dir / "intensity.tif").string(), classes,
                               {"debris-flow intensity class (1 low, 2 medium, 3 high)", "class", meta});
  terrain::write_qml((dir / "intensity.qml").string(), style("intensity", 3, threshold), true);
  w.files.push_back("rasters/intensity.tif");

  terrain::Grid inundated = g.max_depth().like(0.0f);
  for (size_t c = 0; c < inundated.values.size(); ++c) inundated.values[c] = g.max_depth().values[c] >= threshold;
  // Each layer styled in the file (layer_styles): the intensity classes in the colours of intensity.qml and
  // the web map, the inundated area in the depth ramp's blue.
  std::vector<std::string> class_colours;
  for (const auto& st : hazard_colour_scale("intensity", 3, threshold).stops) class_colours.push_back(st.colour);
  terrain::write_class_polygons((dir / "hazard.gpkg").string(),
                                {{"inundated", &inundated, {"inundated"}, {"#2c7fb8"}},
                                 {"intensity", &classes, terrain::intensity_labels(), class_colours}});
  w.files.push_back("rasters/hazard.gpkg");
  // The terrain in grey, under the web map's coloured rasters (raster_map.hpp): the depth map's renderer with
  // no depth to draw.
  terrain::write_depth_map_png((dir / "hillshade.png").string(), g.terrain(), g.terrain().like(terrain::Grid::nodata),
                               threshold);

  json areas = json::object();
  for (int k = 1; k <= 3; ++k) {
    size_t n = 0;
    for (float v : classes.values) n += v == static_cast<float>(k);
    areas[terrain::intensity_labels()[k - 1]] = n * classes.cell_area();
  }
  return {{"max_hv_m2_s", qmax}, {"max_pressure_pa", pmax}, {"intensity_area_m2", areas}, {"rasters", w.files}};
}

}  // namespace runout
