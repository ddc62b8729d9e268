#pragma once
// What a map of a run shows besides its rasters: the map geometry of a resolved scene (structures, protected
// zones, release, cross-sections, in the working CRS, metres) and where the run's depth raster lies. The
// service draws map.json from these instead of reading scene JSON or GeoTIFFs itself.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace runout {

struct MapFeature {
  std::string name, type;                      // type: the structure's type ("" for zones, release, sections)
  std::vector<std::array<double, 2>> points;   // a polygon's ring (closed: last == first) or a line
  bool polygon = false;
};

struct SceneMap {
  std::vector<MapFeature> structures, protected_zones, sections;
  std::optional<MapFeature> release;
};

// From a resolved scene's JSON (as stored with a job); a scene without terrain gives an empty map. Points
// that are not pairs of numbers are left out (the scene was validated when the job was made). A geometry
// given as a layer reference ({"layer": ...}, files relative to `base_dir`) is read and reprojected as the
// run read it; a polygon of several rings gives one feature per ring (the release: its first ring); a layer
// that cannot be read any more gives a feature without points.
SceneMap scene_map(const std::string& resolved_scene_json, const std::filesystem::path& base_dir = {});

struct MapExtent {
  int nx = 0, ny = 0;
  double dx = 0, dy = 0, west = 0, north = 0, east = 0, south = 0;
  std::string crs;  // the CRS's name
};

// The extent of a run's rasters (OUT/rasters/max_depth.tif, whose cells map.png enlarges by a whole factor);
// nullopt when the run wrote none (scenes without terrain). Throws std::runtime_error if the file is unreadable.
std::optional<MapExtent> run_map_extent(const std::filesystem::path& out_dir);

}  // namespace runout
