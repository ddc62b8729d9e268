// Sweeps run and stored: every variant of a sweep runs once, lands in the run store under its manifest, and
// is not run again when the sweep is repeated; mass past a check dam is bounded by the release.
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

TEST(Study, SweepRunsEachLayoutOnceAndStoresIt) {
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
  // Not asserted: that the dam lets less pass the outlet. The volume past the outlet is the flume's least converged
  // metric at this spacing (on the C6 ladder, draft gives 65 times the fine value: docs/tradeoff.md), so no
  // ordering of it can be asserted with its error as margin (issue 42 item 4.6); docs/study.md has it at standard.
  const double out3 = c3.at("monitors.section.Outlet.volume_passed_m3");
  // What the dam holds upstream of its axis did not pass the outlet downstream of it (mass, at any resolution). How
  // much that is needs a resolved dam: at this dp it is two particles tall and stores 3.5e-5 m3 under its crest
  // (0.1 % of the release); at standard dp it holds 8.5 % of the release (docs/study.md).
  const double held = c3.at("terrain.structures.check_dam.CD_P2.upstream_volume_m3");
  EXPECT_LE(held + out3, released * (1 + 1e-9));
  // The flow loads the dam (positive downstream force) and C0 has no such structure.
  EXPECT_GT(c3.at("monitors.structure_load.CD_P2.peak_force_n"), 0);
  EXPECT_EQ(c0.count("monitors.structure_load.CD_P2.peak_force_n"), 0u);
  // Series are stored with the run.
  EXPECT_TRUE(store.series_csv(first.runs[1].run_id, "section_Outlet").has_value());
  EXPECT_TRUE(store.series_csv(first.runs[1].run_id, "run").has_value());

  // The comparison has the outlet volume of C3 against the baseline C0, as a difference in per cent.
  const Comparison cmp = compare_runs(store, {first.runs[1].run_id}, first.runs[0].run_id);
  bool found = false;
  for (const auto& row : cmp.rows)
    if (row.metric == "monitors.section.Outlet.volume_passed_m3") {
      found = true;
      EXPECT_EQ(row.percent[0].has_value(), c0.at("monitors.section.Outlet.volume_passed_m3") != 0);
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
