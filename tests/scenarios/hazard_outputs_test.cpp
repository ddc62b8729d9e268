// A terrain run's hazard outputs read back with GDAL: every raster with its description, unit, nodata and the
// run's metadata, a QGIS style beside it, the maxima against metrics.json, the polygons' area against the
// inundated area; output.intensity refused out of range; a sweep's difference rasters against its baseline.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <gdal_priv.h>
#include <nlohmann/json.hpp>
#include <ogrsf_frmts.h>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/terrain/raster.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("runout-hazard-out-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// The flume without structures at its draft dp (5 cm) for 0.6 s: the flow leaves the release and runs down
// the chute (at g (sin 38 - cos 38 tan 28) = 1.9 m/s2, about 1 m/s by then).
json short_flume() {
  std::ifstream in(kSource / "scenarios/flume/flume.json");
  json s = json::parse(in);
  s["terrain"]["dem"] = (kSource / "scenarios/flume/flume_dem.asc").string();
  s.erase("structures");
  json monitors = json::array();
  for (const auto& m : s["monitors"])
    if (m["type"] == "section") monitors.push_back(m);
  s["monitors"] = monitors;
  s["dp"] = 0.05;  // the flume's draft
  s["duration"] = 0.6;
  s["name"] = "flume-hazard";
  return s;
}

struct Band {
  std::string description, unit, scene;
  bool nodata_set = false;
  double max = 0;
  std::vector<float> values;
};

Band read_band(const fs::path& p) {
  GDALAllRegister();
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(p.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  EXPECT_TRUE(ds) << p;
  Band b;
  if (!ds) return b;
  GDALRasterBand* band = ds->GetRasterBand(1);
  b.description = band->GetDescription();
  b.unit = band->GetUnitType();
  int has = 0;
  band->GetNoDataValue(&has);
  b.nodata_set = has;
  const char* scene = ds->GetMetadataItem("RUNOUT_SCENE");
  b.scene = scene ? scene : "";
  std::vector<float> v(static_cast<size_t>(band->GetXSize()) * band->GetYSize());
  EXPECT_EQ(band->RasterIO(GF_Read, 0, 0, band->GetXSize(), band->GetYSize(), v.data(), band->GetXSize(),
                           band->GetYSize(), GDT_Float32, 0, 0),
            CE_None);
  for (float x : v)
    if (!std::isnan(x)) b.max = std::max(b.max, static_cast<double>(x));
  b.values = std::move(v);
  return b;
}

}  // namespace

TEST(HazardOutputs, EveryRasterDescribesItselfAndAgreesWithTheMetrics) {
  TempDir tmp;
  const Scene scene = parse_scene(short_flume().dump());
  RunOptions opt;
  opt.out_dir = tmp.path;
  opt.threads = 2;
  const RunSummary sum = run_scene(scene, opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;
  const json m = json::parse(sum.metrics_json);
  const json& inund = m.at("terrain").at("inundation");
  const fs::path r = tmp.path / "rasters";
  const std::map<std::string, std::string> units = {{"max_depth", "m"},     {"max_speed", "m/s"},
                                                    {"deposit_depth", "m"}, {"max_hv", "m2/s"},
                                                    {"arrival_time", "s"},  {"max_pressure", "Pa"},
                                                    {"intensity", "class"}};
  for (const auto& [name, unit] : units) {
    SCOPED_TRACE(name);
    const Band b = read_band(r / (name + ".tif"));
    EXPECT_FALSE(b.description.empty());
    EXPECT_EQ(b.unit, unit);
    EXPECT_TRUE(b.nodata_set);
    EXPECT_EQ(b.scene, "flume-hazard");
    EXPECT_TRUE(fs::is_regular_file(r / (name + ".qml")));
    EXPECT_NE(std::find(inund.at("rasters").begin(), inund.at("rasters").end(), "rasters/" + name + ".tif"),
              inund.at("rasters").end());
  }
  EXPECT_FLOAT_EQ(read_band(r / "max_depth.tif").max, inund.at("max_depth_m").get<double>());
  EXPECT_FLOAT_EQ(read_band(r / "max_pressure.tif").max, inund.at("max_pressure_pa").get<double>());
  EXPECT_FLOAT_EQ(read_band(r / "max_hv.tif").max, inund.at("max_hv_m2_s").get<double>());
  // The flow ran (debris at 2000 kg/m3 down a 38 degree chute reaches metres per second): the pressure is
  // rho v^2 of a speed below the fastest particle's.
  const double vmax = inund.at("max_speed_m_s").get<double>();
  EXPECT_GT(inund.at("max_pressure_pa").get<double>(), 2000.0 * 0.5 * 0.5);
  EXPECT_LE(inund.at("max_pressure_pa").get<double>(), 2000.0 * vmax * vmax * (1 + 1e-6));

  // The polygons: the inundated area as the metric has it, and the intensity classes summing to it.
  std::unique_ptr<GDALDataset> gpkg(GDALDataset::Open((r / "hazard.gpkg").c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
  ASSERT_TRUE(gpkg);
  auto layer_area = [&](const char* name) {
    double a = 0;
    for (auto& f : *gpkg->GetLayerByName(name)) a += f->GetGeometryRef()->toPolygon()->get_Area();
    return a;
  };
  const double cell = inund.at("cell_size_m").get<double>();
  const double row = cell * cell * 300;  // one row of the window: at most 300 cells (the 6 m flume at 2 cm)
  const double area = inund.at("inundated_area_m2").get<double>();
  ASSERT_GT(area, 0.0);
  EXPECT_NEAR(layer_area("inundated"), area, row);
  EXPECT_NEAR(layer_area("intensity"), area, row);
  double classes = 0;
  for (const auto& [k, v] : inund.at("intensity_area_m2").items()) classes += v.get<double>();
  EXPECT_NEAR(classes, area, 1e-9 * area);
}

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Cells the flow never reached are nodata, not 0, in every raster of the maxima and the deposit, and the QGIS
// styles do not paint what lies outside their ramp (clip="1"): before, every dry cell of the window held 0 and
// was painted in the ramp's first colour over the basemap.
TEST(HazardOutputs, DryCellsAreNodataAndTheStylesDoNotPaintThem) {
  TempDir tmp;
  RunOptions opt;
  opt.out_dir = tmp.path;
  opt.threads = 2;
  const RunSummary sum = run_scene(parse_scene(short_flume().dump()), opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;
  const double threshold = json::parse(sum.metrics_json).at("terrain").at("inundation").at("threshold_m");
  const fs::path r = tmp.path / "rasters";
  const Band depth = read_band(r / "max_depth.tif");
  size_t dry = 0;
  for (float v : depth.values) {
    EXPECT_NE(v, 0.0f) << "a dry cell holds 0 rather than nodata";
    dry += std::isnan(v);
  }
  ASSERT_GT(dry, depth.values.size() / 10) << "after 0.6 s most of the corridor's window is still dry";
  ASSERT_LT(dry, depth.values.size());
  for (const char* name : {"max_speed", "max_hv", "max_pressure"}) {
    SCOPED_TRACE(name);
    const Band b = read_band(r / (std::string(name) + ".tif"));
    ASSERT_EQ(b.values.size(), depth.values.size());
    for (size_t c = 0; c < b.values.size(); ++c) {
      if (std::isnan(depth.values[c])) EXPECT_TRUE(std::isnan(b.values[c])) << "cell " << c << " is dry but holds " << b.values[c];
      else if (std::string(name) != "max_pressure" || depth.values[c] >= threshold) EXPECT_FALSE(std::isnan(b.values[c])) << c;
    }
  }
  for (float v : read_band(r / "deposit_depth.tif").values) EXPECT_NE(v, 0.0f) << "no deposit is nodata, not 0";
  for (const char* name : {"max_depth", "max_speed", "deposit_depth", "max_hv", "arrival_time", "max_pressure"}) {
    const std::string qml = file_text(r / (std::string(name) + ".qml"));
    EXPECT_NE(qml.find("clip=\"1\""), std::string::npos) << name;
    EXPECT_EQ(qml.find("clip=\"0\""), std::string::npos) << name;
  }
}

// The structures as built are layers of the run's hazard.gpkg: the check dam's axis as a line and the basin as a
// polygon, each with the numbers metrics.json gives it (crest, capacity, what it held at the end).
TEST(HazardOutputs, TheBuiltStructuresAreLayersOfTheGeoPackage) {
  TempDir tmp;
  json s = short_flume();
  std::ifstream in(kSource / "scenarios/flume/flume.json");
  const json flume = json::parse(in);
  for (const auto& st : flume.at("structures"))
    if (st.at("name") == "CD_P1" || st.at("name") == "RB1_P2") s["structures"].push_back(st);
  RunOptions opt;
  opt.out_dir = tmp.path;
  opt.threads = 2;
  const RunSummary sum = run_scene(parse_scene(s.dump()), opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;
  std::map<std::string, json> metrics;
  const json m = json::parse(sum.metrics_json);
  for (const auto& st : m.at("terrain").at("structures")) metrics[st.at("name")] = st;
  ASSERT_EQ(metrics.size(), 2u);
  std::unique_ptr<GDALDataset> gpkg(GDALDataset::Open((tmp.path / "rasters" / "hazard.gpkg").c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
  ASSERT_TRUE(gpkg);
  OGRLayer* dams = gpkg->GetLayerByName("check_dams");
  OGRLayer* areas = gpkg->GetLayerByName("structure_areas");
  ASSERT_TRUE(dams && areas);
  ASSERT_EQ(dams->GetFeatureCount(), 1);
  ASSERT_EQ(areas->GetFeatureCount(), 1);
  std::unique_ptr<OGRFeature> dam(dams->GetNextFeature()), basin(areas->GetNextFeature());
  EXPECT_STREQ(dam->GetFieldAsString("name"), "CD_P1");
  EXPECT_STREQ(dam->GetFieldAsString("type"), "check_dam");
  EXPECT_EQ(wkbFlatten(dam->GetGeometryRef()->getGeometryType()), wkbLineString);
  EXPECT_NEAR(dam->GetGeometryRef()->toLineString()->get_Length(), 0.44, 1e-9);  // the axis, 5000000.38 to .82
  for (const char* f : {"crest_elevation_m", "storage_capacity_m3", "retained_volume_m3", "upstream_volume_m3"})
    EXPECT_DOUBLE_EQ(dam->GetFieldAsDouble(f), metrics["CD_P1"].at(f).get<double>()) << f;
  EXPECT_GT(dam->GetFieldAsDouble("wall_height_m"), 0.05);  // about the 0.1 m crest height
  EXPECT_STREQ(basin->GetFieldAsString("name"), "RB1_P2");
  EXPECT_STREQ(basin->GetFieldAsString("type"), "retention_basin");
  EXPECT_EQ(wkbFlatten(basin->GetGeometryRef()->getGeometryType()), wkbPolygon);
  EXPECT_GT(basin->GetFieldAsDouble("area_m2"), 0.0);
  for (const char* f : {"crest_elevation_m", "storage_capacity_m3", "cut_volume_m3", "retained_volume_m3"})
    EXPECT_DOUBLE_EQ(basin->GetFieldAsDouble(f), metrics["RB1_P2"].at(f).get<double>()) << f;
  OGRSpatialReference want;
  want.importFromEPSG(32632);
  EXPECT_TRUE(dams->GetSpatialRef() && dams->GetSpatialRef()->IsSame(&want));
  // Each layer has its default QGIS style in layer_styles (it was drawn in QGIS's single default colour): the
  // crest a line symbol, the areas by type, both labelled by name.
  OGRLayer* styles = gpkg->GetLayerByName("layer_styles");
  ASSERT_TRUE(styles);
  std::map<std::string, std::string> qml;
  for (auto& f : *styles)
    if (f->GetFieldAsInteger("useAsDefault") == 1) qml[f->GetFieldAsString("f_table_name")] = f->GetFieldAsString("styleQML");
  ASSERT_TRUE(qml.count("check_dams") && qml.count("structure_areas"));
  EXPECT_NE(qml["check_dams"].find("<symbol type=\"line\""), std::string::npos);
  EXPECT_NE(qml["structure_areas"].find("attr=\"type\""), std::string::npos);
  EXPECT_NE(qml["structure_areas"].find("<category value=\"retention_basin\""), std::string::npos);
  for (const auto& [layer, text] : qml)
    if (layer == "check_dams" || layer == "structure_areas")
      EXPECT_NE(text.find("fieldName=\"name\""), std::string::npos) << layer;
  EXPECT_TRUE(qml.count("intensity"));  // the class layers' styles are still there
}

TEST(HazardOutputs, IntensityThresholdsAreReadAndRefusedOutOfRange) {
  json s = short_flume();
  s["output"]["intensity"] = {{"high_depth", 0.5}, {"medium_depth", 0.1}};
  const Scene ok = parse_scene(s.dump());
  EXPECT_DOUBLE_EQ(ok.output.intensity.high_depth, 0.5);
  EXPECT_DOUBLE_EQ(ok.output.intensity.medium_depth, 0.1);
  EXPECT_DOUBLE_EQ(ok.output.intensity.high_hv, 1.0);  // the default
  auto refused = [&](const json& intensity, const std::string& field) {
    json bad = short_flume();
    bad["output"]["intensity"] = intensity;
    try {
      parse_scene(bad.dump());
      ADD_FAILURE() << "accepted " << intensity.dump();
    } catch (const SceneError& e) {
      EXPECT_EQ(e.field, field) << e.what();
    }
  };
  refused({{"high_depth", 0.0}}, "output.intensity.high_depth");
  refused({{"high_hv", 2000.0}}, "output.intensity.high_hv");
  refused({{"medium_depth", 1.5}}, "output.intensity.medium_depth");  // above the default high_depth 1 m
  refused({{"low_depth", 0.1}}, "output.intensity.low_depth");
}

TEST(HazardOutputs, SweepDifferenceRastersAreTheLayoutMinusTheBaseline) {
  TempDir tmp;
  const std::string crs = terrain::crs_wkt_from("EPSG:32632");
  // C0's window is 4 x 3 cells of 0.5 m; C1's is shifted one cell east (its corridor differs).
  terrain::Grid c0(4, 3, 500000, 5000003, 0.5, 0.5, crs, 0.25f), c1(4, 3, 500000.5, 5000003, 0.5, 0.5, crs, 1.0f);
  c1.at(3, 2) = 0.0f;
  c0.at(2, 1) = c1.at(1, 1) = terrain::Grid::nodata;  // the same cell, dry in both layouts
  for (const char* name : {"max_depth", "max_hv"}) {
    terrain::write_geotiff((tmp.path / "C0" / "rasters" / (std::string(name) + ".tif")).string(), c0);
    terrain::write_geotiff((tmp.path / "C1" / "rasters" / (std::string(name) + ".tif")).string(), c1);
  }
  fs::create_directories(tmp.path / "C2");  // a layout not run here: skipped
  const auto written = write_difference_rasters(tmp.path, {"C0", "C1", "C2"});
  ASSERT_EQ(written, std::vector<std::string>{"C1"});
  const terrain::Grid d = terrain::load_dem((tmp.path / "C1" / "rasters" / "diff_max_depth.tif").string());
  EXPECT_EQ(d.nx, 5);
  EXPECT_FLOAT_EQ(d.at(0, 0), -0.25f);  // only C0
  EXPECT_FLOAT_EQ(d.at(1, 0), 0.75f);   // both
  EXPECT_FLOAT_EQ(d.at(4, 0), 1.0f);    // only C1
  EXPECT_FLOAT_EQ(d.at(4, 2), 0.0f);
  EXPECT_TRUE(std::isnan(d.at(2, 1))) << "dry in both: nodata, not a difference of 0";
  EXPECT_NE(file_text(tmp.path / "C1" / "rasters" / "diff_max_depth.qml").find("clip=\"1\""), std::string::npos);
  const Band b = read_band(tmp.path / "C1" / "rasters" / "diff_max_hv.tif");
  EXPECT_EQ(b.unit, "m2/s");
  EXPECT_TRUE(fs::is_regular_file(tmp.path / "C1" / "rasters" / "diff_max_hv.qml"));
  EXPECT_FALSE(fs::exists(tmp.path / "C0" / "rasters" / "diff_max_depth.tif"));
}
