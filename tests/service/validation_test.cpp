// A corpus of malformed requests (issue 5, item 4): bad JSON, wrong types, NaN/Inf, negative sizes,
// out-of-range values, huge arrays, path traversal in names, unknown fields, missing or wrong token, wrong
// methods, unknown ids. Each gets the right 4xx with a JSON error naming the field, and none of them changes
// the store (rows of every table counted before and after).
#include "service/service_harness.hpp"

using namespace runout_test;

namespace {

const std::string kToken = "s3cret-token-for-tests";

struct Case {
  std::string name, method, path, body;
  int status;
  std::string field;  // expected error.field ("" = any non-empty)
  std::string message_contains;
  httplib::Headers headers = {};
  std::string content_type = "application/json";
  bool auth = true;  // send the bearer token
};

std::string with_raw(const json& j, const std::string& key_value, const std::string& raw) {
  // Replaces one "key":value pair in the dump with raw text (NaN, Infinity, 1e400 are not JSON).
  std::string text = j.dump();
  const auto at = text.find(key_value);
  if (at == std::string::npos) throw std::runtime_error("no " + key_value + " in " + text);
  text.replace(at, key_value.size(), raw);
  return text;
}

class Validation : public ServiceTest {
 protected:
  // The reply to one malformed request: its status, an RFC 9457 problem document naming the field
  // (docs/service.md, "Errors"), Allow on a 405, the token never echoed.
  static void expect_problem(const Case& c, const Reply& r) {
    EXPECT_EQ(r.status, c.status) << c.name << ": " << r.text.substr(0, 400);
    ASSERT_TRUE(r.body.is_object() && r.body.contains("errors")) << c.name << ": " << r.text.substr(0, 400);
    EXPECT_EQ(media_type(r.headers), "application/problem+json") << c.name;
    EXPECT_EQ(r.body.at("status"), r.status);
    if (c.path.find('%') == std::string::npos)  // the instance is the decoded path
      EXPECT_EQ(r.body.at("instance"), c.path.substr(0, c.path.find('?'))) << c.name;
    EXPECT_EQ(r.body.at("type").get<std::string>().rfind("https://runout.invalid/problems/", 0), 0u) << c.name;
    EXPECT_FALSE(r.body.at("title").get<std::string>().empty()) << c.name;
    const json e = first_error(r.body);
    const std::string field = e.at("field"), message = e.at("message");
    EXPECT_NE(r.body.at("detail").get<std::string>().find(message), std::string::npos) << c.name;
    EXPECT_FALSE(field.empty()) << c.name;
    EXPECT_FALSE(message.empty()) << c.name;
    if (!c.field.empty()) {
      EXPECT_EQ(field, c.field) << c.name << ": " << message;
    }
    if (!c.message_contains.empty()) {
      EXPECT_NE(message.find(c.message_contains), std::string::npos) << c.name << ": " << message;
    }
    if (std::getenv("RUNOUT_TEST_VERBOSE"))
      std::cerr << "[validation] " << c.name << ": " << r.status << " " << field << ": " << message.substr(0, 160) << "\n";
    if (r.status == 405) {
      bool allow = false;
      for (const auto& [k, v] : r.headers) allow = allow || k == "Allow";
      EXPECT_TRUE(allow) << c.name;
    }
    if (r.status == 401) {
      // The token is never echoed.
      EXPECT_EQ(r.text.find(kToken), std::string::npos);
    }
  }
};

TEST_F(Validation, MalformedRequestsGetTheRight4xxAndLeaveTheStoreUnchanged) {
  std::ofstream(dir_ / "token") << kToken << "\n";
  start({"--workers", "0", "--token-file", (dir_ / "token").string(), "--max-body", "65536", "--particle-budget",
         "5000"});
  const httplib::Headers auth = {{"Authorization", "Bearer " + kToken}};

  // Something in the store first: a scene, a job and a sweep (accepted with the token).
  const Reply scene = post("/scenes", tiny_scene("base"), auth);
  ASSERT_EQ(scene.status, 201) << scene.text;
  const int64_t scene_id = scene.body.at("id");
  const Reply job = post("/jobs", {{"scene", tiny_scene("ok")}}, auth);
  ASSERT_EQ(job.status, 201) << job.text;
  const std::string job_path = "/api/v1/jobs/" + std::to_string(job.body.at("id").get<int64_t>());
  const Reply sweep = post("/sweeps", {{"scene_id", scene_id}, {"variants", json::array({{{"name", "C0"}}})}}, auth);
  ASSERT_EQ(sweep.status, 201) << sweep.text;

  const json ok = tiny_scene("x");
  auto job_with = [&](const std::function<void(json&)>& edit) {
    json s = ok;
    edit(s);
    return json{{"scene", s}}.dump();
  };
  auto scene_with = [&](const std::function<void(json&)>& edit) {
    json s = ok;
    edit(s);
    return s.dump();
  };
  const std::string sid = std::to_string(scene_id);
  const std::string big(70000, ' ');

  std::vector<Case> cases = {
      // Access.
      {"no token", "POST", "/api/v1/jobs", job_with([](json&) {}), 401, "Authorization", "Bearer", {}, "application/json", false},
      {"wrong token", "POST", "/api/v1/jobs", job_with([](json&) {}), 401, "Authorization", "", {{"Authorization", "Bearer nope"}}, "application/json", false},
      {"basic auth", "POST", "/api/v1/jobs", job_with([](json&) {}), 401, "Authorization", "", {{"Authorization", "Basic " + kToken}}, "application/json", false},
      {"token prefix", "POST", "/api/v1/jobs", job_with([](json&) {}), 401, "Authorization", "", {{"Authorization", "Bearer " + kToken.substr(0, 5)}}, "application/json", false},
      {"cancel without token", "DELETE", job_path, "", 401, "Authorization", "", {}, "application/json", false},
      {"scene without token", "POST", "/api/v1/scenes", ok.dump(), 401, "Authorization", "", {}, "application/json", false},
      {"sweep without token", "POST", "/api/v1/sweeps", "{}", 401, "Authorization", "", {}, "application/json", false},
      // Bodies that are not JSON objects.
      {"truncated JSON", "POST", "/api/v1/jobs", R"({"scene": {"dimensions": 2,)", 400, "(body)", "malformed JSON"},
      {"empty body", "POST", "/api/v1/jobs", "", 400, "(body)", ""},
      {"not JSON", "POST", "/api/v1/jobs", "scene=1", 400, "(body)", ""},
      {"array body", "POST", "/api/v1/jobs", "[1, 2]", 422, "(body)", "JSON object"},
      {"null body", "POST", "/api/v1/jobs", "null", 422, "(body)", ""},
      {"NaN", "POST", "/api/v1/jobs", with_raw(json{{"scene", ok}}, "\"dp\":0.02", "\"dp\":NaN"), 400, "(body)", ""},
      {"Infinity", "POST", "/api/v1/jobs", with_raw(json{{"scene", ok}}, "\"duration\":0.05", "\"duration\":Infinity"), 400, "(body)", ""},
      {"-Infinity", "POST", "/api/v1/jobs", with_raw(json{{"scene", ok}}, "\"duration\":0.05", "\"duration\":-Infinity"), 400, "(body)", ""},
      {"beyond double", "POST", "/api/v1/jobs", with_raw(json{{"scene", ok}}, "\"density\":1000", "\"density\":1e400"), 400, "(body)", ""},
      {"body over the limit", "POST", "/api/v1/jobs", R"({"scene": {"description": ")" + big + R"("}})", 413, "(body)", "65536"},
      {"wrong content type", "POST", "/api/v1/jobs", job_with([](json&) {}), 415, "Content-Type", "application/json", {}, "text/plain"},
      // The envelope.
      {"unknown field", "POST", "/api/v1/jobs", json{{"scene", ok}, {"priority", 1}}.dump(), 422, "priority", "accepted:"},
      {"scene not an object", "POST", "/api/v1/jobs", json{{"scene", "dam.json"}}.dump(), 422, "scene", ""},
      {"scene and base", "POST", "/api/v1/jobs", json{{"scene", ok}, {"base", ok}}.dump(), 422, "scene", ""},
      {"nothing to run", "POST", "/api/v1/jobs", json{{"fidelity", "draft"}}.dump(), 422, "base", "scene_id"},
      {"unknown fidelity", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", "ultra"}}.dump(), 422, "fidelity", "draft, standard, fine"},
      {"fidelity wrong type", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", 3}}.dump(), 422, "fidelity", "draft"},
      {"negative custom dp", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", {{"dp", -0.01}}}}.dump(), 422, "fidelity.dp", "[0.0001, 100]"},
      {"custom dp as string", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", {{"dp", "0.01"}}}}.dump(), 422, "fidelity.dp", "[0.0001, 100]"},
      {"fidelity unknown key", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", {{"dp", 0.02}, {"h", 1}}}}.dump(), 422, "fidelity.h", ""},
      {"idempotency key wrong type", "POST", "/api/v1/jobs", json{{"scene", ok}, {"idempotency_key", 7}}.dump(), 422, "idempotency_key", ""},
      {"idempotency key with spaces", "POST", "/api/v1/jobs", job_with([](json&) {}), 400, "Idempotency-Key", "printable", {{"Idempotency-Key", "a b"}}},
      {"idempotency keys differ", "POST", "/api/v1/jobs", json{{"scene", ok}, {"idempotency_key", "k1"}}.dump(), 422, "idempotency_key", "", {{"Idempotency-Key", "k2"}}},
      {"layout with a complete scene", "POST", "/api/v1/jobs", json{{"scene", ok}, {"structures", json::array()}}.dump(), 422, "structures", ""},
      // The scene (the validator's messages, under "scene.").
      {"negative dp", "POST", "/api/v1/jobs", job_with([](json& s) { s["dp"] = -0.02; }), 422, "scene.dp", "[0.0001, 100]"},
      {"dp as string", "POST", "/api/v1/jobs", job_with([](json& s) { s["dp"] = "0.02"; }), 422, "scene.dp", "[0.0001, 100]"},
      {"negative duration", "POST", "/api/v1/jobs", job_with([](json& s) { s["duration"] = -1; }), 422, "scene.duration", "(0, 100000]"},
      {"negative density", "POST", "/api/v1/jobs", job_with([](json& s) { s["materials"][0]["density"] = -1000; }), 422, "scene.materials[0].density", "(0, 100000]"},
      {"friction angle out of range", "POST", "/api/v1/jobs", job_with([](json& s) { s["materials"][0]["rheology"] = "friction-hbp"; s["materials"][0]["friction_angle"] = 95; }), 422, "scene.materials[0].friction_angle", "[0, 90)"},
      {"unknown rheology", "POST", "/api/v1/jobs", job_with([](json& s) { s["materials"][0]["rheology"] = "honey"; }), 422, "scene.materials[0].rheology", "newtonian"},
      {"dimensions 4", "POST", "/api/v1/jobs", job_with([](json& s) { s["dimensions"] = 4; }), 422, "scene.dimensions", "[2, 3]"},
      {"unknown scene field", "POST", "/api/v1/jobs", job_with([](json& s) { s["colour"] = "red"; }), 422, "scene.colour", "accepted"},
      {"materials huge array", "POST", "/api/v1/jobs", job_with([](json& s) { for (int k = 0; k < 100; ++k) s["materials"].push_back(s["materials"][0]); }), 422, "scene.materials", "1 to 16"},
      {"negative block size", "POST", "/api/v1/jobs", job_with([](json& s) { s["fluid"][0]["max"] = {-0.2, 0.2}; }), 422, "", ""},
      {"vector of 3 in 2D", "POST", "/api/v1/jobs", job_with([](json& s) { s["fluid"][0]["min"] = {0, 0, 0}; }), 422, "", ""},
      {"missing materials", "POST", "/api/v1/jobs", job_with([](json& s) { s.erase("materials"); }), 422, "scene.materials", "missing"},
      {"scene name traversal", "POST", "/api/v1/jobs", job_with([](json& s) { s["name"] = "../../etc/cron.d/x"; }), 422, "scene.name", "'..'"},
      {"dem traversal", "POST", "/api/v1/jobs", job_with([](json& s) { s["terrain"] = {{"dem", "../../../etc/passwd"}}; }), 422, "scene.terrain.dem", "no '..'"},
      {"dem absolute", "POST", "/api/v1/jobs", job_with([](json& s) { s["terrain"] = {{"dem", "/etc/passwd"}}; }), 422, "scene.terrain.dem", "not absolute"},
      {"layer absolute", "POST", "/api/v1/jobs", job_with([](json& s) { s["terrain"] = {{"dem", "dem.tif"}}; s["release"] = {{"polygon", {{"layer", "/etc/passwd"}}}}; }), 422, "scene.release.polygon.layer", "not absolute"},
      {"layer over the network", "POST", "/api/v1/jobs", job_with([](json& s) { s["terrain"] = {{"dem", "dem.tif"}}; s["structures"] = {{{"name", "D"}, {"axis", {{"layer", "/vsicurl/http://169.254.169.254/x.geojson"}}}}}; }), 422, "scene.structures[0].axis.layer", "not absolute"},
      {"layer traversal", "POST", "/api/v1/jobs", job_with([](json& s) { s["terrain"] = {{"dem", "dem.tif"}}; s["protected_zones"] = {{{"name", "V"}, {"polygon", {{"layer", "../../x.gpkg"}}}}}; }), 422, "scene.protected_zones[0].polygon.layer", "no '..'"},
      {"over the particle budget", "POST", "/api/v1/jobs", job_with([](json& s) { s["dp"] = 0.001; }), 422, "scene.dp", "5000"},
      {"over budget at a fidelity", "POST", "/api/v1/jobs", json{{"scene", ok}, {"fidelity", {{"dp", 0.0015}}}}.dump(), 422, "scene.dp", "particle budget"},
      // Layouts over a stored base.
      {"unknown scene id", "POST", "/api/v1/jobs", json{{"scene_id", 999}}.dump(), 404, "scene_id", ""},
      {"scene id as string", "POST", "/api/v1/jobs", json{{"scene_id", sid}}.dump(), 422, "scene_id", "integer"},
      {"unknown structure", "POST", "/api/v1/jobs", json{{"scene_id", scene_id}, {"structures", {"Dam9"}}}.dump(), 422, "structures[0]", "candidates"},
      {"structures wrong type", "POST", "/api/v1/jobs", json{{"scene_id", scene_id}, {"structures", "Dam1"}}.dump(), 422, "structures", ""},
      {"structures huge array", "POST", "/api/v1/jobs", json{{"scene_id", scene_id}, {"structures", json(std::vector<std::string>(5000, "Dam1"))}}.dump(), 422, "structures", "0 to 64"},
      {"variant traversal", "POST", "/api/v1/jobs", json{{"scene_id", scene_id}, {"variant", "../../x"}}.dump(), 422, "variant", "'..'"},
      {"variant with slash", "POST", "/api/v1/jobs", json{{"scene_id", scene_id}, {"variant", "a/b"}}.dump(), 422, "variant", ""},
      // Scenes and sweeps.
      {"scene malformed", "POST", "/api/v1/scenes", "{\"dimensions\": ", 400, "(body)", ""},
      {"scene unknown field", "POST", "/api/v1/scenes", scene_with([](json& s) { s["owner"] = "me"; }), 422, "owner", ""},
      {"scene out of range", "POST", "/api/v1/scenes", scene_with([](json& s) { s["materials"][0]["viscosity"] = -1; }), 422, "materials[0].viscosity", "[0, 1e+08]"},
      {"sweep without layouts", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}}.dump(), 422, "variants", "exactly one"},
      {"sweep with both", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"variants", json::array({{{"name", "C0"}}})}, {"factorial", {{"structures", json::array()}}}}.dump(), 422, "variants", ""},
      {"sweep duplicate variants", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"variants", json::array({{{"name", "C0"}}, {{"name", "C0"}}})}}.dump(), 422, "variants[1].name", "duplicate"},
      {"sweep empty variants", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"variants", json::array()}}.dump(), 422, "variants", "1 to 1024"},
      {"sweep variant unknown field", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"variants", json::array({{{"name", "C0"}, {"dp", 1}}})}}.dump(), 422, "variants[0].dp", ""},
      {"sweep name traversal", "POST", "/api/v1/sweeps", json{{"name", "../sweep"}, {"scene_id", scene_id}, {"variants", json::array({{{"name", "C0"}}})}}.dump(), 422, "name", "'..'"},
      {"sweep variant traversal", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"variants", json::array({{{"name", ".."}}})}}.dump(), 422, "variants[0].name", ""},
      {"factorial unknown structure", "POST", "/api/v1/sweeps", json{{"scene_id", scene_id}, {"factorial", {{"structures", {"Dam1"}}}}}.dump(), 422, "factorial.structures[0]", "candidates"},
      // Query strings and URLs.
      {"unknown status", "GET", "/api/v1/jobs?status=finished", "", 400, "status", "queued, running"},
      {"negative limit", "GET", "/api/v1/jobs?limit=-1", "", 400, "limit", "[1, 10000]"},
      {"limit not a number", "GET", "/api/v1/jobs?limit=ten", "", 400, "limit", ""},
      {"huge limit", "GET", "/api/v1/jobs?limit=99999999", "", 400, "limit", "[1, 10000]"},
      {"unknown parameter", "GET", "/api/v1/jobs?order=desc", "", 400, "order", ""},
      {"unknown sweep filter", "GET", "/api/v1/jobs?sweep=999", "", 404, "sweep", ""},
      {"series traversal", "GET", job_path + "/series/..%2F..%2F..%2Fetc%2Fpasswd.csv", "", 400, "name", "'..'"},
      {"series dotdot", "GET", job_path + "/series/...csv", "", 400, "name", ""},
      {"raster traversal", "GET", job_path + "/rasters/..%2Fmax_depth.tif", "", 400, "name", ""},
      {"compare without jobs", "GET", "/api/v1/compare", "", 400, "jobs", "job ids"},
      {"compare bad ids", "GET", "/api/v1/compare?jobs=a,b", "", 400, "jobs", ""},
      {"compare unknown job", "GET", "/api/v1/compare?jobs=99999", "", 404, "baseline", ""},
      {"compare queued job", "GET", "/api/v1/compare?jobs=" + std::to_string(job.body.at("id").get<int64_t>()), "", 409, "baseline", "done"},
      {"metrics of a queued job", "GET", job_path + "/metrics", "", 409, "status", "queued"},
      {"unknown job", "GET", "/api/v1/jobs/424242", "", 404, "id", ""},
      {"job id not a number", "GET", "/api/v1/jobs/abc", "", 404, "path", ""},
      {"unknown scene", "GET", "/api/v1/scenes/77", "", 404, "id", ""},
      {"cancel unknown job", "DELETE", "/api/v1/jobs/424242", "", 404, "id", ""},
      {"unknown path", "GET", "/api/v2/jobs", "", 404, "path", ""},
      // Methods.
      {"PUT jobs", "PUT", "/api/v1/jobs", "{}", 405, "method", "GET, HEAD, POST"},
      {"PATCH a job", "PATCH", job_path, "{}", 405, "method", "DELETE"},
      {"DELETE scenes", "DELETE", "/api/v1/scenes", "", 405, "method", ""},
      {"POST health", "POST", "/api/v1/health", "{}", 405, "method", ""},
      {"DELETE sweeps", "DELETE", "/api/v1/sweeps", "", 405, "method", "POST"},
  };
  ASSERT_GE(cases.size(), 50u);

  const std::vector<std::string> tables = {"jobs", "runs", "metrics", "series", "service_scenes", "service_sweeps"};
  std::map<std::string, int64_t> before;
  for (const auto& t : tables) before[t] = query_int("SELECT COUNT(*) FROM " + t);
  const int64_t changes_before = query_int("SELECT COALESCE(MAX(updated_at), '') = '' FROM jobs");

  for (auto c : cases) {
    SCOPED_TRACE(c.name);
    if (c.auth)
      for (const auto& h : auth) c.headers.insert(h);
    const Reply r = request(c.method, c.path, c.body, c.headers, c.content_type);
    expect_problem(c, r);
  }

  std::cerr << "[validation] " << cases.size() << " malformed requests checked\n";
  for (const auto& t : tables) EXPECT_EQ(query_int("SELECT COUNT(*) FROM " + t), before[t]) << t;
  EXPECT_EQ(query_int("SELECT COALESCE(MAX(updated_at), '') = '' FROM jobs"), changes_before);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs WHERE status <> 'queued'"), 0);
  // Reads stay open without the token; the token never reaches the log.
  EXPECT_EQ(request("GET", "/api/v1/jobs").status, 200);
  EXPECT_EQ(request("GET", "/api/v1/health").status, 200);
  server_.terminate();
  EXPECT_EQ(server_.log_text().find(kToken), std::string::npos);
}

}  // namespace
