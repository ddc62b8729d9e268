// Hazard outputs on synthetic grids: max h v and max pressure from the inundation grid, the intensity classes
// against hand-computed thresholds, rasters' description / unit / nodata / metadata read back with GDAL, the
// polygons' area against the raster's, difference grids, QGIS styles.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>
#include <sqlite3.h>

#include "runout/terrain/hazard.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using namespace runout;
using namespace runout::terrain;

namespace {

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-hazard-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// A flat 10 m x 10 m model of 1 m cells, dp 1 m, local origin at the DEM's south-west corner: a particle at
// local (i + 0.5, j + 0.5) covers exactly one cell.
TerrainModel flat_model() {
  TerrainModel m;
  m.dem = std::make_shared<const Grid>(10, 10, 600000, 4000010, 1, 1, crs_wkt_from("EPSG:32616"), 100.0f);
  m.bed = *m.dem;
  m.origin_x = 600000;
  m.origin_y = 4000000;
  m.dp = 1.0;
  return m;
}

// Cell (i, j) of the inundation window for a local point (x, y).
float at_local(const Grid& g, double x, double y) {
  int i, j;
  EXPECT_TRUE(g.cell_of(600000 + x, 4000000 + y, i, j));
  return g.at(i, j);
}

}  // namespace

TEST(HazardGrids, MaxHvIsTheMaxOverTimeOfDepthTimesSpeedNotTheProductOfTheMaxima) {
  const TerrainModel m = flat_model();
  InundationGrid g(m);
  // Cell A at local (2.5, 2.5): first 1 m deep at 1 m/s (h v = 1), then 0.5 m deep at 4 m/s (h v = 2).
  // Cell B at (6.5, 6.5): two particles of 0.5 m3 at 1 and 3 m/s at once: h = 1 m, mean speed 2 m/s, h v = 2.
  g.update({Vec<3>(2.5, 2.5, 100)}, {1.0}, {1.0}, 0.0, 0.1, {2000.0});
  g.update({Vec<3>(2.5, 2.5, 100), Vec<3>(6.5, 6.5, 100), Vec<3>(6.5, 6.5, 100)}, {0.5, 0.5, 0.5}, {4.0, 1.0, 3.0},
           1.0, 0.1, {2000.0, 2000.0, 2000.0});
  EXPECT_FLOAT_EQ(at_local(g.max_depth(), 2.5, 2.5), 1.0f);
  EXPECT_FLOAT_EQ(at_local(g.max_speed(), 2.5, 2.5), 4.0f);
  EXPECT_FLOAT_EQ(at_local(g.max_hv(), 2.5, 2.5), 2.0f);  // max(1 x 1, 0.5 x 4), not 1 x 4
  EXPECT_FLOAT_EQ(at_local(g.max_hv(), 6.5, 6.5), 2.0f);  // 1 m x the volume-weighted mean speed 2 m/s
  // rho v^2: A max(2000 x 1, 2000 x 16) = 32 kPa; B the volume-weighted mean 2000 x (1 + 9) / 2 = 10 kPa.
  EXPECT_FLOAT_EQ(at_local(g.max_pressure(), 2.5, 2.5), 32000.0f);
  EXPECT_FLOAT_EQ(at_local(g.max_pressure(), 6.5, 6.5), 10000.0f);
  EXPECT_FLOAT_EQ(at_local(g.max_hv(), 4.5, 4.5), 0.0f);
  EXPECT_FLOAT_EQ(at_local(g.arrival_time(), 6.5, 6.5), 1.0f);
}

TEST(HazardGrids, EachUpdateDepthIsThatUpdatesFlowOnly) {
  // The current depth holds the last update's flow: a cell the flow has left reads 0 again (only the cells an
  // update reaches are reset and scanned), while the maxima and the arrival keep what passed.
  const TerrainModel m = flat_model();
  InundationGrid g(m);
  g.update({Vec<3>(2.5, 2.5, 100)}, {1.0}, {1.0}, 0.0, 0.1);
  EXPECT_FLOAT_EQ(at_local(g.depth(), 2.5, 2.5), 1.0f);
  g.update({Vec<3>(7.5, 2.5, 100)}, {0.5}, {2.0}, 1.0, 0.1);
  EXPECT_FLOAT_EQ(at_local(g.depth(), 2.5, 2.5), 0.0f);
  EXPECT_FLOAT_EQ(at_local(g.depth(), 7.5, 2.5), 0.5f);
  EXPECT_FLOAT_EQ(at_local(g.max_depth(), 2.5, 2.5), 1.0f);
  EXPECT_FLOAT_EQ(at_local(g.max_hv(), 7.5, 2.5), 1.0f);
  EXPECT_FLOAT_EQ(at_local(g.arrival_time(), 7.5, 2.5), 1.0f);
  g.update({}, {}, {}, 2.0, 0.1);
  double total = 0;
  for (float v : g.depth().values) total += v;
  EXPECT_EQ(total, 0.0);
  EXPECT_FLOAT_EQ(at_local(g.max_depth(), 7.5, 2.5), 0.5f);
}

TEST(HazardGrids, MaxHvEqualsDepthTimesSpeedForAUniformSheet) {
  // A 0.3 m sheet of dp = 0.5 m particles (each spread over four cells' quarters) moving at 2.5 m/s: every
  // fully covered cell has h = 0.3 m and h v = 0.75 m2/s, the pressure 1800 x 2.5^2 = 11.25 kPa.
  TerrainModel m = flat_model();
  m.dp = 0.5;
  InundationGrid g(m);
  std::vector<Vec<3>> pos;
  for (double y = 2.25; y < 8; y += 0.5)
    for (double x = 2.25; x < 8; x += 0.5) pos.push_back(Vec<3>(x, y, 100));
  const std::vector<real> vol(pos.size(), 0.3 * 0.25), speed(pos.size(), 2.5), rho(pos.size(), 1800.0);
  g.update(pos, vol, speed, 0.0, 0.1, rho);
  int full = 0;
  for (int j = 0; j < g.max_depth().ny; ++j)
    for (int i = 0; i < g.max_depth().nx; ++i) {
      const float h = g.max_depth().at(i, j);
      EXPECT_NEAR(g.max_hv().at(i, j), h * 2.5f, 1e-6) << i << "," << j;
      if (std::abs(h - 0.3f) < 1e-6) {
        ++full;
        EXPECT_NEAR(g.max_pressure().at(i, j), 11250.0f, 1e-2);
      }
    }
  EXPECT_EQ(full, 36);  // the 6 x 6 cells from local 2 to 8
}

TEST(HazardGrids, IntensityClassesFollowTheThresholds) {
  // Thresholds high h >= 1 m or h v >= 1 m2/s, medium h >= 0.2 m or h v >= 0.2 m2/s; inundated from 0.1 m.
  Grid h(8, 1, 0, 1, 1, 1), q(8, 1, 0, 1, 1, 1);
  const float depth[8] = {0.05f, 0.1f, 0.19f, 0.2f, 0.5f, 0.99f, 1.0f, 0.15f};
  const float hv[8] = {5.0f, 0.0f, 0.19f, 0.0f, 0.5f, 1.0f, 0.0f, 0.2f};
  // 0.05 m: not inundated, whatever h v; 0.1: low; 0.19/0.19: low; 0.2 m: medium; 0.5/0.5: medium;
  // 0.99 m with h v 1.0: high; 1.0 m: high; 0.15 m with h v 0.2: medium.
  const float expected[8] = {0, 1, 1, 2, 2, 3, 3, 2};
  for (int i = 0; i < 8; ++i) h.at(i, 0) = depth[i], q.at(i, 0) = hv[i];
  const Grid c = intensity_classes(h, q, IntensityThresholds{}, 0.1);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(c.at(i, 0), expected[i]) << "cell " << i;
  // Other thresholds move the classes.
  const Grid c2 = intensity_classes(h, q, IntensityThresholds{0.5, 2.0, 0.15, 0.5}, 0.1);
  const float expected2[8] = {0, 1, 2, 2, 3, 3, 3, 2};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(c2.at(i, 0), expected2[i]) << "cell " << i;
}

TEST(HazardRasters, DescriptionUnitNodataAndMetadataAreWritten) {
  TempDir tmp;
  Grid g(3, 2, 600000, 4000002, 1, 1, crs_wkt_from("EPSG:32616"), 0.5f);
  g.at(1, 1) = Grid::nodata;
  const std::string path = (tmp.path / "max_hv.tif").string();
  write_geotiff(path, g, {"maximum depth x speed", "m2/s", {{"RUNOUT_SCENE", "flume/C3"}, {"RUNOUT_DP_M", "0.02"}}});
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  ASSERT_TRUE(ds);
  GDALRasterBand* b = ds->GetRasterBand(1);
  EXPECT_STREQ(b->GetDescription(), "maximum depth x speed");
  EXPECT_STREQ(b->GetUnitType(), "m2/s");
  int has = 0;
  EXPECT_TRUE(std::isnan(b->GetNoDataValue(&has)));
  EXPECT_TRUE(has);
  EXPECT_STREQ(ds->GetMetadataItem("RUNOUT_SCENE"), "flume/C3");
  EXPECT_STREQ(ds->GetMetadataItem("RUNOUT_DP_M"), "0.02");
  EXPECT_FALSE(fs::exists(path + ".aux.xml"));  // everything is inside the GeoTIFF

  Grid classes(3, 2, 600000, 4000002, 1, 1, g.crs_wkt, 0.0f);
  classes.at(0, 0) = 3;
  const std::string cpath = (tmp.path / "intensity.tif").string();
  write_class_geotiff(cpath, classes, {"intensity", "class", {}});
  std::unique_ptr<GDALDataset> cds(GDALDataset::Open(cpath.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  EXPECT_EQ(cds->GetRasterBand(1)->GetRasterDataType(), GDT_Byte);
  EXPECT_EQ(cds->GetRasterBand(1)->GetNoDataValue(&has), 0.0);
  EXPECT_TRUE(has);
  classes.at(1, 0) = 2.5f;
  EXPECT_THROW(write_class_geotiff(cpath, classes, {}), std::invalid_argument);
}

TEST(HazardPolygons, PolygonAreasEqualTheRastersClassAreas) {
  // An L-shaped inundated area with a hole and a separate patch on 2 m x 3 m cells; class 2 inside part of it.
  TempDir tmp;
  Grid c(12, 9, 600000, 4000027, 2, 3, crs_wkt_from("EPSG:32616"), 0.0f);
  size_t ones = 0, twos = 0;
  for (int j = 0; j < 9; ++j)
    for (int i = 0; i < 12; ++i) {
      const bool l = (i < 4 && j < 8) || (j >= 5 && j < 8 && i < 9);
      const bool hole = i == 1 && j == 2;
      const bool patch = i >= 10 && j < 2;
      if ((l && !hole) || patch) c.at(i, j) = (i < 2 && j >= 5) ? 2.0f : 1.0f;
      ones += c.at(i, j) == 1.0f;
      twos += c.at(i, j) == 2.0f;
    }
  Grid any = c.like(0.0f);
  for (size_t k = 0; k < c.values.size(); ++k) any.values[k] = c.values[k] > 0;
  const std::string path = (tmp.path / "hazard.gpkg").string();
  write_class_polygons(path, {{"inundated", &any, {"inundated"}}, {"intensity", &c, {"low", "medium", "high"}}});
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
  ASSERT_TRUE(ds);
  auto area_of = [&](const char* layer, int cls, size_t* features = nullptr) {
    OGRLayer* l = ds->GetLayerByName(layer);
    EXPECT_NE(l, nullptr);
    double a = 0, field = 0;
    size_t n = 0;
    for (auto& f : *l) {
      if (f->GetFieldAsInteger("class") != cls) continue;
      a += f->GetGeometryRef()->toPolygon()->get_Area();
      field += f->GetFieldAsDouble("area_m2");
      ++n;
    }
    EXPECT_DOUBLE_EQ(a, field);
    if (features) *features = n;
    return a;
  };
  // Within one row of cells (the tolerance); GDALPolygonize follows the cell edges, so it is exact.
  const double row = c.nx * c.cell_area();
  size_t parts = 0;
  EXPECT_NEAR(area_of("inundated", 1, &parts), (ones + twos) * c.cell_area(), row);
  EXPECT_EQ(parts, 2u);  // the L (its one-cell hole sieved away) and the patch
  EXPECT_NEAR(area_of("intensity", 1), ones * c.cell_area(), row);
  EXPECT_NEAR(area_of("intensity", 2), twos * c.cell_area(), row);
  OGRLayer* l = ds->GetLayerByName("intensity");
  for (auto& f : *l) EXPECT_STREQ(f->GetFieldAsString("label"), f->GetFieldAsInteger("class") == 1 ? "low" : "medium");
  OGRSpatialReference want;
  want.SetFromUserInput("EPSG:32616");
  EXPECT_TRUE(l->GetSpatialRef() && l->GetSpatialRef()->IsSame(&want));
}

// One-cell specks go (GDALSieveFilter, kPolygonSieveCells = 2): a class-3 cell inside a class-1 block merges into
// it, a lone class-2 cell into "no class"; a two-cell region stays. The flume DEM's CRS (ESRI WKT in its .prj)
// is stored as EPSG:32632, not a custom srs_id 100000; each layer has its default QGIS style in layer_styles,
// a category per class in its colour. Read back with SQLite (the GeoPackage's tables) and OGR.
TEST(HazardPolygons, SpecksAreSievedTheCrsIsEpsgAndEachLayerIsStyled) {
  TempDir tmp;
  const Grid dem = load_dem((fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume/flume_dem.asc").string());
  Grid c(12, 8, dem.x0, dem.y0, dem.dx, dem.dy, dem.crs_wkt, 0.0f);
  for (int j = 1; j < 5; ++j)
    for (int i = 1; i < 5; ++i) c.at(i, j) = 1.0f;  // a 4 x 4 block of class 1
  c.at(2, 2) = 3.0f;                                // a speck of class 3 in it
  c.at(9, 1) = 2.0f;                                // a lone cell of class 2
  c.at(8, 6) = c.at(9, 6) = 2.0f;                   // two cells of class 2: kept
  const std::string path = (tmp.path / "hazard.gpkg").string();
  write_class_polygons(path, {{"intensity", &c, {"low", "medium", "high"}, {"#ffff00", "#ff9900", "#e31a1c"}}});
  {
    GDALAllRegister();
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
    ASSERT_TRUE(ds);
    std::map<int, std::vector<long>> cells;  // per class, each polygon's area in cells
    for (auto& f : *ds->GetLayerByName("intensity"))
      cells[f->GetFieldAsInteger("class")].push_back(std::lround(f->GetGeometryRef()->toPolygon()->get_Area() / c.cell_area()));
    EXPECT_EQ(cells[1], std::vector<long>{16}) << "the block, its speck merged in (no hole)";
    EXPECT_EQ(cells[2], std::vector<long>{2}) << "the two-cell region only";
    EXPECT_EQ(cells.count(3), 0u);
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  auto rows = [&](const std::string& sql) {
    std::vector<std::vector<std::string>> out;
    sqlite3_stmt* st = nullptr;
    EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr), SQLITE_OK) << sql << ": " << sqlite3_errmsg(db);
    while (st && sqlite3_step(st) == SQLITE_ROW) {
      out.emplace_back();
      for (int k = 0; k < sqlite3_column_count(st); ++k) {
        const unsigned char* t = sqlite3_column_text(st, k);
        out.back().push_back(t ? reinterpret_cast<const char*>(t) : "");
      }
    }
    sqlite3_finalize(st);
    return out;
  };
  EXPECT_EQ(rows("SELECT c.srs_id, s.organization, s.organization_coordsys_id FROM gpkg_contents c JOIN "
                 "gpkg_spatial_ref_sys s ON s.srs_id = c.srs_id WHERE c.table_name = 'intensity'"),
            (std::vector<std::vector<std::string>>{{"32632", "EPSG", "32632"}}));
  const auto styles = rows("SELECT f_table_name, f_geometry_column, useAsDefault, styleQML FROM layer_styles");
  ASSERT_EQ(styles.size(), 1u);
  EXPECT_EQ(styles[0][0], "intensity");
  EXPECT_EQ(styles[0][1], "geom");
  EXPECT_EQ(styles[0][2], "1");
  const std::string& qml = styles[0][3];
  EXPECT_NE(qml.find("type=\"categorizedSymbol\" attr=\"class\""), std::string::npos) << qml;
  EXPECT_NE(qml.find("<category value=\"3\" symbol=\"2\" label=\"high\""), std::string::npos) << qml;
  EXPECT_NE(qml.find("name=\"color\" value=\"227,26,28,255\""), std::string::npos) << qml;  // #e31a1c
  // Registered as a table of the GeoPackage (gpkg_contents), as QGIS and OGR expect.
  EXPECT_EQ(rows("SELECT data_type FROM gpkg_contents WHERE table_name = 'layer_styles'"),
            (std::vector<std::vector<std::string>>{{"attributes"}}));
  sqlite3_close(db);
}

TEST(HazardGrids, DifferenceGridCoversTheUnionOfTheWindows) {
  Grid a(3, 2, 100, 20, 1, 1, "", 1.0f), b(2, 3, 101, 21, 1, 1, "", 0.25f);
  a.at(0, 0) = Grid::nodata;
  const Grid d = difference_grid(a, b);
  EXPECT_EQ(d.nx, 3);
  EXPECT_EQ(d.ny, 3);
  EXPECT_DOUBLE_EQ(d.x0, 100);
  EXPECT_DOUBLE_EQ(d.y0, 21);
  // Row 0 (y 20-21) is b only; rows 1-2 overlap where x >= 101. A cell with no value in either grid (outside
  // both, or a's nodata outside b) is nodata, not a difference of 0.
  EXPECT_TRUE(std::isnan(d.at(0, 0)));
  EXPECT_FLOAT_EQ(d.at(1, 0), -0.25f);
  EXPECT_TRUE(std::isnan(d.at(0, 1)));
  EXPECT_FLOAT_EQ(d.at(1, 1), 0.75f);
  EXPECT_FLOAT_EQ(d.at(0, 2), 1.0f);
  Grid shifted(2, 2, 100.5, 20, 1, 1);
  EXPECT_THROW(difference_grid(a, shifted), std::invalid_argument);
}

TEST(HazardStyles, QmlHasOneEntryPerStop) {
  TempDir tmp;
  const std::string path = (tmp.path / "intensity.qml").string();
  write_qml(path, {{1, "#ffff00", "low"}, {2, "#ff9900", "medium"}, {3, "#e31a1c", "high & up"}}, true);
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  const std::string q = s.str();
  EXPECT_NE(q.find("type=\"paletted\""), std::string::npos);
  size_t n = 0;
  for (size_t at = q.find("<paletteEntry"); at != std::string::npos; at = q.find("<paletteEntry", at + 1)) ++n;
  EXPECT_EQ(n, 3u);
  EXPECT_NE(q.find("label=\"high &amp; up\""), std::string::npos);
}
