// The Alr catchment study at the rung CI can afford (issue 41 item 5; declared in docs/study.md, "The arrival
// ladder and the CI-sized Alr test", 2026-12-08 02:10 UTC, before the ladder ran): G0 and G1 at draft (dp 4 m) on
// the shipped scene, its duration cut to 100 s. Arrivals are causal, so the cut runs' arrivals are the full runs'
// to the bit (checked against the full draft runs, docs/study.md). What draft resolves on Alr is arrival; the
// thesis' first finding for Dam1 (F1: a dam delays the front) is the ordering t_X(G0) < (1 - e_X) t_X(G1) at the
// section below Dam1 (S1), the two further down (S2, S3) and the Village, e_X the arrival's draft error from the
// ladder. Peak discharges, depths and areas are not asserted: at draft they move in whole 64 m3 particles
// (docs/study.md, "How the findings are judged").
//
// The ladder (2026-12-08) put every e_X above Dam1's delay at draft: the draft front is 7-16 % late behind no dam
// and 23-34 % late behind Dam1 (an 8 m dam is two draft particles high), while at standard Dam1 delays the front by
// 1-6 % only. So each ordering is a known failure of its own (ctest WILL_FAIL, tests/CMakeLists.txt), stating the
// aim, and the runs they read are made once by the fixture test, which asserts what does hold: both layouts
// complete, leak nothing and keep their mass.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const fs::path kDir = fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "catchment";
// The fixture's output, read by the known failures (ctest runs the fixture first).
const fs::path kRuns = fs::path(RUNOUT_BINARY_DIR) / "tests" / "alr_study";

// What the known failures read must come from this build's fixture run, not a stale one.
std::string this_build() {
  return std::to_string(fs::last_write_time("/proc/self/exe").time_since_epoch().count());
}

// The arrival's draft error e_X = max over G0, G1 of |t_draft - t_standard| / t_standard (both at G1): the ladder
// of 2026-12-08 (docs/study.md, "The arrival ladder"), `runout run OUT/alr_g0_g7.json --variant GK --fidelity F
// -j2 --no-db` for F draft and standard on a copy of scenarios/catchment/alr.json with duration 100 (commit
// ec21d13). G0 draft / standard: S1 22.34 / 19.89 s, S2 32.63 / 30.38, S3 51.38 / 44.56, Village 59 / 51;
// G1: 24.73 / 20.08, 42.47 / 31.72, 62.39 / 47.10, 70 / 54.
struct Arrival {
  const char* metric;
  double draft_error;
};
const std::map<std::string, Arrival> kArrivals = {
    {"S1", {"monitors.section.S1.arrival_time_s", 0.231}},
    {"S2", {"monitors.section.S2.arrival_time_s", 0.339}},
    {"S3", {"monitors.section.S3.arrival_time_s", 0.325}},
    {"Village", {"terrain.protected_zones.Village.arrival_time_s", 0.296}},
};

using Metrics = std::map<std::string, std::map<std::string, double>>;

Metrics read_fixture() {
  std::ifstream in(kRuns / "metrics.json");
  if (!in) return {};
  const json j = json::parse(in);
  if (j.value("build", "") != this_build()) return {};
  return j.at("metrics").get<Metrics>();
}

// F1 for Dam1 at arrival X, with the arrival's draft error as the margin.
void expect_dam1_delays(const std::string& x) {
  const Metrics m = read_fixture();
  // Without this build's runs the aim is not tested: a skip passes, which a WILL_FAIL entry reports as red.
  if (m.size() != 2u) GTEST_SKIP() << "no runs of this build in " << kRuns << ": run AlrStudy.DraftG0AndG1 first";
  const Arrival& a = kArrivals.at(x);
  const double t0 = m.at("G0").at(a.metric), t1 = m.at("G1").at(a.metric);
  std::printf("%s: G0 %.3f s, G1 %.3f s (%+.1f %%; draft error %.1f %%)\n", x.c_str(), t0, t1, 100 * (t1 / t0 - 1),
              100 * a.draft_error);
  if (t0 <= 0) GTEST_SKIP() << x << ": G0's front did not arrive before 100 s (the fixture fails on that)";
  if (t1 < 0) return;  // G1's front held back past 100 s: delayed beyond any error
  EXPECT_LT(t0, (1 - a.draft_error) * t1) << x << ": Dam1 (G1) delays the front beyond the draft's arrival error";
}

}  // namespace

// The fixture: G0 and G1 at draft, cut at 100 s; both complete, leak nothing and keep their mass.
TEST(AlrStudy, DraftG0AndG1RunCleanToTheArrivals) {
  fs::remove_all(kRuns);
  fs::create_directories(kRuns);
  RunStore store(kRuns / "runout.db");
  Sweep sweep = load_sweep(kDir / "alr_g0_g7.json");
  json base = json::parse(sweep.base_json);
  base["duration"] = 100.0;  // arrivals only: every draft arrival of G0 and G1 is before 71 s
  sweep.base_json = base.dump();
  std::vector<SweepVariant> pair;
  for (const auto& v : sweep.variants)
    if (v.name == "G0" || v.name == "G1") pair.push_back(v);
  ASSERT_EQ(pair.size(), 2u);
  sweep.variants = pair;
  SweepOptions opt;
  opt.out_root = kRuns / "runs";
  opt.jobs = 1;  // one layout at a time on every core
  const SweepResult r = run_sweep(store, sweep, opt);
  ASSERT_EQ(r.runs.size(), 2u);
  Metrics m;
  for (size_t k = 0; k < r.runs.size(); ++k) {
    ASSERT_EQ(r.runs[k].status, "completed") << r.variants[k] << ": " << r.runs[k].error;
    m[r.variants[k]] = store.metrics(r.runs[k].run_id);
  }
  for (const auto& [variant, mv] : m) {
    EXPECT_EQ(mv.at("leaks"), 0) << variant;
    const double in = mv.at("mass.initial_kg") + mv.at("mass.inflow_kg");
    EXPECT_GT(in, 0) << variant << ": nothing flowed in";
    EXPECT_NEAR(mv.at("mass.final_kg") + mv.at("mass.outflow_kg"), in, 1e-9 * in) << variant << ": mass";
    for (const auto& [x, a] : kArrivals) {  // the 30 000 m3 surge reaches every section and the Village by 71 s
      std::printf("%s %s arrival %.3f s\n", variant.c_str(), x.c_str(), mv.at(a.metric));
      EXPECT_GT(mv.at(a.metric), 0) << variant << ": the front never reached " << x << " by 100 s";
    }
  }
  std::ofstream(kRuns / "metrics.json") << json{{"build", this_build()}, {"metrics", m}}.dump(1);
}

// Known failures (each its own ctest entry with WILL_FAIL, requiring the fixture): Dam1's delay of the front at draft
// beyond the draft's arrival error. At draft G1 arrives 11 % (S1), 30 % (S2), 21 % (S3) and 19 % (Village) after G0;
// the errors are 23-34 %.
TEST(AlrStudy, DISABLED_Dam1DelaysS1BeyondTheDraftError) { expect_dam1_delays("S1"); }
TEST(AlrStudy, DISABLED_Dam1DelaysS2BeyondTheDraftError) { expect_dam1_delays("S2"); }
TEST(AlrStudy, DISABLED_Dam1DelaysS3BeyondTheDraftError) { expect_dam1_delays("S3"); }
TEST(AlrStudy, DISABLED_Dam1DelaysTheVillageBeyondTheDraftError) { expect_dam1_delays("Village"); }
