// A run's hazard rasters coloured for a web map (raster_map.hpp): the colour scales the QGIS styles use too
// (hazard_outputs.cpp writes them from hazard_colour_scale), and RGBA PNGs by libpng's simplified API.
#include "runout/scenarios/raster_map.hpp"

#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "runout/terrain/raster.hpp"

namespace runout {
namespace {

namespace fs = std::filesystem;

struct LayerInfo {
  const char* name;
  const char* title;
  const char* unit;
};
// map_layers() with what a legend says of each.
const std::vector<LayerInfo>& layer_infos() {
  static const std::vector<LayerInfo> list = {
      {"max_depth", "maximum flow depth", "m"},
      {"max_speed", "maximum speed", "m/s"},
      {"max_pressure", "maximum impact pressure", "Pa"},
      {"intensity", "intensity class", "class"},
      {"arrival_time", "arrival time", "s"},
      {"max_hv", "maximum depth x speed", "m2/s"},
      {"deposit_depth", "deposit depth (end of run)", "m"}};
  return list;
}

// Five stops from light yellow to dark blue over [lo, hi], labelled in the unit (or label_unit, values
// multiplied by label_scale: pressures in kPa).
std::vector<ColourStop> ramp(double lo, double hi, const std::string& unit, double label_scale = 1.0,
                             const std::string& label_unit = "") {
  static const char* colours[] = {"#ffffcc", "#a1dab4", "#41b6c4", "#2c7fb8", "#253494"};
  if (!(hi > lo)) hi = lo + 1.0;
  std::vector<ColourStop> stops;
  for (int k = 0; k < 5; ++k) {
    const double v = lo + (hi - lo) * k / 4.0;
    std::ostringstream label;
    label.precision(3);
    label << v * label_scale << ' ' << (label_unit.empty() ? unit : label_unit);
    stops.push_back({v, colours[k], label.str()});
  }
  return stops;
}

double grid_max(const terrain::Grid& g) {
  float m = 0.0f;
  for (float v : g.values)
    if (!std::isnan(v)) m = std::max(m, v);
  return m;
}

// terrain.inundation.threshold_m of OUT/metrics.json; 0 when the file or the entry is missing (a run
// stopped before writing it), which leaves only zero depths transparent.
double run_threshold(const fs::path& out_dir) {
  std::ifstream in(out_dir / "metrics.json");
  if (!in) return 0.0;
  const auto m = nlohmann::json::parse(in, nullptr, false);
  const auto p = nlohmann::json::json_pointer("/terrain/inundation/threshold_m");
  return !m.is_discarded() && m.contains(p) && m[p].is_number() ? m[p].get<double>() : 0.0;
}

std::array<double, 3> rgb_of(const std::string& hex) {
  if (hex.size() != 7 || hex[0] != '#') throw std::invalid_argument("colour '" + hex + "' is not #rrggbb");
  std::array<double, 3> c{};
  for (int k = 0; k < 3; ++k) c[k] = std::stoi(hex.substr(1 + 2 * k, 2), nullptr, 16);
  return c;
}

// The run's raster `layer`, or nullopt when the file is missing. A class raster with no class at all (nothing
// inundated: every cell 0, which is its nodata) reads as "only nodata"; it is then an empty grid of the
// depth raster's placement, so the picture is wholly transparent rather than an error.
std::optional<terrain::Grid> load_layer(const fs::path& out_dir, const std::string& layer) {
  const fs::path tif = out_dir / "rasters" / (layer + ".tif");
  if (!fs::is_regular_file(tif)) return std::nullopt;
  try {
    return terrain::load_dem(tif.string());
  } catch (const terrain::TerrainError& e) {
    const fs::path depth = out_dir / "rasters" / "max_depth.tif";
    if (std::string(e.what()).find("only nodata") == std::string::npos || layer == "max_depth" ||
        !fs::is_regular_file(depth))
      throw std::runtime_error(e.what());
    return terrain::load_dem(depth.string()).like(terrain::Grid::nodata);
  }
}

const std::vector<std::string>& layer_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& l : layer_infos()) n.push_back(l.name);
    return n;
  }();
  return names;
}

// Cell colours, RGBA row by row, by the scale (raster_map.hpp says which cells stay transparent).
std::vector<unsigned char> colour_cells(const terrain::Grid& g, const ColourScale& s) {
  std::vector<std::array<double, 3>> rgb;
  for (const auto& stop : s.stops) rgb.push_back(rgb_of(stop.colour));
  std::vector<unsigned char> out(g.values.size() * 4, 0);  // transparent black
  for (size_t k = 0; k < g.values.size(); ++k) {
    const double v = g.values[k];
    if (std::isnan(v) || v < s.min || (s.zero_transparent && v <= 0.0)) continue;
    std::array<double, 3> c{};
    if (s.classes) {
      const auto hit = std::find_if(s.stops.begin(), s.stops.end(), [&](const ColourStop& st) { return st.value == v; });
      if (hit == s.stops.end()) continue;  // not a class: nothing to show
      c = rgb[hit - s.stops.begin()];
    } else {
      size_t i = 1;  // the stops' interval holding v (values above max take the top colour)
      while (i + 1 < s.stops.size() && v > s.stops[i].value) ++i;
      const double lo = s.stops[i - 1].value, hi = s.stops[i].value;
      const double t = hi > lo ? std::clamp((v - lo) / (hi - lo), 0.0, 1.0) : 1.0;
      for (int ch = 0; ch < 3; ++ch) c[ch] = rgb[i - 1][ch] + t * (rgb[i][ch] - rgb[i - 1][ch]);
    }
    for (int ch = 0; ch < 3; ++ch) out[4 * k + ch] = static_cast<unsigned char>(std::lround(c[ch]));
    out[4 * k + 3] = 255;
  }
  return out;
}

// RGBA pixels as PNG bytes, in memory (libpng's simplified API).
std::string png_rgba(int width, int height, const std::vector<unsigned char>& rgba) {
  if (width < 1 || height < 1 || rgba.size() != size_t(width) * size_t(height) * 4)
    throw std::invalid_argument("png_rgba: " + std::to_string(rgba.size()) + " bytes for " + std::to_string(width) +
                                " x " + std::to_string(height) + " RGBA pixels");
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  img.width = static_cast<png_uint_32>(width);
  img.height = static_cast<png_uint_32>(height);
  img.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;  // first call: the size needed
  if (!png_image_write_to_memory(&img, nullptr, &size, 0, rgba.data(), 0, nullptr))
    throw std::runtime_error(std::string("png_rgba: ") + img.message);
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&img, out.data(), &size, 0, rgba.data(), 0, nullptr))
    throw std::runtime_error(std::string("png_rgba: ") + img.message);
  out.resize(size);
  return out;
}

}  // namespace

const std::vector<std::string>& map_layers() { return layer_names(); }

ColourScale hazard_colour_scale(const std::string& layer, double max_value, double inundation_threshold) {
  const auto it = std::find_if(layer_infos().begin(), layer_infos().end(),
                               [&](const LayerInfo& l) { return layer == l.name; });
  if (it == layer_infos().end()) {
    std::string list;
    for (const auto& n : map_layers()) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument("no raster layer '" + layer + "' (layers: " + list + ")");
  }
  ColourScale s;
  s.layer = layer;
  s.title = it->title;
  s.unit = it->unit;
  if (layer == "intensity") {
    s.classes = true;
    s.stops = {{1, "#ffff00", "low"}, {2, "#ff9900", "medium"}, {3, "#e31a1c", "high"}};
  } else if (layer == "max_depth" || layer == "deposit_depth") {
    s.stops = ramp(inundation_threshold, max_value, s.unit);
  } else if (layer == "max_pressure") {
    s.stops = ramp(0, max_value, s.unit, 1e-3, "kPa");
  } else {
    s.stops = ramp(0, max_value, s.unit);
  }
  s.zero_transparent = layer != "arrival_time";
  s.min = s.stops.front().value;
  s.max = s.stops.back().value;
  s.data_max = max_value;
  return s;
}

std::optional<RasterPicture> render_run_raster(const fs::path& out_dir, const std::string& layer,
                                               std::optional<double> top) {
  (void)hazard_colour_scale(layer, 0, 0);  // an unknown layer is refused before the file system is touched
  const auto g = load_layer(out_dir, layer);
  if (!g) return std::nullopt;
  RasterPicture p;
  p.scale = hazard_colour_scale(layer, top ? *top : grid_max(*g), run_threshold(out_dir));
  p.width = g->nx;
  p.height = g->ny;
  p.png = png_rgba(g->nx, g->ny, colour_cells(*g, p.scale));
  return p;
}

std::vector<ColourScale> run_raster_scales(const fs::path& out_dir) {
  std::vector<ColourScale> out;
  const double threshold = run_threshold(out_dir);
  for (const auto& layer : map_layers())
    if (const auto g = load_layer(out_dir, layer)) out.push_back(hazard_colour_scale(layer, grid_max(*g), threshold));
  return out;
}

double run_inundation_threshold(const fs::path& out_dir) { return run_threshold(out_dir); }

ColourScale difference_colour_scale(const std::string& name, const std::string& unit, double max_abs) {
  const double m = max_abs > 0 ? max_abs : 1.0;
  auto label = [&](double v) {
    std::ostringstream s;
    s.precision(3);
    s << (v > 0 ? "+" : "") << v << ' ' << unit;
    return s.str();
  };
  ColourScale s;
  s.layer = "diff_" + name;
  s.title = name == "max_depth" ? "maximum flow depth, this layout minus the baseline"
                                : "maximum depth x speed, this layout minus the baseline";
  s.unit = unit;
  s.stops = {{-m, "#2166ac", label(-m)}, {-m / 2, "#92c5de", label(-m / 2)}, {0, "#f7f7f7", label(0)},
             {m / 2, "#f4a582", label(m / 2)}, {m, "#b2182b", label(m)}};
  s.zero_transparent = false;  // 0 is "unchanged" (white); a cell dry in both layouts is nodata
  s.min = -m;
  s.max = m;
  s.data_max = max_abs;
  return s;
}

namespace {

// A sweep's raster for a picture; an unreadable file is a runtime_error (the caller says which run).
terrain::Grid load_picture_grid(const fs::path& tif) {
  try {
    return terrain::load_dem(tif.string());
  } catch (const terrain::TerrainError& e) {
    throw std::runtime_error(e.what());
  }
}

}  // namespace

std::optional<RasterPicture> render_difference_raster(const fs::path& out_dir, const std::string& name) {
  const fs::path tif = out_dir / "rasters" / ("diff_" + name + ".tif");
  if (!fs::is_regular_file(tif)) return std::nullopt;
  const terrain::Grid g = load_picture_grid(tif);
  double m = 0;
  for (float v : g.values)
    if (!std::isnan(v)) m = std::max(m, std::abs(static_cast<double>(v)));
  RasterPicture p;
  p.scale = difference_colour_scale(name, name == "max_depth" ? "m" : "m2/s", m);
  p.width = g.nx;
  p.height = g.ny;
  p.png = png_rgba(g.nx, g.ny, colour_cells(g, p.scale));
  return p;
}

ColourScale probability_colour_scale(const std::string& title) {
  ColourScale s;
  s.layer = "exceedance";
  s.title = title;
  s.unit = "probability";
  s.stops = {{0.0, "#ffffcc", "0"}, {0.25, "#fed976", "0.25"}, {0.5, "#fd8d3c", "0.5"},
             {0.75, "#e31a1c", "0.75"}, {1.0, "#800026", "1"}};
  s.min = 0.0;
  s.max = 1.0;
  s.data_max = 1.0;
  return s;  // 0 (no member reaches it) stays transparent, as nodata
}

std::optional<RasterPicture> render_exceedance_raster(const fs::path& tif) {
  if (!fs::is_regular_file(tif)) return std::nullopt;
  const terrain::Grid g = load_picture_grid(tif);
  RasterPicture p;
  p.scale = probability_colour_scale(terrain::band_description(tif.string()));
  p.width = g.nx;
  p.height = g.ny;
  p.png = png_rgba(g.nx, g.ny, colour_cells(g, p.scale));
  return p;
}

fs::path run_hillshade(const fs::path& out_dir) { return out_dir / "rasters" / "hillshade.png"; }

}  // namespace runout
