// Runs that share a machine (docs/performance.md, "Runs that share a machine"): the runs of one process that go at
// once divide its cores, never more threads than cores while each has one, a run left alone takes them all, and a
// run follows its share between steps.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/thread_share.hpp"

using namespace runout;
using json = nlohmann::json;
namespace fs = std::filesystem;

TEST(ThreadShare, RunsGoingAtOnceDivideTheCoresAndOneAloneTakesThemAll) {
  ThreadShare share(4);
  EXPECT_EQ(share.share(), 4);
  {
    ThreadShare::Lease a(share);
    EXPECT_EQ(share.share(), 4);
    auto b = std::make_unique<ThreadShare::Lease>(share);
    EXPECT_EQ(share.share(), 2);
    {
      ThreadShare::Lease c(share);
      EXPECT_EQ(share.share(), 1);  // 4 / 3: never more threads than cores
      ThreadShare::Lease d(share);
      ThreadShare::Lease e(share);
      EXPECT_EQ(share.share(), 1);  // more runs than cores: each keeps one
    }
    b.reset();
    EXPECT_EQ(a.threads_now()(), 4);  // the run left alone takes the machine again
  }
  EXPECT_EQ(share.running(), 0);
  EXPECT_EQ(ThreadShare(0).share(), 1);
}

// A run whose share changes while it runs (another run starts and ends beside it) follows it between steps and
// says so in metrics.json; the flow is the same physics whatever the team: mass exact, completed.
TEST(ThreadShare, ARunFollowsItsShareBetweenStepsAndRecordsTheTeamItHad) {
  const json s = {{"name", "share-tank"},
                  {"dimensions", 2},
                  {"dp", 0.01},
                  {"duration", 1.0},
                  {"materials", {{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}}}},
                  {"fluid", {{{"min", {0.0, 0.0}}, {"max", {0.2, 0.2}}, {"material", "water"}}}},
                  {"boundaries", {{{"type", "tank"}, {"min", {0.0, 0.0}}, {"max", {0.6, 0.4}}}}},
                  {"output", {{"series_interval", 0.05}}}};
  const fs::path out = fs::temp_directory_path() / "runout-thread-share-test";
  fs::remove_all(out);
  std::atomic<int> calls{0};
  RunOptions opt;
  opt.out_dir = out;
  opt.threads_now = [&] { return calls++ % 2 == 0 ? 2 : 1; };  // alternately alone and beside another run
  const RunSummary r = run_scene(parse_scene(s.dump()), opt);
  ASSERT_EQ(r.status, "completed") << r.error;
  const json m = json::parse(r.metrics_json);
  ASSERT_GE(calls.load(), 2) << "the run never read its share again after its start (wall " << r.wall_seconds << " s)";
  EXPECT_EQ(m.at("threads"), 2);
  EXPECT_EQ(m.at("threads_least"), 1);
  EXPECT_NEAR(m.at("mass").at("relative_error").get<double>(), 0.0, 1e-12);  // fixed particle masses: rounding only
  fs::remove_all(out);
}
