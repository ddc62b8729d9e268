// The API's conventions (issue 23, docs/service.md): RFC 9457 problem documents on every 4xx the server can
// produce, every invalid field of a request listed, lists in pages that cover every item exactly once, and the
// sweeps' own resources. Against the real `runout serve` (service_harness.hpp); a few seconds in all.
#include "service/service_harness.hpp"

#include <set>
#include <tuple>

using namespace runout_test;

namespace {

const std::string kToken = "api-test-token";
const std::string kProblems = "https://runout.invalid/problems/";

class Api : public ServiceTest {
 protected:
  httplib::Headers auth() const { return {{"Authorization", "Bearer " + kToken}}; }
  void write_token() const { std::ofstream(dir_ / "token") << kToken << "\n"; }

  // The members RFC 9457 defines, and ours: type (one of the documented kinds), title, status, detail, instance
  // (when the request line was read), errors naming `field` first.
  void expect_problem(const json& p, int status, const std::string& kind, const std::string& instance,
                      const std::string& field) const {
    SCOPED_TRACE(p.dump().substr(0, 400));
    ASSERT_TRUE(p.is_object());
    EXPECT_EQ(p.value("type", ""), kProblems + kind);
    EXPECT_FALSE(p.value("title", "").empty());
    EXPECT_EQ(p.value("status", 0), status);
    EXPECT_FALSE(p.value("detail", "").empty());
    if (instance.empty()) EXPECT_FALSE(p.contains("instance"));
    else EXPECT_EQ(p.value("instance", ""), instance);
    ASSERT_TRUE(p.contains("errors") && p.at("errors").is_array());
    if (!field.empty()) {
      ASSERT_FALSE(p.at("errors").empty());
      EXPECT_EQ(p.at("errors")[0].at("field"), field);
      EXPECT_FALSE(p.at("errors")[0].at("message").get<std::string>().empty());
    }
  }
  void expect_problem(const Reply& r, int status, const std::string& kind, const std::string& instance,
                      const std::string& field) const {
    EXPECT_EQ(r.status, status) << r.text.substr(0, 300);
    EXPECT_EQ(media_type(r.headers), "application/problem+json") << instance;
    expect_problem(r.body, status, kind, instance, field);
  }
  // A raw exchange's status, media type and problem document.
  void expect_raw_problem(const std::string& response, int status, const std::string& kind,
                          const std::string& instance, const std::string& field) const {
    EXPECT_EQ(status_of(response), status) << response.substr(0, 300);
    EXPECT_NE(response.find("Content-Type: application/problem+json\r\n"), std::string::npos) << response.substr(0, 300);
    expect_problem(body_of(response), status, kind, instance, field);
  }

  // Every item of a list, following `next` from `first`; checks that the Link header carries the same URL.
  std::vector<int64_t> walk(const std::string& first, const std::string& member, int* pages) const {
    std::vector<int64_t> ids;
    std::string url = "/api/v1" + first;
    *pages = 0;
    while (!url.empty() && *pages < 100) {
      const Reply r = request("GET", url);
      EXPECT_EQ(r.status, 200) << url << ": " << r.text.substr(0, 300);
      if (r.status != 200) break;
      ++*pages;
      for (const auto& item : r.body.at(member)) ids.push_back(item.at("id"));
      const json& next = r.body.at("next");
      auto link = r.headers.find("Link");
      if (next.is_null()) {
        EXPECT_EQ(link, r.headers.end()) << url;
        url.clear();
      } else {
        url = next.get<std::string>();
        EXPECT_NE(link, r.headers.end()) << url;
        if (link != r.headers.end()) EXPECT_EQ(link->second, "<" + url + ">; rel=\"next\"");
      }
    }
    return ids;
  }
};

// Every 4xx the server produces is application/problem+json with type, title, status, detail, instance and errors.
TEST_F(Api, EveryRefusalIsAProblemDocument) {
  write_token();
  start({"--workers", "0", "--token-file", (dir_ / "token").string(), "--max-body", "4096", "--header-timeout", "1",
         "--max-connections-per-client", "2"});
  const Reply job = post("/jobs", {{"scene", tiny_scene("queued")}}, auth());
  ASSERT_EQ(job.status, 201) << job.text;
  const std::string job_path = "/api/v1/jobs/" + std::to_string(job.body.at("id").get<int64_t>());

  expect_problem(request("POST", "/api/v1/jobs", "{\"scene\": ", auth()), 400, "malformed-request", "/api/v1/jobs", "(body)");
  expect_problem(get("/jobs?limit=0"), 400, "malformed-request", "/api/v1/jobs", "limit");
  const Reply no_token = post("/jobs", {{"scene", tiny_scene("x")}});
  expect_problem(no_token, 401, "unauthorized", "/api/v1/jobs", "Authorization");
  EXPECT_EQ(no_token.headers.find("WWW-Authenticate")->second, "Bearer");
  expect_problem(get("/jobs/999"), 404, "not-found", "/api/v1/jobs/999", "id");
  expect_problem(get("/sweeps/999"), 404, "not-found", "/api/v1/sweeps/999", "id");
  expect_problem(get("/nowhere"), 404, "not-found", "/api/v1/nowhere", "path");
  const Reply put = request("PUT", "/api/v1/jobs", "{}", auth());
  expect_problem(put, 405, "method-not-allowed", "/api/v1/jobs", "method");
  EXPECT_NE(put.headers.find("Allow"), put.headers.end());
  expect_problem(get(job_path.substr(7) + "/metrics"), 409, "not-ready", job_path + "/metrics", "status");
  expect_problem(request("POST", "/api/v1/jobs", "{}", auth(), "text/plain"), 415, "unsupported-media-type",
                 "/api/v1/jobs", "Content-Type");
  expect_problem(post("/jobs", {{"scene", tiny_scene("x")}, {"fidelity", "ultra"}}, auth()), 422, "invalid-field",
                 "/api/v1/jobs", "fidelity");
  // 429 and 422 over the work budget: hostile_test.cpp (WorkBudgetRefusesWithRetryAfterPerTokenAndInAll).

  // Refused by the front end, before any handler: 413 (the body's announced size), 431 (the head's), 408 (a head
  // not finished within --header-timeout: no path read yet, so no instance), 429 (a third connection from this
  // address over --max-connections-per-client 2).
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
                       "\r\nContent-Type: application/json\r\nContent-Length: 100000\r\n\r\n"));
    expect_raw_problem(c.response(3000ms), 413, "body-too-large", "/api/v1/jobs", "(body)");
  }
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'a') + "\r\n\r\n"));
    expect_raw_problem(c.response(3000ms), 431, "head-too-large", "", "(headers)");
  }
  // The rest of the front end's refusals: 414 and 505 (the request line: no path yet), 417 and 501 (the head).
  for (const auto& [head, status, kind, instance, field] :
       std::vector<std::tuple<std::string, int, std::string, std::string, std::string>>{
           {"GET /api/v1/" + std::string(9000, 'a') + " HTTP/1.1\r\nHost: x\r\n\r\n", 414, "target-too-long", "", "(request)"},
           {"GET /api/v1/health HTTP/2.0\r\nHost: x\r\n\r\n", 505, "http-version-not-supported", "", "(request)"},
           {"POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
                "\r\nExpect: 200-ok\r\nContent-Length: 2\r\n\r\n",
            417, "expectation-failed", "/api/v1/jobs", "Expect"},
           {"POST /api/v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken +
                "\r\nTransfer-Encoding: gzip\r\n\r\n",
            501, "not-implemented", "/api/v1/jobs", "Transfer-Encoding"}}) {
    Raw c(server_.port());
    ASSERT_TRUE(c.send(head));
    expect_raw_problem(c.response(3000ms), status, kind, instance, field);
  }
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n"));  // never finished
    expect_raw_problem(c.response(4000ms), 408, "request-timeout", "", "(request)");
  }
  {
    Raw a(server_.port()), b(server_.port());
    ASSERT_TRUE(a.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n"));
    ASSERT_EQ(status_of(a.response(3000ms)), 200);  // both accepted and counted before the third
    ASSERT_TRUE(b.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n"));
    ASSERT_EQ(status_of(b.response(3000ms)), 200);
    Raw c(server_.port());
    const std::string r = c.response(3000ms);
    expect_raw_problem(r, 429, "too-many-connections", "", "(connection)");
    EXPECT_NE(r.find("Retry-After: 1\r\n"), std::string::npos);
  }
}

// 503: over --max-connections in all (its least, 4, held open by this client).
TEST_F(Api, OverTheConnectionLimitIsAProblemDocument) {
  start({"--workers", "0", "--max-connections", "4"});
  std::vector<std::unique_ptr<Raw>> held;
  for (int k = 0; k < 4; ++k) {
    held.push_back(std::make_unique<Raw>(server_.port()));
    ASSERT_TRUE(held.back()->send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n"));
    ASSERT_EQ(status_of(held.back()->response(3000ms)), 200);
  }
  Raw over(server_.port());
  const std::string r = over.response(3000ms);
  expect_raw_problem(r, 503, "overloaded", "", "(connection)");
  EXPECT_NE(r.find("Retry-After: 1\r\n"), std::string::npos);
}

// A request's own fields are checked together: every invalid one is listed, not only the first.
// A stored scene's document is kept once parsed (JobQueue::scene_document): every job naming it gets that scene,
// and an id no scene has is refused on scene_id.
TEST_F(Api, JobsNamingAStoredSceneGetThatSceneAndAnUnknownIdIsNotFound) {
  start({"--workers", "0"});
  const Reply scene = post("/scenes", tiny_scene("stored"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const int64_t sid = scene.body.at("id");
  for (double dp : {0.02, 0.04}) {
    const Reply job = post("/jobs", {{"scene_id", sid}, {"fidelity", {{"dp", dp}}}});
    ASSERT_EQ(job.status, 201) << job.text;
    const Reply got = get("/jobs/" + std::to_string(job.body.at("id").get<int64_t>()));
    EXPECT_EQ(got.body.at("scene_id"), sid) << got.text;
    EXPECT_EQ(got.body.at("scene").at("name"), "stored/none") << got.text;  // base/layout
    EXPECT_EQ(got.body.at("scene").at("dp"), dp) << got.text;
  }
  expect_problem(post("/jobs", {{"scene_id", sid + 1}}), 404, "not-found", "/api/v1/jobs", "scene_id");
}

TEST_F(Api, EveryInvalidFieldIsListed) {
  start({"--workers", "0"});
  auto fields = [](const Reply& r) {
    std::vector<std::string> out;
    if (r.body.contains("errors"))
      for (const auto& e : r.body.at("errors")) out.push_back(e.at("field"));
    return out;
  };
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const int64_t sid = scene.body.at("id");

  // Two bad fields of a job, and an unknown one: all three, in the body's order of checking.
  const Reply two = post("/jobs", {{"scene_id", sid}, {"fidelity", {{"dp", -1}}}, {"variant", "a b"}, {"colour", 1}});
  EXPECT_EQ(two.status, 422) << two.text;
  EXPECT_EQ(fields(two), (std::vector<std::string>{"colour", "fidelity.dp", "variant"})) << two.text;
  EXPECT_NE(two.body.at("detail").get<std::string>().find("3 fields"), std::string::npos) << two.text;
  // A sweep: a bad name and two bad variants.
  const Reply sweep = post("/sweeps", {{"name", "no spaces allowed"},
                                       {"scene_id", sid},
                                       {"variants", json::array({{{"name", "C0"}, {"structures", {"Dam9"}}},
                                                                 {{"name", "C0"}},
                                                                 {{"structures", json::array()}}})}});
  EXPECT_EQ(sweep.status, 422) << sweep.text;
  EXPECT_EQ(fields(sweep), (std::vector<std::string>{"name", "variants[0].structures[0]", "variants[1].name",
                                                     "variants[2].name"}))
      << sweep.text;
  // A body of many unknown fields: the first 100 are listed, the rest counted in a last entry.
  json many = {{"scene", tiny_scene("many")}};
  for (int k = 0; k < 150; ++k) many["x" + std::to_string(1000 + k)] = k;
  const Reply capped = post("/jobs", many);
  EXPECT_EQ(capped.status, 422);
  ASSERT_EQ(capped.body.at("errors").size(), 101u) << capped.text.substr(0, 300);
  EXPECT_EQ(capped.body.at("errors")[100].at("field"), "(errors)");
  EXPECT_NE(capped.body.at("errors")[100].at("message").get<std::string>().find("50 more"), std::string::npos);
  EXPECT_NE(capped.body.at("detail").get<std::string>().find("more than 100 fields"), std::string::npos);
  // Query parameters likewise.
  const Reply query = get("/jobs?limit=0&status=finished&colour=red");
  EXPECT_EQ(query.status, 400);
  std::vector<std::string> q = fields(query);
  std::sort(q.begin(), q.end());
  EXPECT_EQ(q, (std::vector<std::string>{"colour", "limit", "status"})) << query.text;
  // A scene's declared fields are listed too, each on its own (issue 46: every field error at once).
  json bad = tiny_scene("bad");
  bad["materials"][0]["density"] = -1;
  bad["duration"] = -1;
  const Reply both = post("/jobs", {{"scene", bad}});
  EXPECT_EQ(both.status, 422);
  EXPECT_EQ(fields(both), (std::vector<std::string>{"scene.duration", "scene.materials[0].density"})) << both.text;
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 0);
}

// A scene's declared fields (output, numerics, monitors, the terrain sections) are checked key by key before
// anything is built: every error among them in one answer, each naming its field.
TEST_F(Api, EveryDeclaredFieldOfASceneIsListed) {
  start({"--workers", "0"});
  json bad = tiny_scene("declared");
  bad["output"] = {{"rest_time", -1}};
  bad["numerics"] = {{"cfl", 7}, {"kernel", "gauss"}, {"colour", 1}};
  const Reply r = post("/jobs", {{"scene", bad}});
  EXPECT_EQ(r.status, 422) << r.text;
  std::vector<std::string> fields;
  for (const auto& e : r.body.at("errors")) fields.push_back(e.at("field"));
  EXPECT_EQ(fields, (std::vector<std::string>{"scene.output.rest_time", "scene.numerics.colour", "scene.numerics.cfl",
                                              "scene.numerics.kernel"}))
      << r.text;
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 0);
}

// Lists come in pages of `limit` from an opaque cursor: following `next` (and the Link header) covers every
// item exactly once, in the list's order, also when items are added between pages.
TEST_F(Api, PagesCoverEveryItemExactlyOnce) {
  start({"--workers", "0"});
  std::vector<int64_t> scenes, jobs, sweeps;
  for (int k = 0; k < 7; ++k) {
    const Reply r = post("/scenes", tiny_scene("s" + std::to_string(k)));
    ASSERT_EQ(r.status, 201) << r.text;
    scenes.push_back(r.body.at("id"));
  }
  for (int k = 0; k < 11; ++k) {
    const Reply r = post("/jobs", {{"scene", tiny_scene("j" + std::to_string(k))}});
    ASSERT_EQ(r.status, 201) << r.text;
    jobs.push_back(r.body.at("id"));
  }
  for (int k = 0; k < 5; ++k) {
    const Reply r = post("/sweeps", {{"name", "w" + std::to_string(k)}, {"scene_id", scenes[0]},
                                     {"variants", json::array({{{"name", "C0"}}})}});
    ASSERT_EQ(r.status, 201) << r.text;
    sweeps.push_back(r.body.at("id"));
    jobs.push_back(r.body.at("jobs")[0].at("id"));
  }
  int pages = 0;
  EXPECT_EQ(walk("/scenes?limit=3", "scenes", &pages), scenes);
  EXPECT_EQ(pages, 3);
  EXPECT_EQ(walk("/jobs?limit=4", "jobs", &pages), jobs);
  EXPECT_EQ(pages, 4);
  EXPECT_EQ(walk("/jobs?limit=16", "jobs", &pages), jobs);  // the last page exactly full: next is null after it
  EXPECT_EQ(pages, 1);
  std::vector<int64_t> newest_first(sweeps.rbegin(), sweeps.rend());
  EXPECT_EQ(walk("/sweeps?limit=2", "sweeps", &pages), newest_first);
  EXPECT_EQ(pages, 3);
  // Defaults: every scene in one page.
  EXPECT_EQ(get("/scenes").body.at("limit"), 100);
  EXPECT_EQ(get("/sweeps").body.at("limit"), 100);
  EXPECT_EQ(get("/jobs").body.at("limit"), 1000);

  // A filter is kept in `next`; a sweep added between pages neither repeats nor hides the older ones.
  const Reply first = get("/sweeps?limit=2");
  ASSERT_EQ(first.status, 200);
  ASSERT_EQ(post("/sweeps", {{"name", "late"}, {"scene_id", scenes[0]}, {"variants", json::array({{{"name", "C0"}}})}})
                .status,
            201);
  std::vector<int64_t> seen;
  for (const auto& s : first.body.at("sweeps")) seen.push_back(s.at("id"));
  for (std::string url = first.body.at("next"); !url.empty();) {
    const Reply r = request("GET", url);
    for (const auto& s : r.body.at("sweeps")) seen.push_back(s.at("id"));
    url = r.body.at("next").is_null() ? "" : r.body.at("next").get<std::string>();
  }
  EXPECT_EQ(seen, newest_first);
  const Reply filtered = get("/jobs?status=queued&limit=2");
  ASSERT_FALSE(filtered.body.at("next").is_null());
  EXPECT_NE(filtered.body.at("next").get<std::string>().find("status=queued"), std::string::npos);

  // Out of range or foreign: 400 problems naming the parameter and the accepted range.
  for (const std::string bad : {"/scenes?limit=0", "/scenes?limit=1001", "/sweeps?limit=-1", "/jobs?limit=10001"}) {
    const Reply r = get(bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_EQ(first_error(r.body).at("field"), "limit") << bad;
    EXPECT_NE(first_error(r.body).at("message").get<std::string>().find("[1, "), std::string::npos) << r.text;
  }
  for (const std::string bad : {"/scenes?cursor=", "/jobs?cursor=42", "/sweeps?cursor=%2F%2F"}) {
    const Reply r = get(bad);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_EQ(first_error(r.body).at("field"), "cursor") << bad;
  }
  EXPECT_EQ(first_error(get("/jobs?offset=1&cursor=" + first.body.at("next").get<std::string>().substr(
                                                                 first.body.at("next").get<std::string>().find("cursor=") + 7))
                            .body)
                .at("field"),
            "offset");
}

// GET /sweeps and /sweeps/{id}: the sweeps submitted, newest first, and one sweep's variants with their jobs'
// status and progress, linking to the comparison once every job is done.
TEST_F(Api, SweepsAreListedAndFollowedToTheirComparison) {
  start({"--workers", "1", "--threads-per-job", "1"});
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const Reply sweep = post("/sweeps", {{"name", "widths"},
                                       {"scene_id", scene.body.at("id")},
                                       {"fidelity", "standard"},
                                       {"variants", json::array({{{"name", "A"}}, {{"name", "B"}}})}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  const int64_t id = sweep.body.at("id");
  EXPECT_EQ(sweep.headers.find("Location")->second, "/api/v1/sweeps/" + std::to_string(id));

  const Reply list = get("/sweeps");
  ASSERT_EQ(list.status, 200);
  ASSERT_EQ(list.body.at("sweeps").size(), 1u);
  const json& summary = list.body.at("sweeps")[0];
  EXPECT_EQ(summary.at("id"), id);
  EXPECT_EQ(summary.at("name"), "widths");
  EXPECT_EQ(summary.at("jobs_total"), 2);

  json detail;
  for (int k = 0; k < 600; ++k) {  // at most 60 s
    detail = get("/sweeps/" + std::to_string(id)).body;
    const bool finished = detail.value("status", "") != "running";
    if (!finished) EXPECT_TRUE(detail.at("links").at("compare").is_null()) << detail.dump();
    if (finished) break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(detail.value("status", ""), "done") << detail.dump();
  ASSERT_EQ(detail.at("variants").size(), 2u);
  EXPECT_EQ(detail.at("variants")[0].at("variant"), "A");
  EXPECT_EQ(detail.at("variants")[1].at("variant"), "B");
  for (const auto& v : detail.at("variants")) {
    EXPECT_EQ(v.at("status"), "done");
    EXPECT_DOUBLE_EQ(v.at("progress").at("fraction").get<double>(), 1.0);
    EXPECT_TRUE(v.at("run_id").is_number());
  }
  EXPECT_EQ(detail.at("jobs_by_status").at("done"), 2);
  EXPECT_DOUBLE_EQ(detail.at("progress").at("fraction").get<double>(), 1.0);
  const std::string compare = detail.at("links").at("compare");
  const Reply cmp = request("GET", compare);
  ASSERT_EQ(cmp.status, 200) << compare << ": " << cmp.text.substr(0, 300);
  EXPECT_EQ(cmp.body.at("baseline").at("label"), "A");
  ASSERT_EQ(cmp.body.at("jobs").size(), 1u);
  EXPECT_EQ(cmp.body.at("jobs")[0].at("job"), detail.at("variants")[1].at("job"));
  EXPECT_EQ(get("/compare?sweep=99").status, 404);
  EXPECT_EQ(get("/compare?sweep=1&jobs=1").status, 400);

  // The sweep's study report: one HTML page, its first variant the baseline unless another is named.
  const std::string report = "/sweeps/" + std::to_string(id) + "/report.html";
  const Reply page = get(report);
  ASSERT_EQ(page.status, 200) << page.text.substr(0, 300);
  EXPECT_EQ(page.headers.find("Content-Type")->second, "text/html; charset=utf-8");
  EXPECT_EQ(page.text.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.text.find("<h1>Study report: widths</h1>"), std::string::npos);
  EXPECT_NE(page.text.find("<a href=\"#layout-A\">A</a> <small>baseline</small>"), std::string::npos);
  const Reply other = get(report + "?baseline=B");
  ASSERT_EQ(other.status, 200);
  EXPECT_NE(other.text.find("<a href=\"#layout-B\">B</a> <small>baseline</small>"), std::string::npos);
  expect_problem(get(report + "?baseline=C9"), 400, "malformed-request", "/api/v1" + report, "baseline");
  expect_problem(get(report + "?colour=red"), 400, "malformed-request", "/api/v1" + report, "colour");
  expect_problem(get("/sweeps/999/report.html"), 404, "not-found", "/api/v1/sweeps/999/report.html", "id");
}

// An ensemble sweep (issue 45): every layout at every member, named as `runout sweep` names them, each job's
// scene carrying its member's value; GET /sweeps/{id} summarises the members once their jobs are done. A bad
// ensemble is refused with its field named, before anything is queued.
TEST_F(Api, AnEnsembleSweepRunsEveryLayoutAtEveryMemberAndIsSummarised) {
  start({"--workers", "1", "--threads-per-job", "1"});
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const json layouts = json::array({{{"name", "A"}}, {{"name", "B"}}});
  const json ensemble = {{"parameters", json::array({{{"pointer", "/materials/0/viscosity"}, {"values", {0.001, 0.002}}}})}};
  expect_problem(post("/sweeps", {{"scene_id", scene.body.at("id")}, {"variants", layouts},
                                  {"ensemble", {{"parameters", json::array({{{"pointer", "/nothing"}, {"values", {1}}}})}}}}),
                 422, "invalid-field", "/api/v1/sweeps", "ensemble.parameters[0].pointer");
  expect_problem(post("/sweeps", {{"scene_id", scene.body.at("id")}, {"variants", layouts}, {"ensemble", 3}}), 422,
                 "invalid-field", "/api/v1/sweeps", "ensemble");
  // A viscosity out of the material's range at an extreme member: refused, naming the member.
  const Reply bad = post("/sweeps", {{"scene_id", scene.body.at("id")}, {"variants", layouts},
                                     {"ensemble", {{"parameters", json::array({{{"pointer", "/materials/0/viscosity"},
                                                                                {"values", {0.001, -1.0}}}})}}}});
  EXPECT_EQ(bad.status, 422) << bad.text;
  EXPECT_NE(first_error(bad.body).at("message").get<std::string>().find("A-e001"), std::string::npos) << bad.text;
  EXPECT_EQ(get("/sweeps").body.at("sweeps").size(), 0u) << "nothing queued by a refused ensemble";

  const Reply sweep = post("/sweeps", {{"name", "visc"}, {"scene_id", scene.body.at("id")}, {"variants", layouts},
                                       {"ensemble", ensemble}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  const json& jobs = sweep.body.at("jobs");
  ASSERT_EQ(jobs.size(), 4u);
  const std::vector<std::string> names = {"A-e000", "B-e000", "A-e001", "B-e001"};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(jobs[k].at("variant"), names[k]);
    const Reply job = get("/jobs/" + std::to_string(jobs[k].at("id").get<int64_t>()));
    ASSERT_EQ(job.status, 200);
    EXPECT_DOUBLE_EQ(job.body.at("scene").at("materials")[0].at("viscosity").get<double>(), k < 2 ? 0.001 : 0.002)
        << names[k];
  }
  json detail;
  for (int k = 0; k < 600; ++k) {  // at most 60 s
    detail = get("/sweeps/" + std::to_string(sweep.body.at("id").get<int64_t>())).body;
    if (detail.value("status", "") != "running") break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(detail.value("status", ""), "done") << detail.dump();
  const json& e = detail.at("ensemble");
  ASSERT_TRUE(e.is_object()) << detail.dump();
  EXPECT_EQ(e.at("layouts"), json::array({"A", "B"}));
  EXPECT_EQ(e.at("members"), 2);
  EXPECT_EQ(e.at("incomplete"), 0);
  EXPECT_TRUE(e.at("layouts_detail").contains("A"));
}

// A screening job is priced by the screening rung's cost model (docs/tradeoff.md, "The screening rung's cost"),
// not as the 3D run its scene also describes: the shipped flume's release, 0.5 m x 0.3 m at the spacing 0.01 m,
// is 50 x 30 screening particles (the particles the job is counted at too, not the 3D lattice it would make), and
// the screening rung, the ladder's cheap rung, is estimated below the 3D standard rung (measured on one thread:
// 5.6 s against 114 s for C6 at standard, docs/tradeoff.md).
TEST_F(Api, AScreeningJobIsPricedAsTheScreeningRungNotAsA3DRun) {
  const fs::path scenes = dir_ / "scenes", flume = fs::path(RUNOUT_SOURCE_DIR) / "scenarios" / "flume";
  fs::create_directories(scenes);
  for (const std::string ext : {".asc", ".prj"}) fs::copy_file(flume / ("flume_dem" + ext), scenes / ("flume_dem" + ext));
  start({"--workers", "0", "--threads-per-job", "1", "--scene-dir", scenes.string()});
  json base = json::parse(std::ifstream(flume / "flume.json"));
  base["terrain"]["dem"] = "flume_dem.asc";
  auto estimate = [&](const std::string& fidelity) {
    return post("/estimate", {{"base", base}, {"structures", json::array()}, {"fidelity", fidelity}});
  };
  const Reply screening = estimate("screening"), standard = estimate("standard");
  ASSERT_EQ(screening.status, 200) << screening.text.substr(0, 300);
  ASSERT_EQ(standard.status, 200) << standard.text.substr(0, 300);
  EXPECT_EQ(screening.body.at("model").at("flow_model"), "screening");
  EXPECT_EQ(screening.body.at("model").at("fluid_mean"), 50 * 30);
  EXPECT_EQ(screening.body.at("particles").at("boundary_peak_estimate"), 0);  // its bed is a grid
  EXPECT_EQ(screening.body.at("particles").at("fluid"), 50 * 30);  // what the particle budget counts: its own
  EXPECT_EQ(screening.body.at("particles").at("boundary"), 0);
  EXPECT_EQ(standard.body.at("model").at("flow_model"), "sph3d");
  EXPECT_LT(screening.body.at("seconds_estimate").get<double>(), standard.body.at("seconds_estimate").get<double>());
}

// A multi-fidelity study as a sweep (issue 45 item 3, docs/service.md "Studies"): the members are its screening
// stage; once they have ended, the layouts that can still be best run at the detailed rung at the ensemble's
// median member, as `runout study` runs them. The plan is in the store from the submission on: a service
// killed before any job ran picks the study up where it was. No layout here has the ranking metric (no
// cross-section), so each is kept: what must hold is which jobs run, where, at what rung and with what material.
TEST_F(Api, AStudySweepRunsTheChosenLayoutsAtTheMedianMemberAfterItsScreeningStage) {
  start({"--workers", "0"});
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const json layouts = json::array({{{"name", "A"}}, {{"name", "B"}}});
  const json ensemble = {{"parameters", json::array({{{"pointer", "/materials/0/viscosity"}, {"values", {0.001, 0.003}}}})}};
  const json id = scene.body.at("id");
  expect_problem(post("/sweeps", {{"scene_id", id}, {"variants", layouts}, {"study", json::object()}}), 422,
                 "invalid-field", "/api/v1/sweeps", "study");
  expect_problem(post("/sweeps", {{"scene_id", id}, {"variants", layouts}, {"ensemble", ensemble},
                                  {"study", {{"fidelity", "finest"}}}}),
                 422, "invalid-field", "/api/v1/sweeps", "study.fidelity");
  expect_problem(post("/sweeps", {{"scene_id", id}, {"variants", layouts}, {"ensemble", ensemble}, {"study", 2}}), 422,
                 "invalid-field", "/api/v1/sweeps", "study");
  EXPECT_EQ(get("/sweeps").body.at("sweeps").size(), 0u) << "nothing queued by a refused study";

  const Reply sweep = post("/sweeps", {{"name", "visc"}, {"scene_id", id}, {"variants", layouts}, {"fidelity", "draft"},
                                       {"ensemble", ensemble}, {"study", {{"fidelity", "standard"}}}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  ASSERT_EQ(sweep.body.at("jobs").size(), 4u);
  for (const auto& j : sweep.body.at("jobs")) {
    EXPECT_EQ(j.at("stage"), 1);
    EXPECT_EQ(j.at("fidelity"), "draft");
  }
  const json& planned = sweep.body.at("study");
  EXPECT_EQ(planned.at("stage"), "screening");
  EXPECT_EQ(planned.at("detailed").at("candidates"), 2);
  EXPECT_EQ(planned.at("detailed").at("jobs_total"), 0);
  EXPECT_TRUE(planned.at("outcome").is_null());
  const std::string self = "/sweeps/" + std::to_string(sweep.body.at("id").get<int64_t>());
  EXPECT_EQ(get(self).body.at("status"), "running");
  // A second study whose screening jobs are all cancelled: it is decided, and nothing of it runs after.
  const Reply stopped = post("/sweeps", {{"name", "stopped"}, {"scene_id", id}, {"variants", layouts}, {"fidelity", "draft"},
                                         {"ensemble", ensemble}, {"study", {{"fidelity", "standard"}}}});
  ASSERT_EQ(stopped.status, 201) << stopped.text;
  for (const auto& j : stopped.body.at("jobs"))
    EXPECT_EQ(request("DELETE", "/api/v1/jobs/" + std::to_string(j.at("id").get<int64_t>())).status, 200);

  server_.kill9();
  start({"--workers", "1", "--threads-per-job", "1"});
  json detail;
  for (int k = 0; k < 1200; ++k) {  // at most 120 s
    detail = get(self).body;
    if (detail.value("status", "") != "running") break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_EQ(detail.value("status", ""), "done") << detail.dump();
  const json& study = detail.at("study");
  EXPECT_EQ(study.at("stage"), "done");
  EXPECT_EQ(study.at("screening").at("jobs_by_status").at("done"), 4);
  EXPECT_EQ(study.at("detailed").at("jobs_by_status").at("done"), 2);
  const json& outcome = study.at("outcome");
  ASSERT_TRUE(outcome.is_object()) << study.dump();
  EXPECT_EQ(outcome.at("members"), 2);
  EXPECT_EQ(outcome.at("detailed_sweep"), "visc-median");
  ASSERT_EQ(outcome.at("layouts").size(), 2u);
  for (const auto& l : outcome.at("layouts")) EXPECT_TRUE(l.at("chosen").get<bool>()) << l.dump();
  EXPECT_EQ(outcome.at("ranking").size(), 2u);
  ASSERT_EQ(outcome.at("median_member").size(), 1u);
  EXPECT_DOUBLE_EQ(outcome.at("median_member")[0].at("value").get<double>(), 0.002);
  std::vector<std::string> detailed;
  for (const auto& v : detail.at("variants")) {
    if (v.at("stage") != 2) continue;
    detailed.push_back(v.at("variant"));
    const json job = get("/jobs/" + std::to_string(v.at("job").get<int64_t>())).body;
    EXPECT_EQ(job.at("fidelity"), "standard");
    EXPECT_EQ(job.at("sweep"), "visc-median");
    EXPECT_DOUBLE_EQ(job.at("scene").at("materials")[0].at("viscosity").get<double>(), 0.002) << v.dump();
  }
  EXPECT_EQ(detailed, (std::vector<std::string>{"A", "B"}));
  EXPECT_TRUE(detail.at("ensemble").is_object()) << "the screening members are summarised as an ensemble";

  const std::string stopped_self = "/sweeps/" + std::to_string(stopped.body.at("id").get<int64_t>());
  json cancelled;
  for (int k = 0; k < 100; ++k) {  // decided by an idle worker within a second or two
    cancelled = get(stopped_self).body;
    if (cancelled.value("status", "") != "running") break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(cancelled.value("status", ""), "incomplete") << cancelled.dump();
  ASSERT_TRUE(cancelled.at("study").at("outcome").is_object()) << cancelled.dump();
  EXPECT_EQ(cancelled.at("study").at("outcome").at("members"), 0);
  EXPECT_NE(cancelled.at("study").at("outcome").value("note", "").find("cancelled"), std::string::npos);
  EXPECT_EQ(cancelled.at("study").at("detailed").at("jobs_total"), 0) << "no detailed job of a cancelled study";
}

// A sweep whose jobs have not run has no report yet: 409.
TEST_F(Api, ASweepsReportWaitsForADoneJob) {
  start({"--workers", "0"});
  const Reply scene = post("/scenes", tiny_scene("base"));
  ASSERT_EQ(scene.status, 201) << scene.text;
  const Reply sweep = post("/sweeps", {{"name", "queued"}, {"scene_id", scene.body.at("id")},
                                       {"variants", json::array({{{"name", "A"}}})}});
  ASSERT_EQ(sweep.status, 201) << sweep.text;
  const std::string report = "/sweeps/" + std::to_string(sweep.body.at("id").get<int64_t>()) + "/report.html";
  expect_problem(get(report), 409, "not-ready", "/api/v1" + report, "status");
}

}  // namespace
