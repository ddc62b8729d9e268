// output.rest_speed: a run ends before its duration once every flow particle has stayed slower than rest_speed
// for rest_time; a flow still moving runs to the end. metrics.json says which happened.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

// Water in a 0.6 x 0.4 m tank: a layer across the whole floor (hydrostatic, at rest) or a 0.2 m column against
// one wall (a dam break).
json tank(bool layer) {
  json j = json::parse(R"({
    "name": "rest", "dimensions": 2, "dp": 0.02, "duration": 2.0,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}],
    "output": {"rest_speed": 0.05, "rest_time": 0.1, "series_interval": 0.01}
  })");
  json block = {{"min", {0, 0}}, {"material", "water"}};
  block["max"] = layer ? json::array({0.6, 0.1}) : json::array({0.2, 0.2});
  j["fluid"] = json::array({block});
  return j;
}

json run(const json& j, const std::string& label) {
  const fs::path dir = fs::temp_directory_path() / ("runout-rest-" + label);
  fs::remove_all(dir);
  RunOptions opt;
  opt.out_dir = dir;
  run_scene(parse_scene(j.dump()), opt);
  std::ifstream in(dir / "metrics.json");
  std::stringstream s;
  s << in.rdbuf();
  fs::remove_all(dir);
  return json::parse(s.str());
}

}  // namespace

// A layer starting hydrostatic has only start-up transients, a few mm/s, far under 5 % of its gravity-wave
// speed sqrt(g H) = 1 m/s: it is at rest within a few acoustic periods and the run ends after rest_time.
TEST(RestStop, AFlowAtRestEndsTheRunEarly) {
  const json m = run(tank(true), "layer");
  ASSERT_EQ(m["status"], "completed") << m.dump(2);
  const double ended = m["rest"]["ended_at_s"].get<double>();
  EXPECT_GE(ended, 0.1);
  EXPECT_LT(ended, 1.0);
  EXPECT_DOUBLE_EQ(m["simulated_time_s"].get<double>(), ended);
}

// A dam break's front runs at about 2 sqrt(g H) = 2.8 m/s: never at rest within 0.4 s, it runs to the end.
TEST(RestStop, AMovingFlowRunsItsWholeDuration) {
  json j = tank(false);
  j["duration"] = 0.4;
  const json m = run(j, "column");
  ASSERT_EQ(m["status"], "completed") << m.dump(2);
  EXPECT_TRUE(m["rest"]["ended_at_s"].is_null()) << m["rest"].dump();
  EXPECT_GE(m["simulated_time_s"].get<double>(), 0.4);
}
