// The map geometry of a resolved scene and the extent of a run's rasters (scene_map.hpp).
#include "runout/scenarios/scene_map.hpp"

#include <nlohmann/json.hpp>

#include "runout/terrain/raster.hpp"

namespace runout {

namespace {

using json = nlohmann::json;

MapFeature feature(const json& pts, bool polygon, std::string name, std::string type = "") {
  MapFeature f{std::move(name), std::move(type), {}, polygon};
  if (pts.is_array())
    for (const auto& p : pts)
      if (p.is_array() && p.size() >= 2 && p[0].is_number() && p[1].is_number())
        f.points.push_back({p[0].get<double>(), p[1].get<double>()});
  if (polygon && f.points.size() > 2 && f.points.front() != f.points.back()) f.points.push_back(f.points.front());
  return f;
}

const json& array_at(const json& scene, const char* key) {
  static const json empty = json::array();
  return scene.is_object() && scene.contains(key) && scene[key].is_array() ? scene[key] : empty;
}

}  // namespace

SceneMap scene_map(const std::string& resolved_scene_json) {
  const json scene = json::parse(resolved_scene_json, nullptr, false);
  SceneMap m;
  for (const auto& st : array_at(scene, "structures")) {
    const bool area = st.contains("polygon");
    m.structures.push_back(feature(area ? st["polygon"] : st.value("axis", json::array()), area,
                                   st.value("name", ""), st.value("type", "")));
  }
  for (const auto& z : array_at(scene, "protected_zones"))
    m.protected_zones.push_back(feature(z.value("polygon", json::array()), true, z.value("name", "")));
  for (const auto& mon : array_at(scene, "monitors"))
    if (mon.value("type", "") == "section" && mon.contains("line"))
      m.sections.push_back(feature(mon["line"], false, mon.value("name", "")));
  if (scene.is_object() && scene.contains("release") && scene["release"].is_object() &&
      scene["release"].contains("polygon"))
    m.release = feature(scene["release"]["polygon"], true, "release");
  return m;
}

std::optional<MapExtent> run_map_extent(const std::filesystem::path& out_dir) {
  const std::filesystem::path tif = out_dir / "rasters" / "max_depth.tif";
  if (!std::filesystem::is_regular_file(tif)) return std::nullopt;
  const terrain::Grid g = terrain::load_dem(tif.string());
  return MapExtent{g.nx, g.ny, g.dx, g.dy, g.x0, g.y0, g.x1(), g.y1(), terrain::crs_name(g.crs_wkt)};
}

}  // namespace runout
