// output.rest_speed: a run ends before its duration once every flow particle (or the share rest_quantile of
// them) has stayed slower than rest_speed for rest_time; a flow still moving runs to the end. metrics.json says
// which happened.
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

// Both in one scene, in two tanks side by side: a 1.0 m wide layer 0.08 m deep (200 particles, at rest) and a
// 0.2 m dam break in a 0.6 m tank (100 particles, a third of the flow, moving).
json layer_beside_dam_break(double rest_quantile) {
  json j = tank(false);
  j["boundaries"].push_back({{"type", "tank"}, {"min", {1.0, 0}}, {"max", {2.0, 0.4}}});
  j["fluid"].push_back({{"min", {1.0, 0}}, {"max", {2.0, 0.08}}, {"material", "water"}});
  j["duration"] = 0.4;
  j["output"]["rest_quantile"] = rest_quantile;
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

// With rest_quantile 0.5 the run may end while up to half the particles still move: the layer (two thirds) is
// at rest within the time the layer alone takes (above), so the run ends early while the dam break still runs.
// With 0.9 only a tenth may move, and the dam break, a third of the flow, is never at rest within 0.4 s (above):
// the run goes on to its end.
TEST(RestStop, AQuantileLetsAFewParticlesMove) {
  const json half = run(layer_beside_dam_break(0.5), "quantile-half");
  ASSERT_EQ(half["status"], "completed") << half.dump(2);
  ASSERT_FALSE(half["rest"]["ended_at_s"].is_null()) << half["rest"].dump();
  EXPECT_LT(half["rest"]["ended_at_s"].get<double>(), 0.4);
  EXPECT_DOUBLE_EQ(half["rest"]["quantile"].get<double>(), 0.5);
  EXPECT_GT(half["final_speed"]["max_m_s"].get<double>(), 0.05) << "the dam break was at rest: nothing tested";

  const json tenth = run(layer_beside_dam_break(0.9), "quantile-tenth");
  ASSERT_EQ(tenth["status"], "completed") << tenth.dump(2);
  EXPECT_TRUE(tenth["rest"]["ended_at_s"].is_null()) << tenth["rest"].dump();
  EXPECT_GE(tenth["simulated_time_s"].get<double>(), 0.4);
}

// An empty tank fed by an inlet whose hydrograph is zero for 0.2 s, then 0.5 m/s for 0.2 s, then zero: at the
// start the only particles are the inlet's buffer, standing still. A flow waiting for its inflow is not at
// rest: the run must not end before the hydrograph has, and the inflow must have come in.
TEST(RestStop, AFlowWaitingForItsInflowIsNotAtRest) {
  json j = tank(true);
  j.erase("fluid");
  j["boundaries"][0]["max"] = {1.0, 0.4};
  j["duration"] = 1.0;
  j["inlets"] = json::parse(R"([{"material": "water", "direction": "+x", "at": 0.1, "min": [0], "max": [0.06],
                                 "speed": [[0, 0], [0.2, 0], [0.21, 0.5], [0.4, 0.5], [0.41, 0]]}])");
  const json m = run(j, "inflow");
  ASSERT_EQ(m["status"], "completed") << m.dump(2);
  EXPECT_GT(m["mass"]["inflow_kg"].get<double>(), 0.0);
  if (!m["rest"]["ended_at_s"].is_null())
    EXPECT_GE(m["rest"]["ended_at_s"].get<double>(), 0.41 + 0.1) << m["rest"].dump();
}
