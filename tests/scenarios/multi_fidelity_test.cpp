// The multi-fidelity study (multi_fidelity.hpp): the layouts a constructed screening says must go on to 3D, the
// median material by each distribution's definition, and the two stages wired end to end on a cheap 2D scene.
#include <gtest/gtest.h>

#include <boost/math/distributions/lognormal.hpp>
#include <boost/math/distributions/triangular.hpp>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/multi_fidelity.hpp"
#include "runout/scenarios/scene.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const std::string kQ = "monitors.section.Outlet.peak_discharge_m3_s";

MetricQuantiles q(double p10, double p50, double p90) {
  MetricQuantiles m;
  m.p10 = p10, m.p50 = p50, m.p90 = p90, m.count = 16;
  return m;
}

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("runout-multi-fidelity-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

}  // namespace

// B leads (median 1.0, p90 1.2). C's p10 1.1 <= 1.2: it can still be best. D's p10 1.5 > 1.2: dropped. A is the
// baseline (p10 2.0: dropped on its own, kept as the baseline). E has no screening value: nothing rules it out.
TEST(MultiFidelity, TheLayoutsWhoseIntervalsOverlapTheLeadersGoOnWithTheBaseline) {
  EnsembleSummary s;
  s.layouts = {"A", "B", "C", "D", "E"};
  s.ranking_metric = kQ;
  s.quantiles["A"][kQ] = q(2.0, 2.5, 3.0);
  s.quantiles["B"][kQ] = q(0.8, 1.0, 1.2);
  s.quantiles["C"][kQ] = q(1.1, 1.4, 1.9);
  s.quantiles["D"][kQ] = q(1.5, 1.6, 1.7);
  const LayoutSelection sel = select_layouts(s, "A");
  EXPECT_EQ(sel.leader, "B");
  EXPECT_EQ(sel.chosen, (std::vector<std::string>{"A", "B", "C", "E"}));
  EXPECT_NE(sel.why.at("D").find("dropped"), std::string::npos) << sel.why.at("D");
  EXPECT_NE(sel.why.at("A").find("baseline"), std::string::npos) << sel.why.at("A");
  // An interval touching the leader's p90 can still be best (<=).
  s.quantiles["D"][kQ] = q(1.2, 1.6, 1.7);
  EXPECT_EQ(select_layouts(s, "A").chosen.size(), 5u);
}

// The median of each form: uniform (min + max) / 2, normal its mean, lognormal its median, triangular Boost's,
// a grid's middle (the mean of the two middle values for an even count).
TEST(MultiFidelity, TheMedianMemberIsEachParametersMedian) {
  Ensemble e;
  e.parameters = {{"/a", {}, "uniform", 26, 30, 0},
                  {"/b", {}, "normal", 2000, 100, 0},
                  {"/c", {}, "lognormal", 5e4, 0.3, 0},
                  {"/d", {}, "triangular", 1, 2, 4},
                  {"/e", {1, 2, 3, 4}, "", 0, 0, 0}};
  const auto m = median_member(e);
  ASSERT_EQ(m.size(), 5u);
  EXPECT_NEAR(m[0].value, 28.0, 1e-12);
  EXPECT_NEAR(m[1].value, 2000.0, 1e-9);
  EXPECT_NEAR(m[2].value, 5e4, 1e-6);
  EXPECT_NEAR(m[3].value, boost::math::median(boost::math::triangular(1, 2, 4)), 1e-12);
  EXPECT_NEAR(m[4].value, 2.5, 1e-12);
  EXPECT_EQ(m[4].pointer, "/e");
}

// Two layouts of a small 2D column, four members over the friction angle at draft, then both (no outlet: nothing
// rules a layout out) at standard at the median angle: every run completes, the 3D stage's scenes carry the
// median, the result names what ran.
TEST(MultiFidelity, TheTwoStagesRunAndTheSecondAtTheMedianMaterial) {
  TempDir tmp;
  const json base = json::parse(R"({
    "name": "mf-column", "dimensions": 2, "dp": 0.02, "duration": 0.05,
    "materials": [{"name": "sand", "rheology": "friction-hbp", "density": 2000, "viscosity": 1.0, "flow_index": 1.05,
                   "regularisation": 100, "friction_angle": 20, "cohesion": 0}],
    "fluid": [{"min": [0, 0], "max": [0.1, 0.2], "material": "sand"}],
    "boundaries": [{"type": "tank", "min": [0, 0], "max": [0.6, 0.4]}]
  })");
  std::ofstream(tmp.path / "base.json") << base.dump();
  const Sweep sweep = parse_sweep(R"({"name": "mf", "base": "base.json", "variants": [{"name": "A"}, {"name": "B"}],
    "ensemble": {"members": 4, "seed": 3, "parameters": [
      {"pointer": "/materials/0/friction_angle", "distribution": "uniform", "min": 18, "max": 22}]}})",
                                  tmp.path);
  RunStore store(tmp.path / "runout.db");
  MultiFidelityOptions o;
  o.screening = {"draft", std::nullopt};
  o.detailed = {"standard", std::nullopt};
  o.run.out_root = tmp.path / "runs";
  o.run.threads = 1;
  const MultiFidelityResult r = run_multi_fidelity_study(store, sweep, o);
  EXPECT_FALSE(r.stopped);
  EXPECT_EQ(r.screening.members, 4u);
  EXPECT_EQ(r.selection.chosen, (std::vector<std::string>{"A", "B"}));
  ASSERT_EQ(r.detailed.runs.size(), 2u);
  for (const auto& run : r.detailed.runs) EXPECT_EQ(run.status, "completed") << run.error;
  ASSERT_EQ(r.detailed_sweep.variants.size(), 2u);
  const json resolved = json::parse(resolve_variant(r.detailed_sweep.base_json, r.detailed_sweep.variants[0], o.detailed));
  EXPECT_NEAR(resolved["materials"][0]["friction_angle"].get<double>(), 20.0, 1e-12);
  EXPECT_EQ(store.list_runs("mf-median").size(), 2u);
  const json out = json::parse(multi_fidelity_json(r));
  EXPECT_EQ(out["detailed_sweep"], "mf-median");
  EXPECT_EQ(out["layouts"].size(), 2u);
  EXPECT_THROW(run_multi_fidelity_study(store, parse_sweep(R"({"name": "plain", "base": "base.json",
    "variants": [{"name": "A"}]})", tmp.path), o), SceneError);
}
