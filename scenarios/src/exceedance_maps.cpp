// An ensemble's exceedance maps: per layout, the share of the members whose hazard raster reaches a threshold
// (ensemble_summary.hpp; docs/terrain.md, "Hazard outputs").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <map>

#include <nlohmann/json.hpp>

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/raster_map.hpp"
#include "runout/terrain/hazard.hpp"
#include "runout/terrain/raster.hpp"

namespace runout {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// The report's and the web map's probability scale (raster_map.hpp), as QGIS style stops.
std::vector<terrain::StyleStop> probability_stops() {
  std::vector<terrain::StyleStop> stops;
  for (const auto& st : probability_colour_scale("").stops) stops.push_back({st.value, st.colour, st.label});
  return stops;
}

// The member runs' rasters of each layout, loaded once per raster name.
struct LayoutRasters {
  std::vector<fs::path> member_dirs;  // SWEEP_DIR/<variant>/rasters of each member with rasters
  std::map<std::string, std::vector<terrain::Grid>> loaded;
  const std::vector<terrain::Grid>& get(const std::string& name) {
    auto it = loaded.find(name);
    if (it != loaded.end()) return it->second;
    std::vector<terrain::Grid> grids;
    for (const auto& d : member_dirs) {
      const fs::path f = d / (name + ".tif");
      // A member whose run wrote no such raster (nothing reached a structure's pressure) reaches nothing there.
      if (fs::is_regular_file(f)) grids.push_back(terrain::load_dem(f.string()));
    }
    return loaded[name] = std::move(grids);
  }
};

void write_one(const fs::path& out_dir, const std::string& layout, const ExceedanceThreshold& t,
               const std::vector<terrain::Grid>& grids, size_t members) {
  std::vector<const terrain::Grid*> ptrs;
  for (const auto& g : grids) ptrs.push_back(&g);
  // Members without the raster count in the denominator: exceedance_grid divides by the grids it is given, so
  // scale by the share of members that have one.
  terrain::Grid p = terrain::exceedance_grid(ptrs, t.threshold);
  if (std::all_of(p.values.begin(), p.values.end(), [](float v) { return std::isnan(v); })) return;  // reached nowhere
  const float scale = static_cast<float>(grids.size()) / static_cast<float>(members);
  for (float& v : p.values) v *= scale;
  const std::string stem = "p_" + t.raster + "_" + t.level;
  const std::string what = "P(" + t.raster + " >= " + number(t.threshold) + (t.unit.empty() ? "" : " " + t.unit) + ")";
  fs::create_directories(out_dir);
  terrain::write_geotiff((out_dir / (stem + ".tif")).string(), p,
                         {what, "1",
                          {{"RUNOUT_LAYOUT", layout},
                           {"RUNOUT_RASTER", t.raster},
                           {"RUNOUT_THRESHOLD", number(t.threshold)},
                           {"RUNOUT_THRESHOLD_UNIT", t.unit},
                           {"RUNOUT_MEMBERS", std::to_string(members)}}});
  terrain::write_qml((out_dir / (stem + ".qml")).string(), probability_stops(), false);
}

}  // namespace

std::vector<ExceedanceThreshold> exceedance_thresholds(const Sweep& sweep) {
  terrain::IntensityThresholds t;
  const json base = json::parse(sweep.base_json);
  if (base.contains("output") && base["output"].contains("intensity")) {
    const json& in = base["output"]["intensity"];
    t.medium_depth = in.value("medium_depth", t.medium_depth);
    t.high_depth = in.value("high_depth", t.high_depth);
    t.medium_hv = in.value("medium_hv", t.medium_hv);
    t.high_hv = in.value("high_hv", t.high_hv);
  }
  std::vector<ExceedanceThreshold> out = {
      {"max_depth", "medium", t.medium_depth, "m"},
      {"max_depth", "high", t.high_depth, "m"},
      {"max_hv", "medium", t.medium_hv, "m2/s"},
      {"max_hv", "high", t.high_hv, "m2/s"},
      {"intensity", "medium", static_cast<double>(terrain::intensity_medium), "class"},
      {"intensity", "high", static_cast<double>(terrain::intensity_high), "class"}};
  const std::vector<double> pressures =
      sweep.ensemble ? sweep.ensemble->pressure_thresholds_pa : Ensemble{}.pressure_thresholds_pa;
  for (double p : pressures) out.push_back({"max_pressure", number(p / 1000.0) + "kPa", p, "Pa"});
  return out;
}

std::vector<std::string> write_exceedance_maps(const fs::path& sweep_dir, const Sweep& sweep) {
  std::map<std::string, std::vector<std::string>> members;  // layout -> its member variants
  std::vector<std::string> order;
  for (const auto& v : sweep.variants) {
    if (v.member < 0) continue;
    if (!members.count(v.layout)) order.push_back(v.layout);
    members[v.layout].push_back(v.name);
  }
  const auto thresholds = exceedance_thresholds(sweep);
  std::vector<std::string> written;
  for (const auto& layout : order) {
    LayoutRasters r;
    for (const auto& name : members[layout])
      if (fs::is_regular_file(sweep_dir / name / "rasters" / "max_depth.tif"))
        r.member_dirs.push_back(sweep_dir / name / "rasters");
    if (r.member_dirs.empty()) continue;
    for (const auto& t : thresholds) {
      const auto& grids = r.get(t.raster);
      if (!grids.empty()) write_one(sweep_dir / layout / "exceedance", layout, t, grids, r.member_dirs.size());
    }
    written.push_back(layout);
  }
  return written;
}

std::vector<std::string> write_ensemble_outputs(const RunStore& store, const fs::path& sweep_dir, const Sweep& sweep) {
  if (!sweep.ensemble) return {};
  auto written = write_exceedance_maps(sweep_dir, sweep);
  if (const auto summary = summarise_ensemble(store, sweep.name)) {
    fs::create_directories(sweep_dir);
    const fs::path tmp = sweep_dir / "ensemble.json.tmp";
    {
      std::ofstream f(tmp);
      f << ensemble_summary_json(*summary) << "\n";
      if (!f) throw std::runtime_error("cannot write " + tmp.string());
    }
    fs::rename(tmp, sweep_dir / "ensemble.json");
  }
  return written;
}

}  // namespace runout
