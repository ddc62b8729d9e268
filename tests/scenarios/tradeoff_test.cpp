// Speed against accuracy (runout/scenarios/tradeoff.hpp): the convergence analysis on known sequences, and a
// real ladder of a small scene run, stored and reused.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/tradeoff.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

TEST(ObservedOrder, ExactForPowerLawErrorsOnUnevenLadders) {
  for (const double p : {1.0, 2.0, 1.5}) {
    const double dp1 = 0.05, dp2 = 0.04, dp3 = 0.03;  // ratios 1.25 and 1.33: not a constant refinement
    auto f = [&](double dp) { return 7.0 + 3.0 * std::pow(dp, p); };
    const auto got = observed_order(dp1, f(dp1), dp2, f(dp2), dp3, f(dp3));
    ASSERT_TRUE(got.has_value()) << p;
    EXPECT_NEAR(*got, p, 1e-6);
    // Decreasing towards the limit gives the same order.
    auto g = [&](double dp) { return 7.0 - 3.0 * std::pow(dp, p); };
    EXPECT_NEAR(*observed_order(dp1, g(dp1), dp2, g(dp2), dp3, g(dp3)), p, 1e-6);
  }
}

TEST(ObservedOrder, NoneWhenOscillatingFlatOrOutOfRange) {
  EXPECT_FALSE(observed_order(0.05, 1.0, 0.04, 2.0, 0.03, 1.5));  // up then down
  EXPECT_FALSE(observed_order(0.05, 1.0, 0.04, 1.0, 0.03, 1.0));  // no change
  EXPECT_FALSE(observed_order(0.03, 1.0, 0.04, 2.0, 0.05, 3.0));  // dp not decreasing
  // Differences growing on refinement: divergence, no order in [0.05, 8].
  EXPECT_FALSE(observed_order(0.05, 1.0, 0.04, 1.1, 0.03, 2.0));
}

namespace {

TradeoffLevel level(double dp, std::map<std::string, double> metrics) {
  TradeoffLevel l;
  l.dp = dp;
  l.label = "dp=" + std::to_string(dp);
  l.status = "completed";
  l.metrics = std::move(metrics);
  return l;
}

}  // namespace

TEST(AnalyseTradeoff, DeviationsOrderAndTheCoarsestRungWithinTolerance) {
  TradeoffResult r;
  // Q converges at second order to 10: 10 + 100 dp^2 -> deviations 2.5 %, 1.6 %, 0.9 % ... from the finest.
  // t0 is off by 20 % at the coarsest rung, 8 % at the next, 3 % at the third.
  const double dps[] = {0.05, 0.04, 0.03, 0.02};
  const double t0[] = {1.2 * 2, 1.08 * 2, 1.03 * 2, 2};
  for (int k = 0; k < 4; ++k)
    r.levels.push_back(level(dps[k], {{"monitors.S1.peak_discharge_m3_s", 10 + 100 * dps[k] * dps[k]},
                                      {"monitors.S1.arrival_time_s", t0[k]},
                                      {"particles.fluid_initial", 1000.0 / (dps[k] * dps[k])},  // not a result
                                      {"steps", 100 / dps[k]}}));
  TradeoffLevel option = level(0.05, {{"monitors.S1.peak_discharge_m3_s", 99}});
  option.option = "numerics.kernel=cubic";
  r.levels.push_back(option);
  analyse_tradeoff(r);
  ASSERT_EQ(r.metrics.size(), 2u);  // the two results; counts and steps are not
  const TradeoffMetric* q = nullptr;
  const TradeoffMetric* t = nullptr;
  for (const auto& m : r.metrics) (m.name.find("discharge") != std::string::npos ? q : t) = &m;
  ASSERT_TRUE(q && t);
  const double qf = 10 + 100 * 0.02 * 0.02;
  EXPECT_DOUBLE_EQ(q->finest, qf);
  ASSERT_EQ(q->deviation_percent.size(), 5u);
  EXPECT_NEAR(*q->deviation_percent[0], 100 * (100 * 0.05 * 0.05 - 100 * 0.02 * 0.02) / qf, 1e-9);
  EXPECT_NEAR(*q->deviation_percent[3], 0, 1e-12);
  EXPECT_NEAR(*q->deviation_percent[4], 100 * (99 - qf) / qf, 1e-9);  // the option at its rung
  // The three finest rungs 0.04, 0.03, 0.02 of an exact dp^2 sequence.
  ASSERT_TRUE(q->order);
  EXPECT_NEAR(*q->order, 2.0, 1e-6);
  // Q deviations: 0.05 -> 2.06 %, every rung within 5 %: the coarsest rung qualifies for both.
  EXPECT_DOUBLE_EQ(*q->dp_within_5, 0.05);
  EXPECT_DOUBLE_EQ(*q->dp_within_10, 0.05);
  // t0: 20 %, 8 %, 3 %: within 5 % from 0.03, within 10 % from 0.04.
  EXPECT_DOUBLE_EQ(*t->dp_within_5, 0.03);
  EXPECT_DOUBLE_EQ(*t->dp_within_10, 0.04);
}

// An arrival time of -1 says the flow never arrived at that rung: not a time, so no deviation, and that rung
// is not "within" any tolerance; a metric that never arrives at the finest rung is left out.
TEST(AnalyseTradeoff, NeverArrivedIsMissingNotMinusOneSecond) {
  TradeoffResult r;
  r.levels.push_back(level(0.05, {{"terrain.protected_zones.Village.arrival_time_s", -1},
                                  {"monitors.S9.arrival_time_s", -1}}));
  r.levels.push_back(level(0.04, {{"terrain.protected_zones.Village.arrival_time_s", 2.05},
                                  {"monitors.S9.arrival_time_s", -1}}));
  r.levels.push_back(level(0.03, {{"terrain.protected_zones.Village.arrival_time_s", 2.0},
                                  {"monitors.S9.arrival_time_s", -1}}));
  analyse_tradeoff(r);
  ASSERT_EQ(r.metrics.size(), 1u);
  const TradeoffMetric& m = r.metrics[0];
  EXPECT_EQ(m.name, "terrain.protected_zones.Village.arrival_time_s");
  EXPECT_FALSE(m.deviation_percent[0].has_value());
  EXPECT_NEAR(*m.deviation_percent[1], 2.5, 1e-9);
  EXPECT_FALSE(m.order.has_value());
  EXPECT_DOUBLE_EQ(*m.dp_within_5, 0.04);
}

TEST(IsResultMetric, ResultsAreMonitorsInundationZonesRetentionAndFront) {
  EXPECT_TRUE(is_result_metric("monitors.S1.peak_discharge_m3_s"));
  EXPECT_FALSE(is_result_metric("monitors.section.S1.discharge_window_s"));
  EXPECT_FALSE(is_result_metric("monitors.structure_load.D.load_window_s"));
  EXPECT_FALSE(is_result_metric("monitors.structure_load.D.min_wetted_area_m2"));
  EXPECT_TRUE(is_result_metric("terrain.inundation.area_m2"));
  EXPECT_FALSE(is_result_metric("terrain.inundation.cell_size_m"));
  EXPECT_TRUE(is_result_metric("terrain.protected_zones.Fan.max_depth_m"));
  EXPECT_TRUE(is_result_metric("terrain.structures.Dam1.retained_volume_m3"));
  EXPECT_FALSE(is_result_metric("terrain.structures.Dam1.crest_height_m"));
  EXPECT_TRUE(is_result_metric("front_x_m"));
  EXPECT_FALSE(is_result_metric("steps"));
  EXPECT_FALSE(is_result_metric("particles.fluid_initial"));
}

namespace {

// A 2D dam break in a tank, 0.25 s: a ladder of three rungs runs in seconds.
std::string dam_break() {
  return R"({
    "name": "tiny-dam-break",
    "dimensions": 2,
    "dp": 0.02,
    "duration": 0.25,
    "materials": [{"name": "water", "rheology": "newtonian", "density": 1000, "viscosity": 0.001}],
    "fluid": [{"min": [0, 0], "max": [0.2, 0.2], "material": "water"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.8, 0.4]}],
    "fidelity": {"draft": {"dp": 0.04}, "standard": {"dp": 0.02}, "fine": {"dp": 0.0125}}
  })";
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("runout-tradeoff-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST(RunTradeoff, RefusesBadLevelsAndOptionsBeforeRunning) {
  const fs::path dir = fresh_dir("refuse");
  RunStore store((dir / "runout.db").string());
  TradeoffSpec spec;
  spec.name = "tiny";
  spec.base_json = dam_break();
  auto field_of = [&](const TradeoffSpec& s) {
    try {
      (void)run_tradeoff(store, s, {});
    } catch (const SceneError& e) {
      return e.field + ": " + e.what();
    }
    return std::string("accepted");
  };
  spec.levels = {"draft", "fast"};
  EXPECT_NE(field_of(spec).find("levels: "), std::string::npos) << field_of(spec);
  EXPECT_NE(field_of(spec).find("'fast'"), std::string::npos);
  spec.levels = {"draft"};
  EXPECT_EQ(field_of(spec).rfind("levels", 0), 0u);
  spec.levels = {"draft", "0.04"};  // the same dp twice
  EXPECT_NE(field_of(spec).find("same dp"), std::string::npos);
  spec.levels = {"draft", "standard"};
  spec.options = {"numerics.kernel"};
  EXPECT_EQ(field_of(spec).rfind("options", 0), 0u);
  spec.options = {"numerics.kernel=quintic"};
  EXPECT_EQ(field_of(spec).rfind("options", 0), 0u);
  spec.options = {"numerics.kernel=cubic"};
  spec.option_level = "fine";
  EXPECT_EQ(field_of(spec).rfind("option_level", 0), 0u);
  EXPECT_TRUE(store.list_runs().empty());  // nothing ran
  fs::remove_all(dir);
}

TEST(RunTradeoff, LadderIsStoredReusedAndReported) {
  const fs::path dir = fresh_dir("ladder");
  RunStore store((dir / "runout.db").string());
  TradeoffSpec spec;
  spec.name = "tiny";
  spec.base_json = dam_break();
  spec.levels = {"standard", "draft", "fine"};  // any order: run coarse to fine
  spec.options = {"numerics.kernel=cubic"};
  TradeoffRunOptions opt;
  opt.out_dir = dir / "out";
  opt.threads = 1;
  const TradeoffResult r = run_tradeoff(store, spec, opt);
  ASSERT_EQ(r.levels.size(), 4u);
  const double dps[] = {0.04, 0.02, 0.0125, 0.04};
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(r.levels[k].status, "completed") << r.levels[k].label;
    EXPECT_DOUBLE_EQ(r.levels[k].dp, dps[k]);
    // A 0.2 m square column: (0.2 / dp)^2 particles.
    EXPECT_NEAR(r.levels[k].fluid, std::pow(0.2 / dps[k], 2), 0.5) << r.levels[k].label;
    EXPECT_GT(r.levels[k].steps, 0);
    EXPECT_GT(r.levels[k].wall_seconds, 0);
    EXPECT_GT(r.levels[k].predicted_seconds, 0);
    if (std::ofstream("/proc/self/clear_refs")) {  // the peak is the level's own only where it can be reset
      EXPECT_GT(r.levels[k].peak_memory_mb, 0);
    }
    EXPECT_FALSE(r.levels[k].reused);
  }
  EXPECT_EQ(r.levels[3].option, "numerics.kernel=cubic");
  // Finer rungs take more steps (the step is proportional to h).
  EXPECT_GT(r.levels[1].steps, 1.5 * r.levels[0].steps);
  // The front position is a result; the finest rung is its own reference.
  const TradeoffMetric* front = nullptr;
  for (const auto& m : r.metrics)
    if (m.name == "front_x_m") front = &m;
  ASSERT_NE(front, nullptr);
  EXPECT_NEAR(*front->deviation_percent[2], 0.0, 1e-12);
  EXPECT_GT(front->finest, 0.2);  // the column collapsed and spread beyond its initial width
  // Stored as the sweep "tradeoff:tiny", one run per level.
  const auto rows = store.list_runs("tradeoff:tiny");
  ASSERT_EQ(rows.size(), 4u);
  // Files: a row per level, a row per result metric, and the plot.
  write_tradeoff_csv(r, dir / "out");
  write_tradeoff_svg(r, dir / "out" / "tradeoff.svg", "tiny");
  std::ifstream lv(dir / "out" / "levels.csv");
  int lines = 0;
  for (std::string line; std::getline(lv, line);) ++lines;
  EXPECT_EQ(lines, 5);
  std::ifstream mt(dir / "out" / "metrics.csv");
  lines = 0;
  for (std::string line; std::getline(mt, line);) ++lines;
  EXPECT_EQ(lines, 1 + static_cast<int>(r.metrics.size()));
  std::ifstream svg(dir / "out" / "tradeoff.svg");
  std::stringstream text;
  text << svg.rdbuf();
  EXPECT_NE(text.str().find("</svg>"), std::string::npos);
  // Again: every level is reused from the store, nothing runs.
  const TradeoffResult again = run_tradeoff(store, spec, opt);
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(again.levels[k].reused);
    EXPECT_EQ(again.levels[k].run_id, r.levels[k].run_id);
  }
  EXPECT_EQ(store.list_runs("tradeoff:tiny").size(), 4u);
  fs::remove_all(dir);
}

// --predict-only: every level built and priced by the cost model, nothing run or stored.
TEST(RunTradeoff, PredictOnlyPricesEveryLevelAndRunsNothing) {
  const fs::path dir = fresh_dir("predict");
  RunStore store((dir / "runout.db").string());
  TradeoffSpec spec;
  spec.name = "tiny";
  spec.base_json = dam_break();
  spec.levels = {"draft", "standard", "fine"};
  TradeoffRunOptions opt;
  opt.out_dir = dir / "out";
  opt.threads = 1;
  opt.predict_only = true;
  const TradeoffResult r = run_tradeoff(store, spec, opt);
  ASSERT_EQ(r.levels.size(), 3u);
  for (const auto& l : r.levels) {
    EXPECT_EQ(l.status, "not run");
    EXPECT_NEAR(l.fluid, std::pow(0.2 / l.dp, 2), 0.5);
    EXPECT_GT(l.boundary, 0);
    EXPECT_EQ(l.predicted_boundary_peak, l.boundary);  // no terrain: every wall is alive
    EXPECT_EQ(l.predicted_fluid_peak, l.fluid);
    EXPECT_GT(l.predicted_steps, 0);
    EXPECT_EQ(l.steps, 0);
  }
  // Finer costs more: more particles and more steps.
  EXPECT_GT(r.levels[1].predicted_seconds, 2 * r.levels[0].predicted_seconds);
  EXPECT_GT(r.levels[2].predicted_seconds, 2 * r.levels[1].predicted_seconds);
  EXPECT_TRUE(r.metrics.empty());
  EXPECT_TRUE(store.list_runs().empty());
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}
