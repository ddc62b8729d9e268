// The map geometry of a resolved scene and the extent of a run's rasters (scene_map.hpp).
#include "runout/scenarios/scene_map.hpp"

#include <nlohmann/json.hpp>

#include "runout/terrain/raster.hpp"
#include "runout/terrain/vector.hpp"

namespace runout {

namespace {

using json = nlohmann::json;

// Reads layer references as the scene parser does (the working CRS from the scene's terrain section, once).
class Layers {
 public:
  Layers(const json& scene, std::filesystem::path base_dir) : scene_(scene), base_dir_(std::move(base_dir)) {}
  // The rings (or the line) of a layer reference; empty when it cannot be read.
  std::vector<terrain::Polyline> rings(const json& ref, bool polygon) {
    try {
      terrain::LayerRef r;
      std::filesystem::path path = ref.value("layer", std::string());
      if (path.is_relative() && !base_dir_.empty()) path = base_dir_ / path;
      r.path = path.string();
      r.name = ref.value("name", std::string());
      r.where = ref.value("where", std::string());
      r.crs = ref.value("crs", std::string());
      const auto kind = polygon ? terrain::ShapeKind::multipolygon : terrain::ShapeKind::line;
      const terrain::Polyline p = terrain::read_vector_shape(r, kind, crs(), "map").path;
      return polygon ? terrain::split_rings(p) : std::vector<terrain::Polyline>{p};
    } catch (const std::exception&) {
      return {};
    }
  }

 private:
  const std::string& crs() {
    if (crs_.empty()) {
      const json& t = scene_.at("terrain");
      std::filesystem::path dem = t.value("dem", std::string());
      if (dem.is_relative() && !base_dir_.empty()) dem = base_dir_ / dem;
      terrain::DemOptions o;
      o.target_crs = t.value("crs", std::string());
      o.resolution = t.value("resolution", 0.0);
      crs_ = terrain::working_crs_wkt(dem.string(), o);
    }
    return crs_;
  }
  const json& scene_;
  std::filesystem::path base_dir_;
  std::string crs_;
};

MapFeature make_feature(std::vector<std::array<double, 2>> points, bool polygon, std::string name, std::string type) {
  MapFeature f{std::move(name), std::move(type), std::move(points), polygon};
  if (polygon && f.points.size() > 2 && f.points.front() != f.points.back()) f.points.push_back(f.points.front());
  return f;
}

// The features of one geometry: inline points (one feature) or a layer (one per ring).
std::vector<MapFeature> features(const json& pts, bool polygon, const std::string& name, const std::string& type,
                                 Layers& layers) {
  if (pts.is_object()) {
    std::vector<MapFeature> out;
    for (const auto& ring : layers.rings(pts, polygon))
      out.push_back(make_feature({ring.begin(), ring.end()}, polygon, name, type));
    if (out.empty()) out.push_back(make_feature({}, polygon, name, type));
    return out;
  }
  std::vector<std::array<double, 2>> points;
  if (pts.is_array())
    for (const auto& p : pts)
      if (p.is_array() && p.size() >= 2 && p[0].is_number() && p[1].is_number())
        points.push_back({p[0].get<double>(), p[1].get<double>()});
  return {make_feature(std::move(points), polygon, name, type)};
}

void append(std::vector<MapFeature>& to, std::vector<MapFeature> from) {
  for (auto& f : from) to.push_back(std::move(f));
}

const json& array_at(const json& scene, const char* key) {
  static const json empty = json::array();
  return scene.is_object() && scene.contains(key) && scene[key].is_array() ? scene[key] : empty;
}

}  // namespace

SceneMap scene_map(const std::string& resolved_scene_json, const std::filesystem::path& base_dir) {
  const json scene = json::parse(resolved_scene_json, nullptr, false);
  SceneMap m;
  if (!scene.is_object() || !scene.contains("terrain") || !scene["terrain"].is_object()) return m;
  Layers layers(scene, base_dir);
  for (const auto& st : array_at(scene, "structures")) {
    const bool area = st.contains("polygon");
    append(m.structures, features(area ? st["polygon"] : st.value("axis", json::array()), area, st.value("name", ""),
                                  st.value("type", ""), layers));
  }
  for (const auto& z : array_at(scene, "protected_zones"))
    append(m.protected_zones, features(z.value("polygon", json::array()), true, z.value("name", ""), "", layers));
  for (const auto& mon : array_at(scene, "monitors"))
    if (mon.value("type", "") == "section" && mon.contains("line"))
      append(m.sections, features(mon["line"], false, mon.value("name", ""), "", layers));
  if (scene.contains("release") && scene["release"].is_object() && scene["release"].contains("polygon"))
    m.release = features(scene["release"]["polygon"], true, "release", "", layers).front();
  return m;
}

std::optional<MapExtent> run_map_extent(const std::filesystem::path& out_dir) {
  const std::filesystem::path tif = out_dir / "rasters" / "max_depth.tif";
  if (!std::filesystem::is_regular_file(tif)) return std::nullopt;
  const terrain::Grid g = terrain::load_dem(tif.string());
  return MapExtent{g.nx, g.ny, g.dx, g.dy, g.x0, g.y0, g.x1(), g.y1(), terrain::crs_name(g.crs_wkt)};
}

}  // namespace runout
