#pragma once
// Vector inputs: a scene's polygons and lines read from an OGR layer (GeoPackage, GeoJSON, Shapefile, ...)
// and reprojected to the working CRS. GDAL-free header; the reading is in terrain/src/vector.cpp.
//
// Polygons with holes and multipolygons travel as one Polyline (the type every structure, release and zone
// uses): the rings one after the other, each closed by repeating its first vertex, every ring after the first
// reached from the first ring's first vertex and left back to it along the same zero-width bridge. Outer
// rings run counter-clockwise and holes clockwise. On that path the even-odd containment of
// inside_polygon() is the union of the parts minus their holes (each bridge is crossed twice, so it cancels)
// and the shoelace area of polygon_area() is the parts' area minus the holes' (the bridges' terms cancel).
// A simple polygon stays its plain list of vertices. split_rings() gives the rings back (maps, outlines).
#include <string>
#include <vector>

#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout::terrain {

// {"layer": FILE, "name": LAYER, "where": FILTER, "crs": CRS} as a scene writes it.
struct LayerRef {
  std::string path;   // the file (already resolved against the scene's folder)
  std::string name;   // layer name; "" when the file has exactly one layer
  std::string where;  // OGR SQL attribute filter; "" for every feature
  std::string crs;    // the coordinates' CRS when the file declares none (or to override it); "" = the file's
};

enum class ShapeKind {
  line,            // one LineString (a MultiLineString of one part)
  polygon,         // one feature, one Polygon with one ring and no hole
  multipolygon,    // Polygons and MultiPolygons, holes allowed; several features are joined as parts
};

struct VectorShape {
  Polyline path;       // as described above (a line: its vertices)
  size_t parts = 0;    // polygons (1 for a line)
  size_t holes = 0;    // interior rings over all parts
  size_t features = 0; // features the layer (after the filter) gave
};

// Reads the geometry a scene field asks for, in the CRS given as WKT (the working CRS). Throws TerrainError
// naming `field` for a missing or unreadable file, an unknown layer (the message lists the file's layers), a
// filter GDAL refuses or that matches no feature (or more than one where one is needed), a layer without CRS
// and no `crs`, a CRS that cannot be transformed, a geometry of the wrong type, an empty, too short or
// invalid (self-intersecting, overlapping parts) geometry.
// A shape read once is kept by the bytes of its file and sidecars and the settings asked for (terrain/src/
// shape_cache.hpp), so checking, pricing and mapping many jobs on one layer file opens it once per process.
VectorShape read_vector_shape(const LayerRef& ref, ShapeKind kind, const std::string& working_crs_wkt,
                              const std::string& field);

// What the kept shapes did since the process started: a read answered from the keep, or from the file.
struct ShapeCacheStats {
  long hits = 0, misses = 0;
  size_t shapes = 0;
};
ShapeCacheStats shape_cache_stats();

// The CRS (WKT) load_dem(path, options) would return its grid in, from the raster's header only: the named
// target CRS, the DEM's own projected CRS, or the UTM zone of a geographic DEM's centre. Throws TerrainError
// as load_dem does ("terrain.dem", "terrain.crs").
std::string working_crs_wkt(const std::string& dem_path, const DemOptions& options);

// Rings joined into one path as described above (orientation fixed here), and the rings back.
Polyline join_rings(const std::vector<Polyline>& outers_and_holes, const std::vector<bool>& is_hole);
std::vector<Polyline> split_rings(const Polyline& path);

}  // namespace runout::terrain
