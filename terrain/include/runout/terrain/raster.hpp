#pragma once
// Rasters in and out. A Grid is a north-up raster in a projected CRS with metre units; everything above the
// terrain library works on Grids and never sees GDAL.
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace runout::terrain {

// Bad terrain input. `field` names the scene field at fault (for instance "terrain.dem"), so the service can
// put the message next to the right form field.
struct TerrainError : std::runtime_error {
  std::string field;
  TerrainError(std::string field_, const std::string& message)
      : std::runtime_error(field_ + ": " + message), field(std::move(field_)) {}
};

// Cell (i, j) is column i (west to east) and row j (north to south); its centre is
// (x0 + (i + 1/2) dx, y0 - (j + 1/2) dy). Nodata is NaN.
struct Grid {
  int nx = 0, ny = 0;
  double x0 = 0.0, y0 = 0.0;  // west and north edges
  double dx = 0.0, dy = 0.0;  // cell sizes, positive
  std::string crs_wkt;        // OGC WKT of the projected CRS ("" only for scratch grids)
  std::vector<float> values;  // ny * nx, row-major

  static constexpr float nodata = std::numeric_limits<float>::quiet_NaN();

  Grid() = default;
  Grid(int nx_, int ny_, double x0_, double y0_, double dx_, double dy_, std::string crs = {}, float fill = 0.0f)
      : nx(nx_), ny(ny_), x0(x0_), y0(y0_), dx(dx_), dy(dy_), crs_wkt(std::move(crs)),
        values(static_cast<size_t>(nx_) * static_cast<size_t>(ny_), fill) {}

  // An empty grid with the same placement and CRS.
  Grid like(float fill = 0.0f) const { return Grid(nx, ny, x0, y0, dx, dy, crs_wkt, fill); }

  float& at(int i, int j) { return values[static_cast<size_t>(j) * nx + i]; }
  float at(int i, int j) const { return values[static_cast<size_t>(j) * nx + i]; }
  double cx(int i) const { return x0 + (i + 0.5) * dx; }
  double cy(int j) const { return y0 - (j + 0.5) * dy; }
  double x1() const { return x0 + nx * dx; }  // east edge
  double y1() const { return y0 - ny * dy; }  // south edge
  double cell_area() const { return dx * dy; }
  // Cell holding a map point; false outside the grid.
  bool cell_of(double x, double y, int& i, int& j) const {
    const double fi = (x - x0) / dx, fj = (y0 - y) / dy;
    if (!(fi >= 0.0 && fj >= 0.0 && fi < nx && fj < ny)) return false;
    i = static_cast<int>(fi);
    j = static_cast<int>(fj);
    return true;
  }
  // Bilinear interpolation between cell centres (clamped to the outer half cell). NaN outside the grid or
  // where any of the four cells is nodata.
  double sample(double x, double y) const;

  // The cells whose centres surround a map point: those `sample` weighs, up to four (fewer on a centre line
  // or at the edge). False outside the grid.
  struct Stencil {
    int count = 0;
    int i[4], j[4];
    double weight[4];
  };
  bool stencil(double x, double y, Stencil& s) const;
};

struct DemOptions {
  // CRS to work in: "" keeps a projected DEM's own CRS and sends a geographic one to the UTM zone of its
  // centre; otherwise anything OGR's SetFromUserInput accepts ("EPSG:32616", WKT, PROJ string).
  std::string target_crs;
  // Cell size in metres after reprojection; 0 keeps about the native resolution.
  double resolution = 0.0;
};

// Reads band 1 of any raster GDAL opens (GeoTIFF, ESRI ASCII grid, VRT, ...), with nodata as NaN, and
// returns it in a projected metre CRS (warped with bilinear resampling when needed). Throws TerrainError
// (field "terrain.dem") for an unreadable file, a raster without CRS or geotransform, a rotated
// geotransform, a non-metre projected CRS that the options do not reproject, or a raster that is all
// nodata.
// The grid is kept in memory by the content of every file GDAL reads for it (the raster, a VRT's sources) and
// the options: loading the same DEM again returns the kept copy; a file changed in any byte is read afresh.
Grid load_dem(const std::string& path, const DemOptions& options = {});
// The same grid, shared with the keep (no copy): what a terrain build holds, so that a service validating and
// estimating many scenes on one DEM does not copy it for each.
std::shared_ptr<const Grid> load_dem_shared(const std::string& path, const DemOptions& options = {});

// What load_dem's keep has done in this process: lookups answered from it and not, grids and bytes held.
struct DemCacheStats {
  long hits = 0, misses = 0;
  size_t grids = 0, bytes = 0;
};
DemCacheStats dem_cache_stats();

// Band 1's description as written (RasterInfo::description): "" when it has none. Throws TerrainError for a
// file GDAL cannot open.
std::string band_description(const std::string& path);

// EPSG code string of the WGS 84 UTM zone holding a longitude/latitude ("EPSG:32616").
std::string utm_crs_for(double lon_deg, double lat_deg);

// OGC WKT of a CRS given as anything OGR's SetFromUserInput accepts ("EPSG:32616"); throws TerrainError
// (field "terrain.crs") if it is not a CRS.
std::string crs_wkt_from(const std::string& user_input);

// Short human-readable name of a CRS ("WGS 84 / UTM zone 16N"), "" if the WKT is empty or unreadable.
std::string crs_name(const std::string& crs_wkt);

// What a written raster says of itself: the band's description and unit (QGIS shows them instead of
// "Band 1"), and dataset metadata items (the run: scene, dp, time, ...).
struct RasterInfo {
  std::string description;
  std::string unit;
  std::vector<std::pair<std::string, std::string>> metadata;
};

// Single-band Float32 GeoTIFF with the grid's CRS and geotransform, NaN as nodata, deflate-compressed.
// Written to a temporary name and renamed, so a reader never sees half a file.
void write_geotiff(const std::string& path, const Grid& grid, const RasterInfo& info = {});
// A class raster (values 0-255 as Byte, 0 = no class and nodata), otherwise as write_geotiff.
void write_class_geotiff(const std::string& path, const Grid& classes, const RasterInfo& info);

// Polygons of a class grid (terrain/src/polygonize.cpp): one layer per entry, a feature per connected
// region of equal nonzero class (GDALPolygonize, 4-connected, edges on the cell edges), with fields "class",
// "label" (labels[class - 1]) and "area_m2", after GDALSieveFilter merged every region smaller than
// kPolygonSieveCells cells into its largest neighbour (a one-cell speck of a class, or a one-cell hole). A
// GeoPackage in the grid's CRS, stored under its EPSG code where GDAL identifies one, with each layer's QGIS
// style (a fill colour per class, colours[class - 1] "#rrggbb", when given) in the layer_styles table QGIS reads
// as the layer's default style; written atomically.
constexpr int kPolygonSieveCells = 2;
struct ClassLayer {
  std::string name;
  const Grid* classes = nullptr;
  std::vector<std::string> labels;
  std::vector<std::string> colours;  // one per label; empty: no style
};
void write_class_polygons(const std::string& path, const std::vector<ClassLayer>& layers);

// a - b on the union of their extents (both on the same cell lattice: same cell size, edges a whole number
// of cells apart, else std::invalid_argument); a cell outside one grid or NaN in it counts as 0 there, and is
// nodata (NaN) where neither grid has a value (dry in both).
Grid difference_grid(const Grid& a, const Grid& b);
// The share of `members` whose value reaches `threshold` (v >= threshold), cell by cell, on the union of their
// extents (one lattice, as difference_grid): a cell outside a member or NaN in it does not reach it there; the
// denominator is always the number of members. Nodata where no member reaches it (nothing to paint).
// Throws std::invalid_argument for no members or grids off one lattice.
Grid exceedance_grid(const std::vector<const Grid*>& members, double threshold);

// A QGIS layer style (.qml) for a single-band raster: a colour ramp from the stops' values (continuous), or
// one colour per class value (paletted, exact values). Colours "#rrggbb".
struct StyleStop {
  double value;
  std::string colour;
  std::string label;
};
void write_qml(const std::string& path, const std::vector<StyleStop>& stops, bool classes);
// The QGIS style (QML text) of a polygon layer: a categorised fill on the integer field `field`, one category
// per stop (its value, colour and label), at 80 % opacity with a darker outline.
std::string vector_class_qml(const std::string& field, const std::vector<StyleStop>& categories);
// The QGIS style of hazard.gpkg's built structures (write_structure_layers): check dams' crest lines dark and
// thick (`areas` false); deposition areas and retention basins outlined over a light fill, one colour per `type`
// (`areas` true); each labelled with its name.
std::string structure_layer_qml(bool areas);

// A picture for people: the hillshaded terrain in grey with `depth` (same placement as `terrain`) drawn
// over it in a blue colour ramp from `min_depth` to the grid's maximum; cells below min_depth stay grey.
// Optional outlines (polygons/polylines in map coordinates) are drawn in `outline` colours. RGB PNG,
// atomic like write_geotiff.
struct MapOverlay {
  std::vector<std::vector<std::pair<double, double>>> lines;  // each a polyline; closed if first == last
  unsigned char r = 200, g = 30, b = 30;
};
void write_depth_map_png(const std::string& path, const Grid& terrain, const Grid& depth, double min_depth,
                         const std::vector<MapOverlay>& overlays = {});
// Integer factor by which write_depth_map_png enlarges an nx x ny grid (1 for grids of ~600 cells or more on
// the longer side), so the PNG is (nx * factor) x (ny * factor) pixels.
int depth_map_png_scale(int nx, int ny);

}  // namespace runout::terrain
