// Sweeps run and stored: every variant of a sweep runs once, lands in the run store under its manifest, and
// is not run again when the sweep is repeated; a check dam on the flume keeps part of the flow from the outlet.
// Uses the shipped C0-C7 flume (scenarios/flume/) at its draft dp (5 cm): about half a minute a run.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() /
                  ("runout-study-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// C0 (nothing built) and C3 (the check dam at P2) of the shipped flume, at dp = 5 cm.
Sweep two_layouts(const fs::path& dir) {
  const json sweep = {{"name", "flume-test"},
                      {"base", (fs::path(RUNOUT_SOURCE_DIR) / "scenarios/flume/flume.json").string()},
                      {"variants", {{{"name", "C0"}, {"structures", json::array()}}, {{"name", "C3"}, {"structures", {"CD_P2"}}}}}};
  std::ofstream(dir / "sweep.json") << sweep.dump();
  return load_sweep(dir / "sweep.json");
}

SweepOptions coarse(const fs::path& dir) {
  SweepOptions o;
  o.out_root = dir / "runs";
  o.fidelity_override = true;
  o.fidelity = Fidelity{"custom", 0.05};
  return o;
}

}  // namespace

TEST(Study, SweepRunsEachLayoutOnceStoresItAndACheckDamHoldsFlowBack) {
  TempDir tmp;
  const Sweep sweep = two_layouts(tmp.path);
  RunStore store(tmp.path / "runout.db");
  const SweepResult first = run_sweep(store, sweep, coarse(tmp.path));
  ASSERT_EQ(first.runs.size(), 2u);
  for (const auto& r : first.runs) {
    ASSERT_EQ(r.status, "completed") << r.error;
    EXPECT_FALSE(r.reused);
  }
  ASSERT_EQ(store.list_runs("flume-test").size(), 2u);
  const auto c0 = store.metrics(first.runs[0].run_id);
  const auto c3 = store.metrics(first.runs[1].run_id);
  EXPECT_EQ(c0.at("leaks"), 0);
  EXPECT_EQ(c3.at("leaks"), 0);
  // Same release in both layouts.
  EXPECT_DOUBLE_EQ(c0.at("terrain.release_volume_m3"), c3.at("terrain.release_volume_m3"));
  const double released = c0.at("terrain.release_volume_m3");
  // The dam at P2 holds part of the flow upstream of it, so less passes the outlet section; nothing leaves
  // the flume without passing the outlet in C0. How much of C0's flow reaches the plain is the material's (on
  // the granular defaults 0.018 m3 at this dp, 19 % of the release at standard; docs/study.md), not this
  // test's subject: it needs C0 to pass more than the 5 % of the release by which the dam must cut it.
  const double out0 = c0.at("monitors.section.Outlet.volume_passed_m3");
  const double out3 = c3.at("monitors.section.Outlet.volume_passed_m3");
  EXPECT_GT(out0, 0.05 * released) << "in C0 flow passes the outlet";
  EXPECT_LT(out3, out0 - 0.05 * released) << "C0 " << out0 << " m3, C3 " << out3 << " m3";
  // What the dam holds upstream of its axis did not pass the outlet downstream of it. How much that is needs a
  // resolved dam: at this dp it is two particles tall and stores 3.5e-5 m3 under its crest (0.1 % of the
  // release), and nothing rests on the 38 degree chute above it on extrapolated walls, so it holds nothing at
  // the end here; at standard dp it holds 8.5 % of the release (docs/study.md). On DBC walls the layer creeping
  // on the chute above it was counted as held. What it stops here rests between it and the outlet.
  const double held = c3.at("terrain.structures.check_dam.CD_P2.upstream_volume_m3");
  EXPECT_LE(held + out3, released * (1 + 1e-9));
  // The flow loads the dam (positive downstream force) and C0 has no such structure.
  EXPECT_GT(c3.at("monitors.structure_load.CD_P2.peak_force_n"), 0);
  EXPECT_EQ(c0.count("monitors.structure_load.CD_P2.peak_force_n"), 0u);
  // Series are stored with the run.
  EXPECT_TRUE(store.series_csv(first.runs[1].run_id, "section_Outlet").has_value());
  EXPECT_TRUE(store.series_csv(first.runs[1].run_id, "run").has_value());

  // The comparison shows the outlet volume lower in C3 than in the baseline C0.
  const Comparison cmp = compare_runs(store, {first.runs[1].run_id}, first.runs[0].run_id);
  bool found = false;
  for (const auto& row : cmp.rows)
    if (row.metric == "monitors.section.Outlet.volume_passed_m3") {
      found = true;
      ASSERT_TRUE(row.percent[0].has_value());
      EXPECT_LT(*row.percent[0], 0);
    }
  EXPECT_TRUE(found);

  // Run again: both runs are found by their manifests and nothing is recomputed or stored twice.
  const SweepResult again = run_sweep(store, sweep, coarse(tmp.path));
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_TRUE(again.runs[k].reused);
    EXPECT_EQ(again.runs[k].run_id, first.runs[k].run_id);
  }
  EXPECT_EQ(store.list_runs().size(), 2u);
}

TEST(Study, AStoppedSweepStoresNoCompletedRunAndResumesLater) {
  TempDir tmp;
  const Sweep sweep = two_layouts(tmp.path);
  RunStore store(tmp.path / "runout.db");
  std::atomic<bool> stop{true};
  SweepOptions o = coarse(tmp.path);
  o.stop = &stop;
  const SweepResult r = run_sweep(store, sweep, o);
  for (const auto& run : r.runs) EXPECT_EQ(run.status, "not run");
  EXPECT_TRUE(store.list_runs().empty());
}
