// The web map's coloured rasters (raster_map.hpp): a synthetic run folder's raster rendered to PNG and read
// back with libpng: transparent where nodata, zero or below the scale, the top colour at the maximum, the
// bottom colour at the minimum, classes by their exact colour; the scale is the QGIS style's; bad names refused.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "runout/scenarios/raster_map.hpp"
#include "runout/terrain/raster.hpp"

namespace fs = std::filesystem;
using namespace runout;

namespace {

struct TempRun {
  fs::path path;
  TempRun() {
    path = fs::temp_directory_path() /
           ("runout-raster-map-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(path);
    fs::create_directories(path / "rasters");
    std::ofstream(path / "metrics.json") << R"({"terrain": {"inundation": {"threshold_m": 0.1}}})";
  }
  ~TempRun() { fs::remove_all(path); }
  // A 4 x 3 grid (10 m cells) in UTM 32N written as OUT/rasters/<name>.tif.
  void write(const std::string& name, const std::vector<float>& values) const {
    terrain::Grid g(4, 3, 500000, 5200000, 10, 10, terrain::crs_wkt_from("EPSG:32632"));
    g.values = values;
    terrain::write_geotiff((path / "rasters" / (name + ".tif")).string(), g);
  }
};

struct Pixels {
  int w = 0, h = 0;
  std::vector<unsigned char> rgba;
  std::array<int, 4> at(int x, int y) const {
    const size_t k = 4 * (size_t(y) * w + x);
    return {rgba[k], rgba[k + 1], rgba[k + 2], rgba[k + 3]};
  }
};

Pixels decode(const std::string& png) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  EXPECT_TRUE(png_image_begin_read_from_memory(&img, png.data(), png.size())) << img.message;
  img.format = PNG_FORMAT_RGBA;
  Pixels p{int(img.width), int(img.height), std::vector<unsigned char>(PNG_IMAGE_SIZE(img))};
  EXPECT_TRUE(png_image_finish_read(&img, nullptr, p.rgba.data(), 0, nullptr)) << img.message;
  return p;
}

std::array<int, 4> opaque(const std::string& hex) {
  return {std::stoi(hex.substr(1, 2), nullptr, 16), std::stoi(hex.substr(3, 2), nullptr, 16),
          std::stoi(hex.substr(5, 2), nullptr, 16), 255};
}

const float kNodata = terrain::Grid::nodata;

}  // namespace

TEST(RasterMap, ARampIsTransparentWhereNothingIsAndTopColouredAtTheMaximum) {
  TempRun run;
  run.write("max_speed", {kNodata, 0, 1, 2,  //
                          3, 4, 0, kNodata,  //
                          0, 0, 0, 0});
  const auto p = render_run_raster(run.path, "max_speed");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->scale.min, 0.0);
  EXPECT_EQ(p->scale.max, 4.0);
  EXPECT_EQ(p->scale.unit, "m/s");
  ASSERT_EQ(p->scale.stops.size(), 5u);
  const Pixels px = decode(p->png);
  ASSERT_EQ(px.w, 4);  // one pixel per cell
  ASSERT_EQ(px.h, 3);
  for (auto [x, y] : {std::pair{0, 0}, {1, 0}, {2, 1}, {3, 1}, {0, 2}, {3, 2}}) EXPECT_EQ(px.at(x, y)[3], 0) << x << "," << y;
  EXPECT_EQ(px.at(1, 1), opaque(p->scale.stops.back().colour));  // 4 m/s, the maximum
  EXPECT_EQ(px.at(3, 0), opaque(p->scale.stops[2].colour));      // 2 m/s, the middle stop
  // 1 m/s, a quarter of the way: the second stop exactly.
  EXPECT_EQ(px.at(2, 0), opaque(p->scale.stops[1].colour));
}

TEST(RasterMap, DepthsBelowTheRunsThresholdAreTransparent) {
  TempRun run;
  run.write("max_depth", {0.05f, 0.1f, 0.5f, 0, 0, 0, 0, 0, 0, 0, 0, 0});
  const auto p = render_run_raster(run.path, "max_depth");
  ASSERT_TRUE(p);
  EXPECT_FLOAT_EQ(p->scale.min, 0.1f);  // metrics.json's threshold
  EXPECT_FLOAT_EQ(p->scale.max, 0.5f);
  const Pixels px = decode(p->png);
  EXPECT_EQ(px.at(0, 0)[3], 0);
  EXPECT_EQ(px.at(1, 0), opaque(p->scale.stops.front().colour));
  EXPECT_EQ(px.at(2, 0), opaque(p->scale.stops.back().colour));
}

TEST(RasterMap, ArrivalAtZeroSecondsIsShownAndNeverIsNot) {
  TempRun run;
  run.write("arrival_time", {0, 10, kNodata, kNodata, kNodata, kNodata, kNodata, kNodata, kNodata, kNodata, kNodata, kNodata});
  const auto p = render_run_raster(run.path, "arrival_time");
  ASSERT_TRUE(p);
  const Pixels px = decode(p->png);
  EXPECT_EQ(px.at(0, 0), opaque(p->scale.stops.front().colour));  // the release, at t = 0
  EXPECT_EQ(px.at(1, 0), opaque(p->scale.stops.back().colour));
  EXPECT_EQ(px.at(2, 0)[3], 0);
}

TEST(RasterMap, IntensityClassesTakeTheirColourAndNoClassIsTransparent) {
  TempRun run;
  run.write("max_depth", std::vector<float>(12, 0.0f));
  terrain::Grid classes(4, 3, 500000, 5200000, 10, 10, terrain::crs_wkt_from("EPSG:32632"));
  classes.values = {0, 1, 2, 3, 0, 0, 0, 0, 0, 0, 0, 0};
  terrain::write_class_geotiff((run.path / "rasters" / "intensity.tif").string(), classes, {"class", "class", {}});
  const auto p = render_run_raster(run.path, "intensity");
  ASSERT_TRUE(p);
  EXPECT_TRUE(p->scale.classes);
  const Pixels px = decode(p->png);
  EXPECT_EQ(px.at(0, 0)[3], 0);
  for (int k = 1; k <= 3; ++k) EXPECT_EQ(px.at(k, 0), opaque(p->scale.stops[k - 1].colour)) << "class " << k;
  // Nothing inundated: every cell is the class raster's nodata; the picture is empty, not an error.
  classes.values.assign(12, 0);
  terrain::write_class_geotiff((run.path / "rasters" / "intensity.tif").string(), classes, {"class", "class", {}});
  const auto empty = render_run_raster(run.path, "intensity");
  ASSERT_TRUE(empty);
  const Pixels ex = decode(empty->png);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(ex.at(x, y)[3], 0);
}

TEST(RasterMap, TheScaleIsTheQgisStylesAndUnknownLayersAreRefused) {
  const ColourScale s = hazard_colour_scale("max_pressure", 20000, 0.1);
  EXPECT_EQ(s.unit, "Pa");
  EXPECT_EQ(s.stops.back().label, "20 kPa");
  EXPECT_EQ(s.stops.front().colour, "#ffffcc");
  EXPECT_EQ(s.stops.back().colour, "#253494");
  EXPECT_THROW(hazard_colour_scale("elevation", 1, 0), std::invalid_argument);
  TempRun run;
  EXPECT_THROW(render_run_raster(run.path, "../metrics"), std::invalid_argument);
  EXPECT_FALSE(render_run_raster(run.path, "max_speed"));  // no such raster in the run
  EXPECT_TRUE(run_raster_scales(run.path).empty());
  run.write("max_speed", {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12});
  const auto scales = run_raster_scales(run.path);
  ASSERT_EQ(scales.size(), 1u);
  EXPECT_EQ(scales[0].layer, "max_speed");
  EXPECT_EQ(scales[0].max, 12.0);
}
