// A sweep handed by the service to the operator's MPI launch command (RUNOUT_SWEEP_LAUNCHER, docs/cluster.md,
// service/src/sweep_launcher.hpp), end to end: `runout serve` with the launcher set to `mpirun -np 3 runout
// sweep ...`, POST /sweeps, and the jobs followed to `done` through the run store that rank 0 writes. Each
// layout is stored exactly once, its metrics are served like an in-process job's, and a run through the
// launcher computes what an in-process job of the same scene computes (one thread each: the same bits).
// Needs the build with MPI and mpirun (RUNOUT_MPIEXEC, tests/CMakeLists.txt); skipped otherwise.
#include <cstdlib>

#include "service/service_harness.hpp"

using namespace runout_test;

namespace {

#ifdef RUNOUT_MPIEXEC
const std::string kMpiexec = RUNOUT_MPIEXEC;
#else
const std::string kMpiexec;
#endif

class LaunchedSweep : public ServiceTest {};

}  // namespace

TEST_F(LaunchedSweep, MpirunRunsEveryLayoutOnceAndTheJobsReportItsResults) {
  if (kMpiexec.empty() || !fs::exists(kMpiexec)) GTEST_SKIP() << "no MPI in this build (RUNOUT_MPIEXEC)";
  const std::string launcher = kMpiexec + " --allow-run-as-root --oversubscribe --bind-to none -np {ranks} {runout} sweep "
                                          "{sweep} --db {db} --out {out} --threads 1 --no-compare";
  ::setenv("RUNOUT_SWEEP_LAUNCHER", launcher.c_str(), 1);
  ::setenv("RUNOUT_SWEEP_RANKS", "3", 1);
  start({"--workers", "1", "--threads-per-job", "1"});
  ::unsetenv("RUNOUT_SWEEP_LAUNCHER");
  ::unsetenv("RUNOUT_SWEEP_RANKS");

  const Reply scene = post("/scenes", tiny_scene("base", 0.1));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const json variants = json::array({{{"name", "A"}}, {{"name", "B"}}, {{"name", "C"}}});
  const Reply sweep = post("/sweeps", {{"name", "launched"}, {"scene_id", scene.body.at("id")}, {"variants", variants}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  const int64_t sweep_id = sweep.body.at("id");
  std::vector<int64_t> ids;
  for (const auto& j : sweep.body.at("jobs")) ids.push_back(j.at("id"));
  ASSERT_EQ(ids.size(), 3u);

  // An in-process job of the same scene, for the comparison below (the launcher takes only sweeps).
  const Reply solo = post("/jobs", {{"scene", tiny_scene("solo", 0.1)}});
  ASSERT_EQ(solo.status, 201) << solo.text;

  for (int64_t id : ids) {
    const json j = wait_status(id, "done", 600s);
    ASSERT_EQ(j.value("status", ""), "done") << j.dump() << "\n" << server_.log_text();
  }
  ASSERT_EQ(wait_status(solo.body.at("id"), "done", 120s).value("status", ""), "done");

  // rank 0 stored each layout once, under the sweep's name; the command's log is where the docs say.
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs WHERE sweep = 'launched'"), 3);
  EXPECT_EQ(query_int("SELECT COUNT(DISTINCT variant) FROM runs WHERE sweep = 'launched'"), 3);
  const fs::path log = dir_ / "runs" / "service" / ("sweep-" + std::to_string(sweep_id)) / "launcher.log";
  EXPECT_TRUE(fs::exists(log)) << log;

  const json reference = get("/jobs/" + std::to_string(solo.body.at("id").get<int64_t>()) + "/metrics").body;
  for (int64_t id : ids) {
    const Reply m = get("/jobs/" + std::to_string(id) + "/metrics");
    ASSERT_EQ(m.status, 200) << m.text;
    EXPECT_EQ(m.body.at("run_status"), "completed");
    const json& got = m.body.at("metrics_json");
    // Same physics, one thread in both: the same steps, front and energy to the bit.
    EXPECT_EQ(got.at("steps"), reference.at("metrics_json").at("steps"));
    EXPECT_EQ(got.at("front_x_m"), reference.at("metrics_json").at("front_x_m"));
    EXPECT_EQ(got.at("energy"), reference.at("metrics_json").at("energy"));
    EXPECT_EQ(got.at("threads"), 1);
    EXPECT_GT(got.at("steps").get<int64_t>(), 0);
  }
}
