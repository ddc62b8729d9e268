// A sweep's difference rasters: each layout's max depth and max h v minus the baseline layout's
// (study.hpp, write_difference_rasters; docs/terrain.md "Hazard outputs").
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "hazard_outputs.hpp"
#include "runout/scenarios/raster_map.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/terrain/raster.hpp"

namespace runout {
namespace {

namespace fs = std::filesystem;

// The diverging scale the report's maps use too (raster_map.hpp), as QGIS style stops.
std::vector<terrain::StyleStop> diverging(const terrain::Grid& d, const std::string& name, const std::string& unit) {
  float m = 0.0f;
  for (float v : d.values)
    if (!std::isnan(v)) m = std::max(m, std::abs(v));
  std::vector<terrain::StyleStop> stops;
  for (const auto& st : difference_colour_scale(name, unit, m).stops) stops.push_back({st.value, st.colour, st.label});
  return stops;
}

}  // namespace

bool write_layout_differences(const fs::path& rasters, const std::string& variant, const fs::path& base_rasters,
                              const std::string& baseline, const fs::path& out_rasters) {
  bool all = true;
  for (const auto& r : difference_rasters()) {
    const fs::path a = rasters / (std::string(r.name) + ".tif"), b = base_rasters / (std::string(r.name) + ".tif");
    if (!fs::is_regular_file(a) || !fs::is_regular_file(b)) {
      all = false;
      continue;
    }
    const terrain::Grid d = terrain::difference_grid(terrain::load_dem(a.string()), terrain::load_dem(b.string()));
    const std::string name = std::string("diff_") + r.name;
    fs::create_directories(out_rasters);
    terrain::write_geotiff((out_rasters / (name + ".tif")).string(), d,
                           {r.description, r.unit,
                            {{"RUNOUT_LAYOUT", variant}, {"RUNOUT_BASELINE", baseline},
                             {"RUNOUT_DIFFERENCE", variant + " - " + baseline}}});
    terrain::write_qml((out_rasters / (name + ".qml")).string(), diverging(d, r.name, r.unit), false);
  }
  return all;
}

std::vector<std::string> write_difference_rasters(const fs::path& sweep_dir, const std::vector<std::string>& variants) {
  std::vector<std::string> written;
  if (variants.size() < 2) return written;
  const fs::path base = sweep_dir / variants.front() / "rasters";
  for (size_t k = 1; k < variants.size(); ++k) {
    const fs::path dir = sweep_dir / variants[k] / "rasters";
    if (write_layout_differences(dir, variants[k], base, variants.front(), dir)) written.push_back(variants[k]);
  }
  return written;
}

std::vector<std::string> write_sweep_differences(const fs::path& sweep_dir, const Sweep& sweep) {
  std::map<int, std::vector<std::string>> groups;  // member -> its variants, in the sweep's order
  for (const auto& v : sweep.variants) groups[v.member].push_back(v.name);
  std::vector<std::string> written;
  for (const auto& [member, names] : groups)
    for (auto& w : write_difference_rasters(sweep_dir, names)) written.push_back(std::move(w));
  return written;
}

}  // namespace runout
