// Issue 24, "the service must survive one hostile client": one test per defect the outside tester found,
// against the real `runout serve` on loopback (service_harness.hpp). Framing cases (chunked bodies, trickled
// heads, duplicate Content-Length) use raw sockets; every wait is bounded (a few seconds per test).
#include "service/service_harness.hpp"

#include <atomic>
#include <deque>

using namespace runout_test;

namespace {

// An /estimate body: the shipped flume for 0.05 s at dp 0.06 m, its DEM at `dem`.
json flume_with_dem(const std::string& dem) {
  std::ifstream in(RUNOUT_SOURCE_DIR "/scenarios/flume/flume.json");
  json s = json::parse(in);
  s["duration"] = 0.05;
  s["terrain"]["dem"] = dem;
  return json{{"base", s}, {"structures", json::array()}, {"fidelity", {{"dp", 0.06}}}};
}

const std::string kToken = "hostile-test-token";

std::string post_head(const std::string& path, const std::string& extra) {
  return "POST /api/v1" + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n" + extra + "\r\n";
}

std::string chunked(const std::string& body, size_t piece) {
  std::string out;
  char size[32];
  for (size_t off = 0; off < body.size(); off += piece) {
    const std::string part = body.substr(off, piece);
    std::snprintf(size, sizeof size, "%zx\r\n", part.size());
    out += size + part + "\r\n";
  }
  return out + "0\r\n\r\n";
}

class Hostile : public ServiceTest {
 protected:
  double ms_since(std::chrono::steady_clock::time_point t0) const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  void write_token(const std::vector<std::string>& tokens) {
    std::ofstream out(dir_ / "token");
    for (const auto& t : tokens) out << t << "\n";
  }
  httplib::Headers auth(const std::string& token = kToken) const { return {{"Authorization", "Bearer " + token}}; }
};

// D1: a value nested 70 000 deep overflowed the stack (SIGSEGV) on every body-taking route.
TEST_F(Hostile, DeeplyNestedBodyIsRefusedNamingTheLimit) {
  start({"--workers", "0"});
  const std::string deep = std::string(70000, '[') + std::string(70000, ']');
  for (const auto& [path, body] : std::vector<std::pair<std::string, std::string>>{
           {"/jobs", "{\"scene\": {\"x\": " + deep + "}}"},
           {"/estimate", "{\"base\": {\"x\": " + deep + "}}"},
           {"/scenes", "{\"x\": " + deep + "}"},
           {"/sweeps", "{\"base\": {\"x\": " + deep + "}, \"variants\": []}"},
           {"/jobs", "{\"scene\": " + std::string(65, '{') + std::string(65, '}') + "}"}}) {
    const Reply r = request("POST", "/api/v1" + path, body);
    ASSERT_EQ(r.status, 422) << path << ": " << r.text.substr(0, 300);
    EXPECT_EQ(first_error(r.body).at("field"), "(body)");
    EXPECT_NE(first_error(r.body).at("message").get<std::string>().find("64"), std::string::npos) << r.text;
  }
  // Brackets inside strings do not count; 64 levels are accepted as far as nesting goes.
  const Reply in_string = post("/estimate", {{"scene", tiny_scene(std::string(100, '['))}});
  EXPECT_EQ(in_string.status, 200) << in_string.text.substr(0, 300);
  EXPECT_EQ(get("/health").status, 200);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 0);
}

// D2: --max-body did not apply to chunked bodies, and bodies were read before the token was checked.
TEST_F(Hostile, BodyLimitHoldsForEveryTransferCodingAndTheTokenComesFirst) {
  write_token({kToken});
  start({"--workers", "0", "--token-file", (dir_ / "token").string(), "--max-body", "65536"});
  const std::string authz = "Authorization: Bearer " + kToken + "\r\n";
  {  // Chunked, three times the limit: refused while reading, before the whole body is sent.
    Raw c(server_.port());
    ASSERT_TRUE(c.send(post_head("/jobs", authz + "Transfer-Encoding: chunked\r\n")));
    const std::string big = "{\"scene\": {\"description\": \"" + std::string(3 * 65536, 'x') + "\"}}";
    (void)c.send(chunked(big, 8192).substr(0, 70000 + 8 * 10));  // a little over the limit, never the end
    const std::string r = c.response();
    EXPECT_EQ(status_of(r), 413) << r.substr(0, 300);
    EXPECT_NE(first_error(body_of(r)).at("message").get<std::string>().find("65536"), std::string::npos);
    EXPECT_TRUE(c.closed_within(3000ms));
  }
  {  // No token, 64 MiB announced and nothing sent: 401 at once, the body is never waited for.
    Raw c(server_.port());
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(c.send(post_head("/jobs", "Content-Length: 67108864\r\n")));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 401) << r.substr(0, 300);
    EXPECT_LT(ms_since(t0), 2000);
    EXPECT_TRUE(c.closed_within(3000ms));
  }
  {  // No token, chunked: 401 before a chunk is read.
    Raw c(server_.port());
    ASSERT_TRUE(c.send(post_head("/scenes", "Transfer-Encoding: chunked\r\n") + "10000\r\n"));
    EXPECT_EQ(status_of(c.response(3000ms)), 401);
  }
  {  // With the token, a Content-Length over the limit: 413 before the body.
    Raw c(server_.port());
    ASSERT_TRUE(c.send(post_head("/jobs", authz + "Content-Length: 3145728\r\n")));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 413) << r.substr(0, 300);
    EXPECT_EQ(first_error(body_of(r)).at("field"), "(body)");
  }
  {  // A compressed body could expand without bound once decoded: refused.
    Raw c(server_.port());
    ASSERT_TRUE(c.send(post_head("/jobs", authz + "Content-Encoding: gzip\r\nContent-Length: 10\r\n") + "0123456789"));
    EXPECT_EQ(status_of(c.response(3000ms)), 415);
  }
  {  // A chunked body within the limit is a job like any other.
    Raw c(server_.port());
    const std::string body = json{{"scene", tiny_scene("chunked")}}.dump();
    ASSERT_TRUE(c.send(post_head("/jobs", authz + "Transfer-Encoding: chunked\r\n") + chunked(body, 100)));
    const std::string r = c.response();
    EXPECT_EQ(status_of(r), 201) << r.substr(0, 300);
  }
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 1);
  EXPECT_EQ(get("/health").status, 200);
}

// D3: 20 connections sending a header byte a second kept /health unanswered for 25 s; none was closed.
TEST_F(Hostile, SlowClientsAreCutAtTheDeadlineAndHealthStaysFast) {
  start({"--workers", "0", "--header-timeout", "2", "--max-connections-per-client", "8"});
  std::vector<std::unique_ptr<Raw>> slow;
  for (int k = 0; k < 20; ++k) slow.push_back(std::make_unique<Raw>(server_.port()));
  std::atomic<bool> stop{false};
  std::thread trickle([&] {  // one byte per connection every 200 ms: a head that never ends
    const std::string head = "GET /api/v1/health HTTP/1.1\r\nX-Pad: " + std::string(1000, 'a');
    for (size_t i = 0; !stop.load() && i < head.size(); ++i) {
      for (auto& c : slow) (void)c->send(head.substr(i, 1));
      std::this_thread::sleep_for(200ms);
    }
  });
  const auto t0 = std::chrono::steady_clock::now();
  double worst = 0;
  int answered = 0;
  for (int k = 0; k < 10; ++k) {  // health from another client address, meanwhile
    Raw h(server_.port(), "127.0.0.2");
    const auto s = std::chrono::steady_clock::now();
    ASSERT_TRUE(h.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n"));
    const std::string r = h.response(3000ms);
    worst = std::max(worst, ms_since(s));
    answered += status_of(r) == 200;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(answered, 10);
  EXPECT_LT(worst, 1000) << "slowest /health " << worst << " ms";
  // Every slow connection is closed within the header deadline (+ slack) although it is still trickling:
  // 12 refused at once (over 8 per address, 429), the other 8 cut at 2 s (408).
  int closed = 0;
  for (auto& c : slow) closed += c->closed_within(std::chrono::milliseconds(
      static_cast<int64_t>(std::max(0.0, 4000 - ms_since(t0)))));
  stop = true;
  trickle.join();
  EXPECT_EQ(closed, 20);
  EXPECT_LT(ms_since(t0), 5000);
  const Reply health = get("/health");
  ASSERT_EQ(health.status, 200);
  EXPECT_GE(health.body.at("connections").at("refused").get<int64_t>(), 12);
  EXPECT_GE(health.body.at("connections").at("timed_out").get<int64_t>(), 8);
}

// D4, D5: --scene-dir containment was lexical (a link inside it was followed outside), and errors showed
// absolute server paths.
TEST_F(Hostile, SceneFilesMustResolveInsideTheSceneDirAndErrorsShowNoServerPaths) {
  const fs::path scenes = dir_ / "scenes", outside = dir_ / "outside";
  fs::create_directories(scenes);
  fs::create_directories(outside);
  const fs::path flume = RUNOUT_SOURCE_DIR "/scenarios/flume";
  for (const std::string ext : {".asc", ".prj"}) {  // the grid and its CRS
    fs::copy_file(flume / ("flume_dem" + ext), outside / ("dem" + ext));
    fs::copy_file(flume / ("flume_dem" + ext), scenes / ("inside" + ext));
  }
  fs::create_symlink(outside / "dem.asc", scenes / "link.asc");
  fs::create_directory_symlink(outside, scenes / "sub");
  fs::create_symlink("/etc/passwd", scenes / "passwd.asc");
  start({"--workers", "0", "--scene-dir", scenes.string()});
  for (const std::string dem : {"link.asc", "sub/dem.asc", "passwd.asc"}) {
    const Reply r = post("/estimate", flume_with_dem(dem));
    EXPECT_EQ(r.status, 422) << dem << ": " << r.text.substr(0, 300);
    EXPECT_EQ(first_error(r.body).at("field"), "base.terrain.dem") << dem;
    EXPECT_NE(r.text.find("outside the service's scene directory"), std::string::npos) << r.text.substr(0, 300);
  }
  const Reply ok = post("/estimate", flume_with_dem("inside.asc"));
  EXPECT_EQ(ok.status, 200) << ok.text.substr(0, 300);
  // A missing file: named as the client wrote it, relative to the scene directory, never by a server path.
  const Reply missing = post("/estimate", flume_with_dem("missing.asc"));
  EXPECT_EQ(missing.status, 422) << missing.text.substr(0, 300);
  EXPECT_NE(missing.text.find("missing.asc"), std::string::npos) << missing.text;
  EXPECT_EQ(missing.text.find(dir_.string()), std::string::npos) << missing.text;
  EXPECT_EQ(missing.text.find(fs::weakly_canonical(dir_).string()), std::string::npos) << missing.text;
}

// D6–D9: strict query strings, media types, idempotency keys and Content-Length.
TEST_F(Hostile, QueriesMediaTypesKeysAndLengthsAreStrict) {
  start({"--workers", "0"});
  for (const std::string q : {"limit=5=6", "limit=ten", "limit=5&limit=6", "limit", "=5"}) {
    const Reply r = get("/jobs?" + q);
    EXPECT_EQ(r.status, 400) << q << ": " << r.text;
  }
  EXPECT_EQ(first_error(get("/jobs?limit=5=6").body).at("field"), "limit");
  EXPECT_NE(get("/jobs?limit=ten").text.find("[1, 10000]"), std::string::npos);
  EXPECT_EQ(get("/jobs?limit=5").status, 200);

  const std::string body = json{{"scene", tiny_scene("types")}}.dump();
  auto estimate = [&](const std::string& type) { return request("POST", "/api/v1/estimate", body, {}, type).status; };
  EXPECT_EQ(estimate("application/jsonx"), 415);
  EXPECT_EQ(estimate("application/json-patch+json"), 415);
  EXPECT_EQ(estimate("text/json"), 415);
  EXPECT_EQ(estimate("application/json; charset=latin1"), 415);
  EXPECT_EQ(estimate("Application/JSON"), 200);
  EXPECT_EQ(estimate("application/json; charset=UTF-8"), 200);

  auto raw_post = [&](const std::string& headers, const std::string& payload) {
    Raw c(server_.port());
    (void)c.send(post_head("/jobs", headers) + payload);
    return c.response(3000ms);
  };
  const std::string r1 = raw_post("Idempotency-Key:\r\nContent-Length: " + std::to_string(body.size()) + "\r\n", body);
  EXPECT_EQ(status_of(r1), 400) << r1.substr(0, 300);
  EXPECT_EQ(first_error(body_of(r1)).at("field"), "Idempotency-Key");
  const std::string r2 = raw_post("Idempotency-Key: " + std::string(201, 'k') + "\r\nContent-Length: " +
                                      std::to_string(body.size()) + "\r\n", body);
  EXPECT_EQ(status_of(r2), 400);
  const std::string r3 = raw_post("Idempotency-Key: a\r\nIdempotency-Key: b\r\nContent-Length: " +
                                      std::to_string(body.size()) + "\r\n", body);
  EXPECT_EQ(status_of(r3), 400);

  const std::string n = std::to_string(body.size());
  const std::string d1 = raw_post("Content-Length: " + n + "\r\nContent-Length: " + std::to_string(body.size() + 5) + "\r\n", body);
  EXPECT_EQ(status_of(d1), 400) << d1.substr(0, 300);
  EXPECT_EQ(first_error(body_of(d1)).at("field"), "Content-Length");
  EXPECT_EQ(status_of(raw_post("Content-Length: " + n + "\r\nContent-Length: " + n + "\r\n", body)), 400);
  EXPECT_EQ(status_of(raw_post("Content-Length: " + n + "\r\nTransfer-Encoding: chunked\r\n", body)), 400);
  EXPECT_EQ(status_of(raw_post("Content-Length: -1\r\n", body)), 400);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 0);  // nothing refused was written
}

// Pipelined requests are answered in order; a request followed by a half-close is still answered.
TEST_F(Hostile, PipelinedAndHalfClosedRequestsAreAnswered) {
  start({"--workers", "0"});
  Raw c(server_.port());
  ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\nHEAD /api/v1/openapi.json HTTP/1.1\r\nHost: x\r\n\r\n"
                     "GET /api/v1/jobs?limit=2 HTTP/1.1\r\nHost: x\r\n\r\n"));
  c.shutdown_write();
  const std::string a = c.response(), b = c.response(5000ms, true), d = c.response();
  EXPECT_EQ(status_of(a), 200);
  EXPECT_TRUE(body_of(a).contains("backlog")) << a.substr(0, 200);
  EXPECT_EQ(status_of(b), 200);
  EXPECT_EQ(b.substr(b.find("\r\n\r\n") + 4), "");  // HEAD: no body
  EXPECT_EQ(status_of(d), 200);
  EXPECT_EQ(body_of(d).at("limit"), 2) << d.substr(0, 200);
  EXPECT_TRUE(c.closed_within(3000ms));
}

// The work budget: predicted CPU-seconds queued per token and in all; over it 429 with Retry-After.
TEST_F(Hostile, WorkBudgetRefusesWithRetryAfterPerTokenAndInAll) {
  write_token({kToken, "second-token"});
  // A probe server to learn the predicted cost of one tiny job (the cost model, one thread).
  start({"--workers", "0", "--threads-per-job", "1", "--token-file", (dir_ / "token").string()});
  const json job = {{"scene", tiny_scene("budget")}};
  const Reply est = post("/estimate", job, auth());
  ASSERT_EQ(est.status, 200) << est.text;
  const double cost = est.body.at("seconds_estimate").get<double>();
  ASSERT_GT(cost, 0);
  server_.terminate();
  fs::remove(db_);
  // Two jobs per token fit, five in all.
  auto text = [](double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.17g", v);
    return std::string(b);
  };
  const std::string per_token = text(2.5 * cost), total = text(4.5 * cost);
  start({"--workers", "0", "--threads-per-job", "1", "--token-file", (dir_ / "token").string(), "--budget-token-cpu-s",
         per_token, "--budget-total-cpu-s", total});
  auto submit = [&](const std::string& key, const std::string& token) {
    return post("/jobs", job, {{"Authorization", "Bearer " + token}, {"Idempotency-Key", key}});
  };
  EXPECT_EQ(submit("a1", kToken).status, 201);
  EXPECT_EQ(submit("a2", kToken).status, 201);
  const Reply a3 = submit("a3", kToken);
  ASSERT_EQ(a3.status, 429) << a3.text;
  EXPECT_EQ(first_error(a3.body).at("field"), "(budget)");
  EXPECT_EQ(a3.body.at("budget").at("scope"), "per token");
  EXPECT_EQ(a3.body.at("type"), "https://runout.invalid/problems/over-work-budget");
  EXPECT_EQ(media_type(a3.headers), "application/problem+json");
  EXPECT_NEAR(a3.body.at("budget").at("limit_cpu_s").get<double>(), 2.5 * cost, 1e-6 * cost + 1e-9);
  bool retry_after = false;
  for (const auto& [k, v] : a3.headers) retry_after = retry_after || (k == "Retry-After" && std::stoi(v) >= 1);
  EXPECT_TRUE(retry_after);
  EXPECT_EQ(submit("a1", kToken).status, 200);  // a retry of an accepted job is not new work
  // The other token has its own budget, until the total is reached.
  EXPECT_EQ(submit("b1", "second-token").status, 201);
  EXPECT_EQ(submit("b2", "second-token").status, 201);
  const Reply b3 = submit("b3", "second-token");
  EXPECT_EQ(b3.status, 429);
  const Reply health = get("/health");
  ASSERT_EQ(health.status, 200);
  EXPECT_EQ(health.body.at("backlog").at("jobs"), 4);
  EXPECT_NEAR(health.body.at("backlog").at("cpu_seconds").get<double>(), 4 * cost, 1e-6 * cost + 1e-9);
  // Cancelling frees the budget.
  const Reply first = get("/jobs?limit=1");
  const int64_t id = first.body.at("jobs")[0].at("id");
  EXPECT_EQ(request("DELETE", "/api/v1/jobs/" + std::to_string(id), "", auth()).status, 200);
  EXPECT_EQ(submit("a4", kToken).status, 201);
  // A sweep is counted whole: one more job's worth is over this token's budget, and nothing is written.
  const Reply sweep = post("/sweeps", {{"name", "over"}, {"base", tiny_scene("sweep")}, {"variants", json::array({{{"name", "C0"}}})}},
                           auth());
  EXPECT_EQ(sweep.status, 429) << sweep.text.substr(0, 300);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM service_sweeps"), 0);
  // A job that alone exceeds the budget can never be accepted: 422, not 429.
  const Reply huge = post("/jobs", {{"scene", tiny_scene("huge", 1000.0)}}, auth());
  EXPECT_EQ(huge.status, 422) << huge.text.substr(0, 300);
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM jobs"), 5);
}

// Issue 46: findings of the second outside probe, one test each.

// One address opening ~300 connections a second: its refused (429) connections lingered 2 s each and counted
// toward --max-connections, so every other client got 503. The bar, declared before measuring: while the flood
// runs, at least 9 of 10 /health requests from another address are answered 200 within 3 s each.
TEST_F(Hostile, AConnectionFloodFromOneAddressLeavesOtherClientsServed) {
  start({"--workers", "0", "--max-connections", "256", "--max-connections-per-client", "8"});
  std::atomic<bool> stop{false};
  std::atomic<int> opened{0};
  // One connection every ~3 ms, each held (never sending) for 1 s by the client: about 330 open at once, within
  // a default limit of 1024 descriptors; a refusal the server kept for its 2 s linger would still pile up.
  std::thread flood([&] {
    std::deque<std::pair<std::chrono::steady_clock::time_point, std::unique_ptr<Raw>>> held;
    while (!stop.load()) {
      const auto now = std::chrono::steady_clock::now();
      try {
        held.emplace_back(now, std::make_unique<Raw>(server_.port()));
        ++opened;
      } catch (const std::exception&) {  // out of descriptors or ports: the flood goes on with what it holds
      }
      while (!held.empty() && now - held.front().first > 1s) held.pop_front();
      std::this_thread::sleep_for(3ms);
    }
  });
  std::this_thread::sleep_for(1500ms);  // the flood at its height: its first refusals would still linger
  int answered = 0;
  std::string last;
  for (int k = 0; k < 10; ++k) {
    Raw h(server_.port(), "127.0.0.2");
    (void)h.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string r = h.response(3000ms);
    answered += status_of(r) == 200;
    if (status_of(r) != 200) last = r.substr(0, 300);
    std::this_thread::sleep_for(100ms);
  }
  stop = true;
  flood.join();
  EXPECT_GE(opened.load(), 300) << "the flood was slower than intended";
  EXPECT_GE(answered, 9) << "the flood opened " << opened.load() << " connections; last refusal: " << last;
  EXPECT_EQ(get("/health").status, 200);
}

// A NUL in a header's name or in the method was taken for a token character: `Content-Length\0: 42` was ignored,
// and the 42 bytes after the head were read as a second request (smuggling).
TEST_F(Hostile, NulInAHeaderNameOrMethodIsRefused) {
  start({"--workers", "0"});
  const std::string second = "GET /api/v1/jobs HTTP/1.1\r\nHost: x\r\n\r\n";
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\nContent-Length" + std::string(1, '\0') + ": " +
                       std::to_string(second.size()) + "\r\n\r\n" + second));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 400) << r.substr(0, 300);
    EXPECT_EQ(status_of(c.response(1000ms)), 0) << "the body was read as a request of its own";
  }
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET" + std::string(1, '\0') + " /api/v1/health HTTP/1.1\r\nHost: x\r\n\r\n"));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 400) << r.substr(0, 300);
  }
  EXPECT_EQ(get("/health").status, 200);
}

// Control characters and DEL in a header's value were accepted; RFC 9110 allows only HTAB, SP, visible
// characters and obs-text there.
TEST_F(Hostile, ControlCharactersInAHeaderValueAreRefused) {
  start({"--workers", "0"});
  auto with_value = [&](const std::string& value) {
    Raw c(server_.port());
    (void)c.send("GET /api/v1/health HTTP/1.1\r\nHost: x\r\nX-Note: a" + value + "b\r\n\r\n");
    return c.response(3000ms);
  };
  for (const char bad : {'\x01', '\x08', '\x0b', '\x1b', '\x7f'}) {
    const std::string r = with_value(std::string(1, bad));
    EXPECT_EQ(status_of(r), 400) << "byte " << static_cast<int>(bad) << ": " << r.substr(0, 300);
  }
  EXPECT_EQ(status_of(with_value("\t")), 200);
  EXPECT_EQ(status_of(with_value(" c ")), 200);
}

// A chunk extension arriving in one read was skipped unread and counted against no limit: 60 kB of it (one read
// on loopback) with --max-body 4096 was accepted. Refused whole or in pieces, and at 1 MB.
TEST_F(Hostile, AHugeChunkExtensionIsRefused) {
  start({"--workers", "0", "--max-body", "4096"});
  const std::string body = json{{"scene", tiny_scene("ext")}}.dump();
  ASSERT_LT(body.size(), 4096u);
  char size[32];
  std::snprintf(size, sizeof size, "%zx", body.size());
  for (const size_t ext : {size_t{60000}, size_t{1} << 20}) {
    Raw c(server_.port());
    ASSERT_TRUE(c.send(post_head("/estimate", "Transfer-Encoding: chunked\r\n") + size + ";x=" + std::string(ext, 'e') +
                       "\r\n" + body + "\r\n0\r\n\r\n"));
    const std::string r = c.response(5000ms);
    const int status = status_of(r);
    EXPECT_TRUE(status == 413 || status == 400) << ext << " bytes: " << r.substr(0, 300);
  }
  EXPECT_EQ(get("/health").status, 200);
}

// RFC 9112 3.2: a server MUST accept the absolute form of a target (routed by its path), and MUST refuse with
// 400 an HTTP/1.1 request without a Host header.
TEST_F(Hostile, AbsoluteFormTargetsAreRoutedAndHostIsRequired) {
  start({"--workers", "0"});
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET http://127.0.0.1/api/v1/jobs?limit=3 HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 200) << r.substr(0, 300);
    EXPECT_EQ(body_of(r).value("limit", 0), 3) << r.substr(0, 300);
  }
  {
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.1\r\n\r\n"));
    const std::string r = c.response(3000ms);
    EXPECT_EQ(status_of(r), 400) << r.substr(0, 300);
    EXPECT_EQ(first_error(body_of(r)).at("field"), "Host") << r.substr(0, 300);
  }
  {  // HTTP/1.0 has no Host requirement.
    Raw c(server_.port());
    ASSERT_TRUE(c.send("GET /api/v1/health HTTP/1.0\r\n\r\n"));
    EXPECT_EQ(status_of(c.response(3000ms)), 200);
  }
}

// A relative symbolic link in --scene-dir whose target does not exist beside it passed the containment check
// (weakly_canonical keeps a dangling link as a plain name), and GDAL then read the link's target relative to the
// server's working directory: terrain from outside the scene directory.
TEST_F(Hostile, ADanglingRelativeLinkInTheSceneDirIsRefused) {
  const fs::path scenes = dir_ / "scenes";
  fs::create_directories(scenes);
  const fs::path flume = RUNOUT_SOURCE_DIR "/scenarios/flume";
  const fs::path target = fs::relative(flume / "flume_dem.asc", fs::current_path());  // the server's cwd is ours
  ASSERT_FALSE(target.empty());
  ASSERT_TRUE(fs::exists(fs::current_path() / target));
  ASSERT_FALSE(fs::exists(scenes / target)) << "the link would resolve inside the scene directory";
  fs::create_symlink(target, scenes / "link.asc");
  fs::copy_file(flume / "flume_dem.asc", scenes / "inside.asc");
  fs::copy_file(flume / "flume_dem.prj", scenes / "inside.prj");
  fs::create_symlink("inside.asc", scenes / "good.asc");  // a link that resolves inside is fine
  fs::create_symlink("inside.prj", scenes / "good.prj");  // (its CRS)
  start({"--workers", "0", "--scene-dir", scenes.string()});
  const Reply r = post("/estimate", flume_with_dem("link.asc"));
  EXPECT_EQ(r.status, 422) << r.text.substr(0, 300);
  EXPECT_EQ(first_error(r.body).at("field"), "base.terrain.dem") << r.text.substr(0, 300);
  EXPECT_NE(r.text.find("outside the service's scene directory"), std::string::npos) << r.text.substr(0, 300);
  const Reply good = post("/estimate", flume_with_dem("good.asc"));
  EXPECT_EQ(good.status, 200) << good.text.substr(0, 300);
}

}  // namespace
