// The HTTP service end to end (issue 5): the real `runout serve` on a loopback port with a scratch database.
//  - SIGTERM puts the running job back in the queue with its state saved; the restarted service resumes it;
//  - round trip: submit -> poll -> done; the stored metrics equal `runout run`'s on the same resolved scene
//    (every metric that does not depend on wall time); /compare gives the right differences;
//  - kill -9 while a job runs, restart on the same database: every accepted job finishes exactly once;
//  - cancelling a running job stops it within seconds and frees its worker; a queued job cancels at once;
//  - idempotency keys, the OpenAPI document, 404/405.
// Scenes are tiny 2D dam breaks (a few hundred particles).
#include "service/service_harness.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "runout/scenarios/store.hpp"

using namespace runout_test;

namespace {

// Metrics that depend on the wall clock (or the machine), not on the simulation.
bool wall_time_metric(const std::string& name) {
  return name.find("wall") != std::string::npos || name.find("per_s") != std::string::npos ||
         name.find("elapsed") != std::string::npos;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Service : public ServiceTest {};

TEST_F(Service, RoundTripMatchesTheCliAndCompareGivesTheDifferences) {
  start({"--workers", "1", "--threads-per-job", "1"});
  // A base dp of 0.01 at draft fidelity: the service resolves it to dp 0.02.
  const Reply a = post("/jobs", {{"scene", tiny_scene("rt-a", 0.05, 0.01)}, {"fidelity", "draft"}});
  ASSERT_EQ(a.status, 201) << a.text;
  const Reply b = post("/jobs", {{"scene", tiny_scene("rt-b", 0.05, 0.01, 0.2, 0.16)}, {"fidelity", "draft"}});
  ASSERT_EQ(b.status, 201) << b.text;
  const int64_t ja = a.body.at("id"), jb = b.body.at("id");
  EXPECT_EQ(a.body.at("status"), "queued");
  EXPECT_EQ(a.body.at("particles"), 268);  // 100 fluid + 168 boundary at dp 0.02

  const json da = wait_status(ja, "done"), db = wait_status(jb, "done");
  ASSERT_EQ(da.value("status", ""), "done") << da.dump();
  ASSERT_EQ(db.value("status", ""), "done") << db.dump();
  EXPECT_EQ(da.at("scene").at("dp"), 0.02);
  EXPECT_GT(da.at("progress").at("steps").get<int64_t>(), 0);
  EXPECT_NEAR(da.at("progress").at("fraction").get<double>(), 1.0, 0.01);

  // The CLI on the same resolved scene, same thread count.
  const fs::path scene_file = dir_ / "resolved.json";
  std::ofstream(scene_file) << da.at("scene").dump();
  const std::string cmd = "'" + kRunout + "' run '" + scene_file.string() + "' --out '" + (dir_ / "cli").string() +
                          "' --threads 1 --quiet --no-db > '" + (dir_ / "cli.log").string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << read_text(dir_ / "cli.log");
  const auto cli = runout::flatten_metrics(read_text(dir_ / "cli" / "metrics.json"));

  const Reply ma = get("/jobs/" + std::to_string(ja) + "/metrics");
  ASSERT_EQ(ma.status, 200) << ma.text;
  const json& service = ma.body.at("metrics");
  size_t compared = 0;
  for (const auto& [name, value] : cli) {
    if (wall_time_metric(name)) continue;
    ASSERT_TRUE(service.contains(name)) << name;
    EXPECT_EQ(service.at(name).get<double>(), value) << name;
    ++compared;
  }
  EXPECT_GT(compared, 20u);
  for (const auto& [name, value] : service.items()) EXPECT_TRUE(cli.count(name)) << "only in the service: " << name;
  // The series too, byte for byte.
  const Reply csv = request("GET", "/api/v1/jobs/" + std::to_string(ja) + "/series/run.csv");
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.text, read_text(dir_ / "cli" / "series" / "run.csv"));

  // Compare: B against the baseline A, every metric, differences from the two metric sets.
  const Reply mb = get("/jobs/" + std::to_string(jb) + "/metrics");
  ASSERT_EQ(mb.status, 200);
  const Reply cmp = get("/compare?jobs=" + std::to_string(ja) + "," + std::to_string(jb) + "&baseline=" + std::to_string(ja));
  ASSERT_EQ(cmp.status, 200) << cmp.text;
  EXPECT_EQ(cmp.body.at("baseline").at("job"), ja);
  ASSERT_EQ(cmp.body.at("jobs").size(), 1u);
  EXPECT_EQ(cmp.body.at("jobs")[0].at("job"), jb);
  std::set<std::string> names;
  for (const auto& [n, v] : ma.body.at("metrics").items()) names.insert(n);
  for (const auto& [n, v] : mb.body.at("metrics").items()) names.insert(n);
  ASSERT_EQ(cmp.body.at("metrics").size(), names.size());
  size_t differing = 0;
  for (const auto& row : cmp.body.at("metrics")) {
    const std::string n = row.at("metric");
    const double base = ma.body.at("metrics").at(n), v = mb.body.at("metrics").at(n);
    EXPECT_EQ(row.at("baseline").get<double>(), base) << n;
    EXPECT_EQ(row.at("values")[0].get<double>(), v) << n;
    EXPECT_DOUBLE_EQ(row.at("difference")[0].get<double>(), v - base) << n;
    if (base != 0) EXPECT_NEAR(row.at("percent")[0].get<double>(), (v - base) / std::abs(base) * 100, 1e-9) << n;
    else EXPECT_TRUE(row.at("percent")[0].is_null()) << n;
    differing += v != base;
  }
  EXPECT_GT(differing, 3u);  // a lower column: mass, energy, particle count differ
  // A tank has no cross-section, structure or terrain: no decision metric, no outlet, no ranking, and the
  // rows in the store's order (by name).
  std::vector<std::string> order;
  for (const auto& row : cmp.body.at("metrics")) {
    EXPECT_FALSE(row.at("decision").get<bool>()) << row.at("metric");
    order.push_back(row.at("metric"));
  }
  EXPECT_TRUE(std::is_sorted(order.begin(), order.end()));
  EXPECT_TRUE(cmp.body.at("outlet").is_null());
  EXPECT_TRUE(cmp.body.at("ranking").is_null());
  EXPECT_EQ(cmp.body.at("metrics").size(), names.size());
  // A job that is not done cannot be compared; an unknown one is 404.
  EXPECT_EQ(get("/compare?jobs=" + std::to_string(ja) + ",999").status, 404);
}

// GET /compare on an arrival that never happened: null with its never flag, no difference or per cent (before:
// -1 and a per cent of it). A pressure probe in the water is wet at once; one high in the empty corner never.
TEST_F(Service, CompareSaysNeverForAnArrivalThatNeverHappened) {
  start({"--workers", "1", "--threads-per-job", "1"});
  auto with_probe = [](const std::string& name, double x, double y) {
    json s = tiny_scene(name, 0.02);
    s["monitors"] = json::array({{{"type", "pressure_probe"}, {"name", "P"}, {"point", {x, y}}}});
    return s;
  };
  const Reply a = post("/jobs", {{"scene", with_probe("wet", 0.1, 0.05)}});
  const Reply b = post("/jobs", {{"scene", with_probe("dry", 0.35, 0.25)}});
  ASSERT_EQ(a.status, 201) << a.text;
  ASSERT_EQ(b.status, 201) << b.text;
  const int64_t ja = a.body.at("id"), jb = b.body.at("id");
  ASSERT_EQ(wait_status(ja, "done").value("status", ""), "done");
  ASSERT_EQ(wait_status(jb, "done").value("status", ""), "done");
  const std::string metric = "monitors.pressure_probe.P.arrival_time_s";
  auto row_of = [&](const json& cmp) {
    for (const auto& r : cmp.at("metrics"))
      if (r.at("metric") == metric) return r;
    ADD_FAILURE() << "no row " << metric << " in " << cmp.dump().substr(0, 400);
    return json::object();
  };
  const Reply cmp = get("/compare?jobs=" + std::to_string(ja) + "," + std::to_string(jb));
  ASSERT_EQ(cmp.status, 200) << cmp.text;
  const json r = row_of(cmp.body);
  EXPECT_TRUE(r.at("baseline").is_number()) << r.dump();
  EXPECT_EQ(r.at("baseline_never"), false);
  EXPECT_EQ(r.at("values"), json::array({nullptr}));
  EXPECT_EQ(r.at("never"), json::array({true}));
  EXPECT_EQ(r.at("difference"), json::array({nullptr}));
  EXPECT_EQ(r.at("percent"), json::array({nullptr}));
  // The other way round: the baseline never arrived; the wet probe keeps its time, with nothing against "never".
  const Reply back = get("/compare?jobs=" + std::to_string(ja) + "," + std::to_string(jb) + "&baseline=" + std::to_string(jb));
  ASSERT_EQ(back.status, 200) << back.text;
  const json rb = row_of(back.body);
  EXPECT_TRUE(rb.at("baseline").is_null());
  EXPECT_EQ(rb.at("baseline_never"), true);
  EXPECT_TRUE(rb.at("values")[0].is_number());
  EXPECT_EQ(rb.at("never"), json::array({false}));
  EXPECT_EQ(rb.at("percent"), json::array({nullptr}));
}

TEST_F(Service, IdempotencyKeyReturnsTheOriginalJobAndSweep) {
  start({"--workers", "0"});
  const json body = {{"scene", tiny_scene("idem")}};
  const Reply first = post("/jobs", body, {{"Idempotency-Key", "retry-1"}});
  ASSERT_EQ(first.status, 201) << first.text;
  const Reply again = post("/jobs", body, {{"Idempotency-Key", "retry-1"}});
  ASSERT_EQ(again.status, 200) << again.text;
  EXPECT_EQ(again.body.at("id"), first.body.at("id"));
  json with_field = body;
  with_field["idempotency_key"] = "retry-1";
  EXPECT_EQ(post("/jobs", with_field).body.at("id"), first.body.at("id"));
  EXPECT_EQ(post("/jobs", body).status, 201);  // no key: a new job
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 2);

  // A sweep of explicit variants over a stored base scene (no candidate structures: every layout is empty).
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  EXPECT_EQ(post("/scenes", tiny_scene("base")).status, 200);  // the same scene: stored once
  const json sweep = {{"name", "S1"},
                      {"scene_id", scene.body.at("id")},
                      {"fidelity", "standard"},
                      {"variants", json::array({{{"name", "C0"}}, {{"name", "C1"}, {"structures", json::array()}}})}};
  const Reply s1 = post("/sweeps", sweep, {{"Idempotency-Key", "sweep-1"}});
  ASSERT_EQ(s1.status, 201) << s1.text;
  ASSERT_EQ(s1.body.at("jobs").size(), 2u);
  EXPECT_EQ(s1.body.at("jobs")[0].at("variant"), "C0");
  EXPECT_EQ(s1.body.at("jobs")[0].at("scene_name"), "base/C0");
  const Reply s2 = post("/sweeps", sweep, {{"Idempotency-Key", "sweep-1"}});
  ASSERT_EQ(s2.status, 200) << s2.text;
  EXPECT_EQ(s2.body.at("id"), s1.body.at("id"));
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM service_sweeps"), 1);
  const Reply listed = get("/jobs?sweep=" + std::to_string(s1.body.at("id").get<int64_t>()));
  ASSERT_EQ(listed.status, 200);
  EXPECT_EQ(listed.body.at("total"), 2);
  EXPECT_EQ(get("/jobs?status=queued").body.at("total"), 4);
}

TEST_F(Service, KillNineWhileAJobRunsThenRestartFinishesEveryJobExactlyOnce) {
  start({"--workers", "1", "--threads-per-job", "1"});
  // Job 1 runs a few seconds (10 s simulated: over a second of wall time even on a fast machine, where 2.5 s
  // was within a progress write of finishing); 2-4 are short. Distinct scenes: four distinct runs.
  std::vector<int64_t> ids;
  for (int k = 0; k < 4; ++k) {
    const double duration = k == 0 ? 10.0 : 0.05;
    const Reply r = post("/jobs", {{"scene", tiny_scene("crash-" + std::to_string(k), duration)}},
                         {{"Idempotency-Key", "crash-" + std::to_string(k)}});
    ASSERT_EQ(r.status, 201) << r.text;
    ids.push_back(r.body.at("id"));
  }
  // Wait until job 1 runs and has written progress, then kill the server without warning.
  const json running = wait_job(ids[0], [](const json& j) {
    return j.value("status", "") == "running" && j.at("progress").at("steps").get<int64_t>() > 0;
  });
  ASSERT_EQ(running.value("status", ""), "running") << running.dump();
  server_.kill9();
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs WHERE status = 'running'"), 1);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs WHERE status = 'done'"), 0);

  // A client retry of an accepted submission after the restart does not add a job.
  start({"--workers", "1", "--threads-per-job", "1"});
  const Reply retry = post("/jobs", {{"scene", tiny_scene("crash-1", 0.05)}}, {{"Idempotency-Key", "crash-1"}});
  EXPECT_EQ(retry.status, 200);
  EXPECT_EQ(retry.body.at("id"), ids[1]);
  for (int64_t id : ids) {
    const json j = wait_status(id, "done", 90s);
    ASSERT_EQ(j.value("status", ""), "done") << j.dump();
  }
  const json first = get("/jobs/" + std::to_string(ids[0])).body;
  EXPECT_EQ(first.at("attempts"), 2);  // killed once, run again
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(DISTINCT run_id) FROM jobs WHERE status = 'done'"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs WHERE status = 'completed'"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM (SELECT run_id FROM metrics GROUP BY run_id)"), 4);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs j JOIN runs r ON r.id = j.run_id"), 4);
  // The stored run of the killed job is complete: its series cover the whole duration.
  const Reply m = get("/jobs/" + std::to_string(ids[0]) + "/metrics");
  ASSERT_EQ(m.status, 200);
  EXPECT_NEAR(m.body.at("metrics").at("simulated_time_s").get<double>(), 10.0, 0.01);
  EXPECT_EQ(server_.terminate() >> 8, 0);
  runout::RunStore store(db_);
  EXPECT_EQ(store.integrity_check(), "ok");
}

TEST_F(Service, CancellingARunningJobStopsItAndFreesTheWorker) {
  start({"--workers", "1", "--threads-per-job", "1"});
  const Reply longjob = post("/jobs", {{"scene", tiny_scene("long", 60.0)}});  // about a minute if not stopped
  ASSERT_EQ(longjob.status, 201);
  const int64_t id = longjob.body.at("id");
  const json running = wait_job(id, [](const json& j) {
    return j.value("status", "") == "running" && j.at("progress").at("steps").get<int64_t>() > 0;
  });
  ASSERT_EQ(running.value("status", ""), "running") << running.dump();

  // A queued job behind it is cancelled at once.
  const Reply queued = post("/jobs", {{"scene", tiny_scene("behind")}});
  ASSERT_EQ(queued.status, 201);
  const Reply cq = request("DELETE", "/api/v1/jobs/" + std::to_string(queued.body.at("id").get<int64_t>()));
  EXPECT_EQ(cq.status, 200) << cq.text;
  EXPECT_EQ(cq.body.at("status"), "cancelled");

  const auto t0 = std::chrono::steady_clock::now();
  const Reply c = request("DELETE", "/api/v1/jobs/" + std::to_string(id));
  EXPECT_EQ(c.status, 202) << c.text;
  EXPECT_TRUE(c.body.at("cancel_requested").get<bool>());
  const json cancelled = wait_status(id, "cancelled", 20s);
  ASSERT_EQ(cancelled.value("status", ""), "cancelled") << cancelled.dump();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 10.0);  // generous: the run checks the stop flag every step
  EXPECT_LT(cancelled.at("progress").at("simulated_time").get<double>(), 60.0);
  std::cerr << "[service] running job cancelled after " << seconds << " s\n";
  // Cancelled again: still cancelled (200); a cancelled job has no results (409).
  EXPECT_EQ(request("DELETE", "/api/v1/jobs/" + std::to_string(id)).status, 200);
  EXPECT_EQ(get("/jobs/" + std::to_string(id) + "/metrics").status, 409);

  // The worker is free: the next job runs to the end.
  const Reply next = post("/jobs", {{"scene", tiny_scene("next")}});
  ASSERT_EQ(next.status, 201);
  const json done = wait_status(next.body.at("id"), "done", 60s);
  EXPECT_EQ(done.value("status", ""), "done") << done.dump();
  EXPECT_EQ(get("/health").body.at("busy_workers"), 0);
  // A done job cannot be cancelled.
  EXPECT_EQ(request("DELETE", "/api/v1/jobs/" + std::to_string(next.body.at("id").get<int64_t>())).status, 409);
}

TEST_F(Service, SweepOverAStoredTerrainSceneServesRastersAndTheMap) {
  // The flume (scenarios/flume), coarse (dp 0.06 m) and short (0.05 s): two layouts, a few seconds each.
  start({"--workers", "1", "--threads-per-job", "1", "--scene-dir", RUNOUT_SOURCE_DIR "/scenarios/flume"});
  json flume = json::parse(read_text(RUNOUT_SOURCE_DIR "/scenarios/flume/flume.json"));
  flume["duration"] = 0.05;
  const Reply scene = post("/scenes", flume);
  ASSERT_EQ(scene.status, 201) << scene.text;
  EXPECT_EQ(scene.body.at("structures").size(), 5u);
  const int64_t sid = scene.body.at("id");
  EXPECT_EQ(get("/scenes").body.at("scenes").size(), 1u);
  EXPECT_EQ(get("/scenes/" + std::to_string(sid)).body.at("scene"), flume);

  // Layouts are checked when named: an unknown structure, and two candidates that overlap.
  const Reply unknown = post("/jobs", {{"scene_id", sid}, {"structures", {"FD_P1", "Dam9"}}});
  EXPECT_EQ(unknown.status, 422);
  EXPECT_EQ(first_error(unknown.body).at("field"), "structures[1]");
  EXPECT_NE(first_error(unknown.body).at("message").get<std::string>().find("RB2_P2"), std::string::npos);
  const Reply overlap = post("/jobs", {{"scene_id", sid}, {"structures", {"FD_P1", "CD_P1"}}, {"fidelity", {{"dp", 0.06}}}});
  EXPECT_EQ(overlap.status, 422) << overlap.text;

  const Reply sweep = post("/sweeps", {{"name", "flume-test"},
                                       {"scene_id", sid},
                                       {"fidelity", {{"dp", 0.06}}},
                                       {"variants", json::array({{{"name", "C0"}, {"structures", json::array()}},
                                                                 {{"name", "C1"}, {"structures", {"FD_P1"}}}})}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  const int64_t c0 = sweep.body.at("jobs")[0].at("id"), c1 = sweep.body.at("jobs")[1].at("id");
  for (int64_t id : {c0, c1}) {
    const json j = wait_status(id, "done", 90s);
    ASSERT_EQ(j.value("status", ""), "done") << j.dump();
  }
  const json job = get("/jobs/" + std::to_string(c1)).body;
  EXPECT_EQ(job.at("sweep"), "flume-test");
  EXPECT_EQ(job.at("variant"), "C1");
  EXPECT_EQ(job.at("scene").at("structures").size(), 1u);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs WHERE sweep = 'flume-test'"), 2);

  // Rasters and the map: the files of the job's run directory, byte for byte.
  const fs::path out = dir_ / "runs" / "service" / ("job-" + std::to_string(c1));  // --runs DIR/runs
  // Downloads carry their registered media type and a file name (Content-Disposition: attachment).
  auto header = [](const Reply& r, const std::string& name) {
    auto it = r.headers.find(name);
    return it == r.headers.end() ? std::string() : it->second;
  };
  const std::string job_prefix = "job-" + std::to_string(c1) + "-";
  // GeoTIFFs keep the run's names, and their QGIS styles are served under the same names, so that QGIS applies
  // NAME.qml to NAME.tif downloaded beside it. The sweep's difference rasters (C1 minus C0) are C1's.
  for (const std::string name : {"max_depth", "max_speed", "deposit_depth", "diff_max_depth", "diff_max_hv"}) {
    const std::string path = "/api/v1/jobs/" + std::to_string(c1) + "/rasters/" + name;
    const Reply tif = request("GET", path + ".tif");
    ASSERT_EQ(tif.status, 200) << name << ": " << tif.text.substr(0, 300);
    EXPECT_EQ(tif.text, read_text(out / "rasters" / (name + ".tif"))) << name;
    EXPECT_EQ(tif.text.substr(0, 4), std::string("II*\0", 4));
    EXPECT_EQ(header(tif, "Content-Type"), "image/tiff; application=geotiff");
    EXPECT_EQ(header(tif, "Content-Disposition"), "attachment; filename=\"" + name + ".tif\"");
    const Reply qml = request("GET", path + ".qml");
    ASSERT_EQ(qml.status, 200) << name << ": " << qml.text.substr(0, 300);
    EXPECT_EQ(qml.text, read_text(out / "rasters" / (name + ".qml"))) << name;
    EXPECT_NE(qml.text.find("<qgis"), std::string::npos) << name;
    EXPECT_EQ(media_type(qml.headers), "application/xml");
    EXPECT_EQ(header(qml, "Content-Disposition"), "attachment; filename=\"" + name + ".qml\"");
  }
  // The baseline has none of its own.
  EXPECT_EQ(request("GET", "/api/v1/jobs/" + std::to_string(c0) + "/rasters/diff_max_depth.tif").status, 404);
  EXPECT_EQ(request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/rasters/nope.qml").status, 404);
  EXPECT_EQ(request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/rasters/..%2Fmetrics.qml").status, 400);
  // The sweep's report shows them.
  const Reply report = request("GET", "/api/v1/sweeps/" + std::to_string(sweep.body.at("id").get<int64_t>()) + "/report.html");
  ASSERT_EQ(report.status, 200);
  EXPECT_NE(report.text.find("data-raster=\"diff_max_depth\""), std::string::npos);
  // The hazard polygons: the run's rasters/hazard.gpkg, a GeoPackage (SQLite) file.
  const Reply gpkg = request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/vectors/hazard.gpkg");
  ASSERT_EQ(gpkg.status, 200) << gpkg.text.substr(0, 300);
  EXPECT_EQ(gpkg.text, read_text(out / "rasters" / "hazard.gpkg"));
  EXPECT_EQ(gpkg.text.substr(0, 16), std::string("SQLite format 3\0", 16));
  EXPECT_EQ(header(gpkg, "Content-Type"), "application/geopackage+sqlite3");
  EXPECT_EQ(header(gpkg, "Content-Disposition"), "attachment; filename=\"" + job_prefix + "hazard.gpkg\"");
  const Reply csv = request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/series/run.csv");
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(media_type(csv.headers), "text/csv");
  EXPECT_EQ(header(csv, "Content-Disposition"), "attachment; filename=\"" + job_prefix + "run.csv\"");
  const Reply png = request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/map.png");
  ASSERT_EQ(png.status, 200);
  EXPECT_EQ(png.text.substr(1, 3), "PNG");
  EXPECT_EQ(request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/rasters/nope.tif").status, 404);
  // A 2D job has no rasters.
  const Reply flat = post("/jobs", {{"scene", tiny_scene("flat")}});
  ASSERT_EQ(wait_status(flat.body.at("id"), "done").value("status", ""), "done");
  EXPECT_EQ(get("/jobs/" + std::to_string(flat.body.at("id").get<int64_t>()) + "/map.png").status, 404);

  // The sweep compared against C0: the structure changes the deposit.
  const Reply cmp = get("/compare?jobs=" + std::to_string(c0) + "," + std::to_string(c1));
  ASSERT_EQ(cmp.status, 200) << cmp.text;
  EXPECT_EQ(cmp.body.at("baseline").at("label"), "C0");
  EXPECT_EQ(cmp.body.at("jobs")[0].at("label"), "C1");
  // Jobs of one sweep: its report, with the baseline's variant.
  const std::string sid_text = std::to_string(sweep.body.at("id").get<int64_t>());
  EXPECT_EQ(cmp.body.at("sweep").at("report"), "/api/v1/sweeps/" + sid_text + "/report.html?baseline=C0");
  EXPECT_EQ(cmp.body.at("sweep").at("name"), "flume-test");
  EXPECT_TRUE(get("/compare?jobs=" + std::to_string(c0) + "," + std::to_string(flat.body.at("id").get<int64_t>()))
                  .body.at("sweep").is_null());
  // Each row says which way is better (decision metrics only) and names the metric for people.
  std::map<std::string, json> rows;
  for (const auto& r : cmp.body.at("metrics")) rows[r.at("metric")] = r;
  const json q = rows.at("monitors.section.Outlet.peak_discharge_m3_s");
  EXPECT_EQ(q.at("better"), "lower");
  EXPECT_EQ(q.at("label"), "Outlet Q_m [m³/s]");
  EXPECT_EQ(rows.at("terrain.protected_zones.Village.arrival_time_s").at("better"), "higher");
  EXPECT_EQ(rows.at("terrain.protected_zones.Village.arrival_time_s").at("label"), "Village arrival [s]");
  EXPECT_TRUE(rows.at("steps").at("better").is_null());
  EXPECT_EQ(rows.at("steps").at("label"), "steps");

  // Maps of both on one colour scale: each ramp spans the larger of the two rasters' largest values, and the
  // picture is coloured on it.
  const json own0 = get("/jobs/" + std::to_string(c0) + "/map.json").body;
  const json own1 = get("/jobs/" + std::to_string(c1) + "/map.json").body;
  const Reply shared = get("/jobs/" + std::to_string(c1) + "/map.json?shared=" + std::to_string(c0));
  ASSERT_EQ(shared.status, 200) << shared.text;
  EXPECT_EQ(shared.body.at("shared").at("jobs"), json::array({c0, c1}));
  EXPECT_TRUE(own1.at("shared").is_null());
  for (size_t k = 0; k < own1.at("layers").size(); ++k) {
    const json& a = own0.at("layers")[k].at("scale");
    const json& b = own1.at("layers")[k].at("scale");
    const json& l = shared.body.at("layers")[k];
    if (b.at("classes").get<bool>()) {
      EXPECT_EQ(l.at("scale"), b);
      continue;
    }
    const double top = std::max(a.at("data_max").get<double>(), b.at("data_max").get<double>());
    EXPECT_EQ(l.at("scale").at("data_max"), b.at("data_max")) << l.dump();
    EXPECT_EQ(l.at("scale").at("shared"), true);
    if (top > l.at("scale").at("min").get<double>()) {
      EXPECT_DOUBLE_EQ(l.at("scale").at("max").get<double>(), top) << l.dump();
    }
    const std::string image = l.at("image");
    ASSERT_NE(image.find("?max="), std::string::npos) << image;
    const Reply pic = request("GET", image);
    EXPECT_EQ(pic.status, 200) << image;
    EXPECT_EQ(pic.text.substr(1, 3), "PNG");
  }
  EXPECT_EQ(get("/jobs/" + std::to_string(c1) + "/map.json?shared=999").status, 404);
  EXPECT_EQ(first_error(get("/jobs/" + std::to_string(c1) + "/map.json?shared=x").body).at("field"), "shared");
  const Reply bad_max = request("GET", "/api/v1/jobs/" + std::to_string(c1) + "/rasters/max_depth.png?max=-1");
  EXPECT_EQ(bad_max.status, 400);
  EXPECT_NE(bad_max.text.find("\"max\""), std::string::npos) << bad_max.text;
}

// A fresh `runout serve` (no --scene-dir) offers the shipped studies' base scenes: stored in the background (a
// catchment takes ~13 s to check) while cheap requests answer at once, their file names relative to the shipped
// scenarios folder, which stays the boundary a scene's files must not leave.
TEST_F(Service, AFreshServiceOffersTheShippedStudies) {
  using Clock = std::chrono::steady_clock;
  start({"--workers", "0", "--shipped-studies", "on"});
  const auto t0 = Clock::now();
  const Reply health = get("/health");
  const Reply scenes = get("/scenes");
  EXPECT_LT(Clock::now() - t0, 2s);
  ASSERT_EQ(health.status, 200);
  ASSERT_EQ(scenes.status, 200);
  EXPECT_EQ(health.body.at("shipped_studies").at("status"), "storing") << health.body.dump();
  json status;
  for (const auto end = Clock::now() + 600s; Clock::now() < end; std::this_thread::sleep_for(500ms)) {
    const auto t = Clock::now();
    status = get("/health").body.at("shipped_studies");
    EXPECT_LT(Clock::now() - t, 2s) << "GET /health while the studies are checked";
    if (status.at("status") == "done") break;
  }
  ASSERT_EQ(status.at("status"), "done") << status.dump();
  EXPECT_EQ(status.at("failed"), json::array()) << status.dump();
  std::map<std::string, json> offered;  // file -> {scene_id, name}
  for (const auto& o : status.at("offered")) offered[o.at("file")] = o;
  for (const char* file : {"flume/flume.json", "catchment/jacksboro_g.json", "catchment/alr.json"})
    ASSERT_TRUE(offered.count(file)) << file << " in " << status.dump();
  EXPECT_EQ(status.at("offered")[0].at("file"), "flume/flume.json");  // first: it is offered within a second
  EXPECT_EQ(get("/scenes").body.at("scenes").size(), offered.size());
  auto scene_of = [&](const char* file) { return get("/scenes/" + std::to_string(offered.at(file).at("scene_id").get<int64_t>())).body; };
  // File names relative to the scenarios folder, resolving to the shipped files.
  const json flume = scene_of("flume/flume.json");
  EXPECT_EQ(flume.at("name"), "flume");
  EXPECT_EQ(flume.at("structures").size(), 5u);
  EXPECT_EQ(flume.at("scene").at("terrain").at("dem"), "flume/flume_dem.asc");
  const json alr = scene_of("catchment/alr.json");
  EXPECT_EQ(alr.at("scene").at("terrain").at("dem"), "dem/alr_5m.tif");
  EXPECT_EQ(scene_of("catchment/jacksboro_g_gpkg.json").at("scene").at("release").at("polygon").at("layer"), "catchment/layouts.gpkg");
  // A layout of the catchment is a job the service accepts.
  const Reply est = post("/estimate", {{"scene_id", alr.at("id")}, {"structures", {"Dam1"}}, {"fidelity", "draft"}});
  EXPECT_EQ(est.status, 200) << est.text.substr(0, 400);
  // The folder stays the boundary: a name that leaves it is refused, naming the field.
  json escape = flume.at("scene");
  escape["name"] = "escape";
  escape["terrain"]["dem"] = "../README.md";
  const Reply refused = post("/scenes", escape);
  EXPECT_EQ(refused.status, 422);
  EXPECT_EQ(first_error(refused.body).at("field"), "terrain.dem");
  escape["terrain"]["dem"] = "dem/../../README.md";
  EXPECT_EQ(post("/scenes", escape).status, 422);

  // Restarted on the same file: found by their hash, not checked again (done at once), nothing stored twice.
  EXPECT_EQ(server_.terminate() >> 8, 0);
  start({"--workers", "0", "--shipped-studies", "on"});
  const auto t1 = Clock::now();
  for (; Clock::now() - t1 < 20s; std::this_thread::sleep_for(200ms))
    if (get("/health").body.at("shipped_studies").at("status") == "done") break;
  EXPECT_LT(Clock::now() - t1, 20s);
  EXPECT_EQ(get("/scenes").body.at("scenes").size(), offered.size());
}

TEST_F(Service, SigtermPutsTheRunningJobBackInTheQueue) {
  start({"--workers", "1", "--threads-per-job", "1"});
  // 30 s simulated: several seconds of wall time even on a fast machine (progress is written every 0.5 s, and
  // a 2 s job finished before the signal on CI), well inside the restart's 60 s.
  const Reply r = post("/jobs", {{"scene", tiny_scene("term", 30.0)}});
  ASSERT_EQ(r.status, 201);
  const int64_t id = r.body.at("id");
  const json running = wait_job(id, [](const json& j) {
    return j.value("status", "") == "running" && j.at("progress").at("steps").get<int64_t>() > 0;
  });
  ASSERT_EQ(running.value("status", ""), "running");
  const int status = server_.terminate();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs WHERE status = 'queued'"), 1);
  start({"--workers", "1", "--threads-per-job", "1"});
  const json done = wait_status(id, "done", 60s);
  ASSERT_EQ(done.value("status", ""), "done") << done.dump();
  EXPECT_EQ(done.at("attempts"), 2);
  // The stopped job saved its state and the restarted service resumed it there (RunOptions::checkpoint_interval).
  const Reply m = get("/jobs/" + std::to_string(id) + "/metrics");
  ASSERT_EQ(m.status, 200);
  const json& metrics = m.body.at("metrics_json");
  ASSERT_TRUE(metrics.contains("resumed")) << metrics.dump();
  EXPECT_GT(metrics.at("resumed").at("from_s").get<double>(), 0.0);
  EXPECT_EQ(metrics.at("resumed").at("sessions"), 2);
  EXPECT_NEAR(metrics.at("simulated_time_s").get<double>(), 30.0, 0.01);
  // The stopped attempt's row was replaced by the completed run: one run for the job.
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs"), 1);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM runs WHERE status = 'completed'"), 1);
}

TEST_F(Service, OpenApiDocumentDescribesEveryRoute) {
  start({"--workers", "0"});
  const Reply doc = get("/openapi.json");
  ASSERT_EQ(doc.status, 200);
  ASSERT_TRUE(doc.body.is_object()) << doc.text.substr(0, 200);
  EXPECT_EQ(doc.body.at("openapi").get<std::string>().substr(0, 2), "3.");
  const std::map<std::string, std::vector<std::string>> routes = {
      {"/health", {"get"}},
      {"/openapi.json", {"get"}},
      {"/scenes", {"get", "post"}},
      {"/scenes/{id}", {"get"}},
      {"/jobs", {"get", "post"}},
      {"/jobs/{id}", {"get", "delete"}},
      {"/sweeps", {"get", "post"}},
      {"/sweeps/{id}", {"get"}},
      {"/sweeps/{id}/report.html", {"get"}},
      {"/jobs/{id}/vectors/hazard.gpkg", {"get"}},
      {"/estimate", {"post"}},
      {"/jobs/{id}/metrics", {"get"}},
      {"/jobs/{id}/series/{name}.csv", {"get"}},
      {"/jobs/{id}/rasters/{name}.tif", {"get"}},
      {"/jobs/{id}/rasters/{name}.qml", {"get"}},
      {"/jobs/{id}/map.png", {"get"}},
      {"/jobs/{id}/map.json", {"get"}},
      {"/jobs/{id}/rasters/{name}.png", {"get"}},
      {"/jobs/{id}/hillshade.png", {"get"}},
      {"/compare", {"get"}},
      {"/schema/scene", {"get"}}};
  const json& paths = doc.body.at("paths");
  EXPECT_EQ(paths.size(), routes.size());
  for (const auto& [path, methods] : routes) {
    ASSERT_TRUE(paths.contains(path)) << path;
    EXPECT_EQ(paths.at(path).size(), methods.size()) << path;
    for (const auto& m : methods) EXPECT_TRUE(paths.at(path).contains(m)) << path << " " << m;
  }
  // Every route answers: an unknown id is 404 (not 405), a wrong method 405 with Allow.
  for (const std::string p : {"/scenes/9", "/jobs/9", "/jobs/9/metrics", "/jobs/9/series/run.csv", "/jobs/9/rasters/max_depth.tif",
                              "/jobs/9/map.png", "/jobs/9/map.json", "/sweeps/9", "/sweeps/9/report.html",
                              "/jobs/9/vectors/hazard.gpkg", "/jobs/9/rasters/max_depth.png", "/jobs/9/hillshade.png"})
    EXPECT_EQ(get(p).status, 404) << p;
  const Reply wrong = request("PUT", "/api/v1/sweeps", "{}");
  EXPECT_EQ(wrong.status, 405);
  bool allow = false;
  for (const auto& [k, v] : wrong.headers) allow = allow || (k == "Allow" && v.find("POST") != std::string::npos);
  EXPECT_TRUE(allow);
}

// The scene schema the OpenAPI's Scene refers to: served, one alternative per registered rheology.
TEST_F(Service, SceneSchemaIsServedFromTheDescriptors) {
  start({"--workers", "0"});
  const Reply doc = get("/openapi.json");
  EXPECT_EQ(doc.body.at("components").at("schemas").at("Scene").at("$ref"), "schema/scene");
  const Reply schema = get("/schema/scene");
  ASSERT_EQ(schema.status, 200) << schema.text.substr(0, 200);
  const json& alts = schema.body.at("properties").at("materials").at("items").at("oneOf");
  std::vector<std::string> names;
  for (const auto& a : alts) names.push_back(a.at("properties").at("rheology").at("const"));
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"bingham", "friction-hbp", "hbp", "mu-i", "newtonian"}));
}

}  // namespace
