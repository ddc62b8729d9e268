// Vector inputs (terrain/src/vector.cpp): layers of GeoJSON and GeoPackage files as lines and polygons in the
// working CRS, a reprojection checked against the meridian arc, multipolygons and holes, and every refusal
// naming the scene field.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "runout/terrain/vector.hpp"

namespace fs = std::filesystem;
using namespace runout::terrain;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-vector-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

struct Feature {
  std::string wkt;
  std::string id;
};

// A vector file with one layer per call (GPKG: several layers in one file), features from WKT, an "id" field.
void write_layer(const fs::path& file, const std::string& driver, const std::string& layer, const std::string& crs,
                 const std::vector<Feature>& features) {
  GDALAllRegister();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver.c_str());
  ASSERT_NE(drv, nullptr);
  GDALDataset* ds = fs::exists(file) ? GDALDataset::Open(file.c_str(), GDAL_OF_VECTOR | GDAL_OF_UPDATE)
                                     : drv->Create(file.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
  ASSERT_NE(ds, nullptr);
  OGRSpatialReference srs;
  if (!crs.empty()) {
    srs.SetFromUserInput(crs.c_str());
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  }
  OGRLayer* l = ds->CreateLayer(layer.c_str(), crs.empty() ? nullptr : &srs, wkbUnknown, nullptr);
  ASSERT_NE(l, nullptr);
  OGRFieldDefn id("id", OFTString);
  ASSERT_EQ(l->CreateField(&id), OGRERR_NONE);
  for (const auto& f : features) {
    OGRFeature feature(l->GetLayerDefn());
    feature.SetField("id", f.id.c_str());
    OGRGeometry* g = nullptr;
    ASSERT_EQ(OGRGeometryFactory::createFromWkt(f.wkt.c_str(), nullptr, &g), OGRERR_NONE) << f.wkt;
    feature.SetGeometryDirectly(g);
    ASSERT_EQ(l->CreateFeature(&feature), OGRERR_NONE);
  }
  GDALClose(ds);
}

const std::string& utm16() {
  static const std::string wkt = crs_wkt_from("EPSG:32616");
  return wkt;
}

// Meridian arc length of WGS 84 from the equator to latitude phi, by Simpson's rule on the meridian radius of
// curvature a (1 - e2) / (1 - e2 sin^2)^(3/2): independent of PROJ, accurate to far below a millimetre.
double meridian_arc(double phi_deg) {
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2.0 - f);
  const double phi = phi_deg * M_PI / 180.0;
  const int n = 2000;
  auto m = [&](double t) { return a * (1 - e2) / std::pow(1 - e2 * std::sin(t) * std::sin(t), 1.5); };
  double s = m(0) + m(phi);
  for (int k = 1; k < n; ++k) s += (k % 2 ? 4 : 2) * m(phi * k / n);
  return s * phi / (3.0 * n);
}

// Expects a TerrainError naming `field` whose message contains `words`.
template <class F>
void expect_refused(F f, const std::string& field, const std::string& words) {
  try {
    f();
    ADD_FAILURE() << "not refused; expected " << field << ": ..." << words;
  } catch (const TerrainError& e) {
    EXPECT_EQ(e.field, field) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(VectorLayer, GeoJsonPolygonInTheWorkingCrsKeepsItsVerticesWithoutTheClosingOne) {
  TempDir tmp;
  const fs::path file = tmp.path / "release.geojson";
  write_layer(file, "GeoJSON", "release", "EPSG:32616",
              {{"POLYGON ((600040 4000025, 600050 4000025, 600050 4000035, 600040 4000035, 600040 4000025))", "R"}});
  const VectorShape s = read_vector_shape({file.string(), "", "", ""}, ShapeKind::multipolygon, utm16(), "release.polygon");
  const Polyline expected = {{600040, 4000025}, {600050, 4000025}, {600050, 4000035}, {600040, 4000035}};
  EXPECT_EQ(s.path, expected);
  EXPECT_EQ(s.parts, 1u);
  EXPECT_EQ(s.holes, 0u);
  EXPECT_DOUBLE_EQ(polygon_area(s.path), 100.0);
}

TEST(VectorLayer, GeoPackageLayerByNameAndFilterGivesOneDamAxis) {
  TempDir tmp;
  const fs::path file = tmp.path / "layouts.gpkg";
  write_layer(file, "GPKG", "dams", "EPSG:32616",
              {{"LINESTRING (600100 4000000, 600100 4000061)", "Dam1"},
               {"LINESTRING (600120 4000000, 600125 4000030, 600120 4000061)", "Dam2"}});
  write_layer(file, "GPKG", "zones", "EPSG:32616", {{"POLYGON ((0 0, 1 0, 1 1, 0 0))", "Z"}});
  const VectorShape s =
      read_vector_shape({file.string(), "dams", "id = 'Dam2'", ""}, ShapeKind::line, utm16(), "structures[1].axis");
  const Polyline expected = {{600120, 4000000}, {600125, 4000030}, {600120, 4000061}};
  EXPECT_EQ(s.path, expected);
  EXPECT_EQ(s.features, 1u);
}

TEST(VectorLayer, GeographicLayerIsReprojectedOntoTheUtmGrid) {
  // Points on zone 16's central meridian (87 W): easting 500 000 m by definition, northing k0 times the
  // meridian arc. EPSG:4326 declares latitude first; the file stores x = longitude as GIS software does, so
  // a wrong axis order would put the points thousands of kilometres off.
  TempDir tmp;
  const fs::path file = tmp.path / "line_wgs84.geojson";
  write_layer(file, "GeoJSON", "line", "EPSG:4326", {{"LINESTRING (-87 36.75, -87 36.8)", "L"}});
  const VectorShape s = read_vector_shape({file.string(), "", "", ""}, ShapeKind::line, utm16(), "monitors[0].line");
  ASSERT_EQ(s.path.size(), 2u);
  // PROJ's transverse Mercator is exact to well under a millimetre this close to the central meridian.
  const double tol = 1e-3;
  EXPECT_NEAR(s.path[0][0], 500000.0, tol);
  EXPECT_NEAR(s.path[0][1], 0.9996 * meridian_arc(36.75), tol);
  EXPECT_NEAR(s.path[1][0], 500000.0, tol);
  EXPECT_NEAR(s.path[1][1], 0.9996 * meridian_arc(36.8), tol);
}

TEST(VectorLayer, LayerWithoutCrsTakesTheOneTheSceneGives) {
  TempDir tmp;
  // GeoJSON without a crs member is WGS 84 by RFC 7946 (GDAL says so); a Shapefile without .prj has no CRS.
  write_layer(tmp.path / "nocrs.shp", "ESRI Shapefile", "nocrs", "", {{"LINESTRING (-87 36.75, -87 36.8)", "L"}});
  expect_refused([&] { read_vector_shape({(tmp.path / "nocrs.shp").string(), "", "", ""}, ShapeKind::line, utm16(), "structures[0].axis"); },
                 "structures[0].axis", "no coordinate reference system");
  const VectorShape s = read_vector_shape({(tmp.path / "nocrs.shp").string(), "", "", "EPSG:4326"}, ShapeKind::line, utm16(),
                                          "structures[0].axis");
  EXPECT_NEAR(s.path[0][0], 500000.0, 1e-3);
}

TEST(VectorLayer, MultipolygonWithAHoleIsTheUnionOfItsPartsLessTheHole) {
  TempDir tmp;
  const fs::path file = tmp.path / "zones.gpkg";
  // Part A: 20 x 20 m with a 10 x 10 m hole in its middle; part B: 10 x 10 m, 30 m east; a second feature C
  // (10 x 5 m) joins them as another part.
  write_layer(file, "GPKG", "zones", "EPSG:32616",
              {{"MULTIPOLYGON (((0 0, 20 0, 20 20, 0 20, 0 0), (5 5, 5 15, 15 15, 15 5, 5 5)),"
                "((50 0, 60 0, 60 10, 50 10, 50 0)))", "AB"},
               {"POLYGON ((0 40, 10 40, 10 45, 0 45, 0 40))", "C"}});
  const VectorShape s = read_vector_shape({file.string(), "", "", ""}, ShapeKind::multipolygon, utm16(), "protected_zones[0].polygon");
  EXPECT_EQ(s.parts, 3u);
  EXPECT_EQ(s.holes, 1u);
  EXPECT_EQ(s.features, 2u);
  EXPECT_NEAR(polygon_area(s.path), 400.0 - 100.0 + 100.0 + 50.0, 1e-9);
  EXPECT_TRUE(inside_polygon(s.path, 2, 2));     // part A, outside the hole
  EXPECT_FALSE(inside_polygon(s.path, 10, 10));  // in the hole
  EXPECT_TRUE(inside_polygon(s.path, 55, 5));    // part B
  EXPECT_TRUE(inside_polygon(s.path, 5, 42));    // feature C
  EXPECT_FALSE(inside_polygon(s.path, 35, 5));   // between the parts (the bridges cross here)
  EXPECT_FALSE(inside_polygon(s.path, 30, 25));
  // Containment on a 0.5 m lattice against the geometry itself: every point agrees.
  int disagree = 0;
  for (double y = -4.75; y < 50; y += 0.5)
    for (double x = -4.75; x < 65; x += 0.5) {
      const bool in_a = x > 0 && x < 20 && y > 0 && y < 20 && !(x > 5 && x < 15 && y > 5 && y < 15);
      const bool in_b = x > 50 && x < 60 && y > 0 && y < 10;
      const bool in_c = x > 0 && x < 10 && y > 40 && y < 45;
      disagree += inside_polygon(s.path, x, y) != (in_a || in_b || in_c);
    }
  EXPECT_EQ(disagree, 0);
  const auto rings = split_rings(s.path);
  ASSERT_EQ(rings.size(), 4u);
  EXPECT_NEAR(std::abs(polygon_area(rings[1])), 100.0, 1e-9);  // the hole, as a ring of its own
}

TEST(VectorLayer, RefusalsNameTheFieldAndWhatWasWrong) {
  TempDir tmp;
  const fs::path gpkg = tmp.path / "layouts.gpkg";
  write_layer(gpkg, "GPKG", "dams", "EPSG:32616",
              {{"LINESTRING (0 0, 0 10)", "Dam1"}, {"LINESTRING (5 0, 5 10)", "Dam2"}, {"POINT (1 1)", "P"}});
  write_layer(gpkg, "GPKG", "areas", "EPSG:32616",
              {{"POLYGON ((0 0, 20 0, 20 20, 0 20, 0 0), (5 5, 5 15, 15 15, 15 5, 5 5))", "holed"},
               {"MULTIPOLYGON (((0 0, 1 0, 1 1, 0 0)), ((3 3, 4 3, 4 4, 3 3)))", "two"},
               {"POLYGON ((0 0, 10 10, 10 0, 0 10, 0 0))", "bowtie"}});
  const std::string f = "structures[2].axis";
  const std::string p = gpkg.string();
  expect_refused([&] { read_vector_shape({(tmp.path / "none.gpkg").string(), "", "", ""}, ShapeKind::line, utm16(), f); },
                 f, "cannot open");
  expect_refused([&] { read_vector_shape({p, "", "", ""}, ShapeKind::line, utm16(), f); }, f, "has 2 layers (");
  expect_refused([&] { read_vector_shape({p, "walls", "", ""}, ShapeKind::line, utm16(), f); }, f, "no such layer");
  expect_refused([&] { read_vector_shape({p, "dams", "id = 'Dam9'", ""}, ShapeKind::line, utm16(), f); }, f,
                 "matches no feature");
  expect_refused([&] { read_vector_shape({p, "dams", "id LIKE 'Dam%'", ""}, ShapeKind::line, utm16(), f); }, f,
                 "2 features match");
  expect_refused([&] { read_vector_shape({p, "dams", "nosuchcolumn = 1", ""}, ShapeKind::line, utm16(), f); }, f,
                 "not a filter");
  expect_refused([&] { read_vector_shape({p, "dams", "id = 'P'", ""}, ShapeKind::line, utm16(), f); }, f,
                 "Point; this field takes a LineString");
  const std::string g = "structures[0].polygon";
  expect_refused([&] { read_vector_shape({p, "dams", "id = 'Dam1'", ""}, ShapeKind::polygon, utm16(), g); }, g,
                 "Line String; this field takes a Polygon");
  expect_refused([&] { read_vector_shape({p, "areas", "id = 'holed'", ""}, ShapeKind::polygon, utm16(), g); }, g,
                 "1 parts and 1 holes; this field takes a single ring");
  expect_refused([&] { read_vector_shape({p, "areas", "id = 'two'", ""}, ShapeKind::polygon, utm16(), g); }, g,
                 "2 parts and 0 holes");
  expect_refused([&] { read_vector_shape({p, "areas", "id = 'bowtie'", ""}, ShapeKind::multipolygon, utm16(), "release.polygon"); },
                 "release.polygon", "not valid");
  expect_refused([&] { read_vector_shape({p, "dams", "", "EPSG:999999"}, ShapeKind::line, utm16(), f); }, f,
                 "not a coordinate reference system");
}

TEST(VectorLayer, WorkingCrsIsTheDemsOrTheNamedOne) {
  TempDir tmp;
  Grid g(4, 4, 600000, 4000004, 1, 1, utm16(), 100.0f);
  write_geotiff((tmp.path / "dem.tif").string(), g);
  OGRSpatialReference a, b;
  a.importFromWkt(working_crs_wkt((tmp.path / "dem.tif").string(), {}).c_str());
  b.SetFromUserInput("EPSG:32616");
  EXPECT_TRUE(a.IsSame(&b));
  a.importFromWkt(working_crs_wkt((tmp.path / "dem.tif").string(), {"EPSG:32617", 0.0}).c_str());
  b.SetFromUserInput("EPSG:32617");
  EXPECT_TRUE(a.IsSame(&b));
  expect_refused([&] { working_crs_wkt((tmp.path / "missing.tif").string(), {}); }, "terrain.dem", "cannot open");
}

// A layer read once is answered from the keep while its bytes stay the same; a file rewritten with another
// geometry is read afresh, and so is a shapefile whose sidecar (.dbf: the filter's attribute) changed.
TEST(VectorLayer, AShapeIsReadOnceWhileItsFilesStayTheSame) {
  TempDir tmp;
  const fs::path gpkg = tmp.path / "axes.gpkg";
  write_layer(gpkg, "GPKG", "dams", "EPSG:32616", {{"LINESTRING (500000 4000000, 500010 4000000)", "Dam1"}});
  const LayerRef ref{gpkg.string(), "dams", "", ""};
  const ShapeCacheStats s0 = shape_cache_stats();
  const VectorShape first = read_vector_shape(ref, ShapeKind::line, utm16(), "structures[0].axis");
  const VectorShape again = read_vector_shape(ref, ShapeKind::line, utm16(), "structures[0].axis");
  const ShapeCacheStats s1 = shape_cache_stats();
  EXPECT_EQ(s1.misses - s0.misses, 1);
  EXPECT_EQ(s1.hits - s0.hits, 1);
  EXPECT_EQ(again.path, first.path);

  fs::remove(gpkg);
  write_layer(gpkg, "GPKG", "dams", "EPSG:32616", {{"LINESTRING (500000 4000000, 500020 4000000)", "Dam1"}});
  const VectorShape changed = read_vector_shape(ref, ShapeKind::line, utm16(), "structures[0].axis");
  EXPECT_EQ(shape_cache_stats().misses - s1.misses, 1);
  ASSERT_EQ(changed.path.size(), 2u);
  EXPECT_NEAR(changed.path[1][0] - changed.path[0][0], 20.0, 1e-6);

  // A shapefile: the filter matches Dam1 by its attribute in the .dbf; renaming it there changes the answer.
  const fs::path shp = tmp.path / "axes.shp";
  write_layer(shp, "ESRI Shapefile", "axes", "EPSG:32616",
              {{"LINESTRING (500000 4000000, 500010 4000000)", "Dam1"}, {"LINESTRING (0 0, 1 1)", "Dam2"}});
  const LayerRef by_id{shp.string(), "", "id = 'Dam1'", ""};
  EXPECT_EQ(read_vector_shape(by_id, ShapeKind::line, utm16(), "structures[0].axis").path.size(), 2u);
  for (const char* ext : {".shp", ".shx", ".dbf", ".prj", ".cpg"}) fs::remove(fs::path(shp).replace_extension(ext));
  write_layer(shp, "ESRI Shapefile", "axes", "EPSG:32616", {{"LINESTRING (500000 4000000, 500010 4000000)", "Dam3"}});
  expect_refused([&] { read_vector_shape(by_id, ShapeKind::line, utm16(), "structures[0].axis"); },
                 "structures[0].axis", "matches no feature");
}
