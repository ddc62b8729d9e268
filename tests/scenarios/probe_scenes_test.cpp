// The point probes' scene side: refusals name the field and what is accepted (a point's length, the domain's
// range, the corridor, the declared ranges of wet_kernel_sum and spacing); points land where the scene says
// (terrain: map coordinates less the local origin, heights from the bed); a short run on the flume writes each
// probe's series and summary.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kSource = RUNOUT_SOURCE_DIR;

// A water column in a 2D tank (0.6 m x 0.4 m, dp 0.02 m).
json tank_2d(const json& monitor) {
  json s = json::parse(R"({
    "dimensions": 2, "dp": 0.02, "duration": 0.1,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000}],
    "fluid": [{"min": [0, 0], "max": [0.2, 0.2], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}]
  })");
  s["monitors"] = {monitor};
  return s;
}

json tank_3d(const json& monitor) {
  json s = json::parse(R"({
    "dimensions": 3, "dp": 0.02, "duration": 0.1,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000}],
    "fluid": [{"min": [0, 0, 0], "max": [0.1, 0.1, 0.1], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0, 0], "max": [0.2, 0.2, 0.2]}]
  })");
  s["monitors"] = {monitor};
  return s;
}

// The flume (docs/study.md) without structures at its draft dp, with these monitors.
json flume(const json& monitors, double duration = 0.05) {
  std::ifstream in(kSource / "scenarios/flume/flume.json");
  json s = json::parse(in);
  s["terrain"]["dem"] = (kSource / "scenarios/flume/flume_dem.asc").string();
  s.erase("structures");
  s["monitors"] = monitors;
  s["dp"] = 0.05;
  s["duration"] = duration;
  return s;
}

// The SceneError parse_scene throws: its field, and whether its message holds each text.
void expect_refused(const json& scene, const std::string& field, const std::vector<std::string>& contains) {
  try {
    parse_scene(scene.dump());
    ADD_FAILURE() << "accepted; expected a refusal of " << field;
  } catch (const SceneError& e) {
    EXPECT_EQ(e.field, field) << e.what();
    for (const auto& c : contains) EXPECT_NE(std::string(e.what()).find(c), std::string::npos) << e.what() << " lacks " << c;
  }
}

json probe(const json& point, const std::string& name = "P") {
  return {{"type", "pressure_probe"}, {"name", name}, {"point", point}};
}
json gauge() { return {{"type", "depth_gauge"}, {"name", "G"}}; }

}  // namespace

TEST(ProbeScenes, ABadPointIsRefusedNamingItsFieldAndRange) {
  expect_refused(tank_2d(probe({0.1, 0.1, 0.1})), "monitors[0].point", {"array of 2 numbers"});
  expect_refused(tank_3d(probe({0.1, 0.1})), "monitors[0].point", {"array of 3 numbers"});
  expect_refused(tank_2d(probe({0.1, "a"})), "monitors[0].point[1]", {"must be a number in"});
  expect_refused(tank_2d(probe({2.0, 0.1})), "monitors[0].point[0]", {"x must be in [", "] m, in the domain", "got 2"});
  expect_refused(tank_2d(probe({0.1, -1.0})), "monitors[0].point[1]", {"y must be at least", "domain"});
  expect_refused(tank_3d(probe({0.1, 0.5, 0.05})), "monitors[0].point[1]", {"y must be in", "domain"});
  json sum = probe({0.1, 0.1});
  sum["wet_kernel_sum"] = 0;
  expect_refused(tank_2d(sum), "monitors[0].wet_kernel_sum", {"(0, 1]"});
  json unknown = probe({0.1, 0.1});
  unknown["height"] = 0.1;
  expect_refused(tank_2d(unknown), "monitors[0].height", {"unknown field", "point", "wet_kernel_sum"});
}

TEST(ProbeScenes, ADepthGaugeTakesOnePointOrOneLine) {
  expect_refused(tank_2d(gauge()), "monitors[0].point", {"one of point or line"});
  json both = gauge();
  both["point"] = {0.1, 0.0};
  both["line"] = {{0.05, 0.0}, {0.15, 0.0}};
  expect_refused(tank_2d(both), "monitors[0].point", {"one of point or line"});
  json floor = gauge();
  floor["point"] = {0.05, 0.05, 0.0};
  floor["floor"] = 0.0;
  expect_refused(tank_3d(floor), "monitors[0].floor", {"only with a line"});
  json sum = gauge();
  sum["point"] = {0.1, 0.0};
  sum["wet_kernel_sum"] = 0.4;
  expect_refused(tank_2d(sum), "monitors[0].wet_kernel_sum", {"[0.5, 1)"});
  json dense = gauge();
  dense["line"] = {{0.0, 0.0}, {0.2, 0.0}};
  dense["spacing"] = 1e-6;
  expect_refused(tank_2d(dense), "monitors[0].spacing", {"200001 stations", "at most 100000"});
  json off = gauge();
  off["line"] = {{0.05, 0.05}, {0.05, 0.9}};
  expect_refused(tank_3d(off), "monitors[0].line", {"y must be in", "domain"});

  // Stations every dp (or `spacing`), ends included, their feet on the line (2D: its y) or at `floor` (3D).
  json line = gauge();
  line["line"] = {{0.0, 0.0}, {0.1, 0.05}};
  line["spacing"] = 0.03;
  const Scene s2 = parse_scene(tank_2d(line).dump());
  const MonitorSpec& m2 = s2.monitors.at(0);
  ASSERT_EQ(m2.probe_points.size(), 5u);  // 0.112 m in 4 intervals of 0.028 m
  EXPECT_NEAR(m2.probe_points[2][0], 0.05, 1e-12);
  EXPECT_NEAR(m2.probe_points[2][1], 0.025, 1e-12);
  EXPECT_NEAR(m2.probe_stations.back(), std::hypot(0.1, 0.05), 1e-12);
  json plan = gauge();
  plan["line"] = {{0.02, 0.05}, {0.18, 0.05}};
  plan["floor"] = 0.01;
  const Scene s3 = parse_scene(tank_3d(plan).dump());
  ASSERT_EQ(s3.monitors.at(0).probe_points.size(), 9u);  // 0.16 m at dp = 0.02 m
  EXPECT_EQ(s3.monitors.at(0).probe_points[4][2], 0.01);
  EXPECT_EQ(s3.monitors.at(0).number("wet_kernel_sum"), 0.5);
}

TEST(ProbeScenes, OnTerrainPointsAreMapCoordinatesOverTheBed) {
  // The flume's corridor is x in [500000, 500006], y in [5000000, 5000001.2] (EPSG:32632).
  expect_refused(flume(json::array({probe({500010.0, 5000000.6})})), "monitors[0].point", {"off the modelled corridor"});
  expect_refused(flume(json::array({probe({500000.35, 5000000.6, -0.1})})), "monitors[0].point[2]", {"above the bed", "at least 0"});
  expect_refused(flume(json::array({probe({500000.35})})), "monitors[0].point", {"array of 2 or 3 numbers"});
  json foot = gauge();
  foot["point"] = {500000.35, 5000000.6, 3.0};
  expect_refused(flume(json::array({foot})), "monitors[0].point", {"array of 2 numbers"});
  json floor = gauge();
  floor["line"] = {{500000.35, 5000000.4}, {500000.35, 5000000.8}};
  floor["floor"] = 3.0;
  expect_refused(flume(json::array({floor})), "monitors[0].floor", {"only with a 3D line off terrain"});

  json line = gauge();
  line["line"] = {{500000.35, 5000000.4}, {500000.35, 5000000.8}};
  const Scene s = parse_scene(flume(json::array({probe({500000.35, 5000000.6}), probe({500000.35, 5000000.6, 0.1}, "P2"), line})).dump());
  const auto& setup = std::get<SceneSetup<3>>(s.setup);
  const auto tm = s.terrain;
  ASSERT_TRUE(tm);
  const double x = 0.35 + 500000 - tm->origin_x, y = 0.6 + 5000000 - tm->origin_y, bed = tm->bed_at(x, y);
  const auto& p = s.monitors.at(0).probe_points.at(0);
  EXPECT_NEAR(p[0], x, 1e-9);
  EXPECT_NEAR(p[1], y, 1e-9);
  EXPECT_NEAR(p[2], bed + setup.config.smoothing_length, 1e-9);  // default: h above the bed
  EXPECT_NEAR(s.monitors.at(1).probe_points.at(0)[2], bed + 0.1, 1e-9);
  const auto& stations = s.monitors.at(2).probe_points;
  ASSERT_EQ(stations.size(), 9u);  // 0.4 m at dp = 0.05 m
  for (const auto& q : stations) EXPECT_NEAR(q[2], tm->bed_at(q[0], q[1]), 1e-9);
}

TEST(ProbeScenes, ARunWritesEachProbesSeriesAndSummary) {
  // The flume's release (x 0.1-0.6 m, y 0.45-0.75 m on the 38 degree chute, 5 layers of 0.05 m): both probes
  // stand in it, a third over the plain far downstream, dry for the 0.05 s run.
  json line = gauge();
  line["name"] = "across";
  line["line"] = {{500000.35, 5000000.3}, {500000.35, 5000000.9}};
  const json monitors = {probe({500000.35, 5000000.6}), {{"type", "pressure_probe"}, {"name", "dry"}, {"point", {500005.0, 5000000.6}}},
                         line};
  const fs::path out = fs::temp_directory_path() / "runout-probe-scenes-run";
  fs::remove_all(out);
  RunOptions opt;
  opt.out_dir = out;
  opt.threads = 1;  // 300 particles: a second thread only waits at the barriers (long waits on a loaded machine)
  const RunSummary sum = run_scene(parse_scene(flume(monitors).dump()), opt);
  ASSERT_EQ(sum.status, "completed") << sum.error;
  auto header = [&](const std::string& file) {
    std::ifstream in(out / "series" / file);
    std::string h;
    std::getline(in, h);
    return h;
  };
  EXPECT_EQ(header("pressure_probe_P.csv"), "t,pressure_pa,kernel_sum,wet");
  EXPECT_EQ(header("depth_gauge_across.csv"), "t,depth_m,surface_m,station_m");
  const json m = json::parse(sum.metrics_json);
  std::map<std::string, json> by_name;
  for (const auto& mon : m.at("monitors")) by_name[mon.at("name").get<std::string>()] = mon;
  ASSERT_TRUE(by_name.count("P") && by_name.count("dry") && by_name.count("across"));
  const json& p = by_name["P"];
  EXPECT_EQ(p.at("type"), "pressure_probe");
  for (const char* key : {"peak_pressure_pa", "time_of_peak_s", "mean_wet_pressure_pa", "arrival_time_s", "wet_fraction"})
    EXPECT_TRUE(p.contains(key)) << key;
  EXPECT_GT(p.at("peak_pressure_pa").get<double>(), 0.0);
  EXPECT_EQ(p.at("arrival_time_s").get<double>(), 0.0);
  EXPECT_EQ(by_name["dry"].at("wet_fraction").get<double>(), 0.0);
  EXPECT_EQ(by_name["dry"].at("peak_pressure_pa").get<double>(), 0.0);
  const json& g = by_name["across"];
  for (const char* key : {"max_depth_m", "time_of_max_depth_s", "final_depth_m", "station_of_max_depth_m"})
    EXPECT_TRUE(g.contains(key)) << key;
  // The release is 5 layers of dp = 0.25 m deep (vertical columns on the chute); 0.05 s later it has barely
  // moved. The level where the fluid fraction is 1/2 over a bed sloping at 38 degrees: within dp of it.
  std::printf("  flume release: depth gauge %.4f m at the end (max %.4f m at t = %.3f s, %.3f m along), probe peak "
              "%.1f Pa\n",
              g.at("final_depth_m").get<double>(), g.at("max_depth_m").get<double>(),
              g.at("time_of_max_depth_s").get<double>(), g.at("station_of_max_depth_m").get<double>(),
              p.at("peak_pressure_pa").get<double>());
  EXPECT_NEAR(g.at("final_depth_m").get<double>(), 0.25, 0.05);
  fs::remove_all(out);
}
