// Service benchmark (not a test): requests per second on the read endpoints and the latency of submissions,
// against the real `runout serve` started as a child process on a loopback port with a scratch database.
//
//   build/bench/bench_service [--runout build/runout] [--clients 4] [--seconds 3] [--jobs 1000]
//
// Phases: (1) one tiny job is run to completion (so /metrics, /series and /compare have a stored run);
// (2) the server is restarted with --workers 0 and `--jobs` tiny jobs are submitted, first one at a time
// (latency of a single client), then from 16 clients at once (throughput); (3) each read endpoint is hammered
// by `--clients` keep-alive clients for `--seconds`, on a queue of that many jobs. docs/performance.md.
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

struct Child {
  pid_t pid = -1;
  int port = 0;
};

Child start(const std::string& runout, const fs::path& dir, const std::vector<std::string>& extra) {
  int out[2];
  if (::pipe(out) != 0) std::exit(1);
  std::vector<std::string> args = {runout, "serve", "--port", "0", "--db", (dir / "bench.db").string(), "--runs", (dir / "runs").string()};
  args.insert(args.end(), extra.begin(), extra.end());
  Child c;
  c.pid = ::fork();
  if (c.pid == 0) {
    ::dup2(out[1], 1);
    ::close(out[0]);
    ::close(out[1]);
    std::FILE* err = std::fopen((dir / "server.log").c_str(), "a");
    if (err) ::dup2(fileno(err), 2);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(runout.c_str(), argv.data());
    std::_Exit(127);
  }
  ::close(out[1]);
  std::string text;
  const std::regex re(R"(listening on http://[0-9.]+:([0-9]+))");
  std::smatch m;
  const auto deadline = Clock::now() + std::chrono::seconds(30);
  while (!std::regex_search(text, m, re) && Clock::now() < deadline) {
    pollfd p{out[0], POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    char buf[512];
    const ssize_t n = ::read(out[0], buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, static_cast<size_t>(n));
  }
  ::close(out[0]);
  if (!std::regex_search(text, m, re)) {
    std::fprintf(stderr, "runout serve did not start: %s\n", text.c_str());
    std::exit(1);
  }
  c.port = std::stoi(m[1].str());
  return c;
}

void stop(Child& c) {
  ::kill(c.pid, SIGTERM);
  ::waitpid(c.pid, nullptr, 0);
}

json tiny_scene(const std::string& name) {
  return {{"name", name},
          {"dimensions", 2},
          {"dp", 0.02},
          {"duration", 0.05},
          {"materials", json::array({{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}}})},
          {"fluid", json::array({{{"min", {0, 0}}, {"max", {0.2, 0.2}}, {"material", "water"}}})},
          {"boundaries", json::array({{{"type", "tank"}, {"min", {0, 0}}, {"max", {0.4, 0.3}}}})}};
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

}  // namespace

int main(int argc, char** argv) {
  std::string runout = RUNOUT_BINARY_DIR "/runout";
  int clients = 4, jobs = 1000;
  double seconds = 3;
  for (int k = 1; k + 1 < argc; k += 2) {
    if (!std::strcmp(argv[k], "--runout")) runout = argv[k + 1];
    else if (!std::strcmp(argv[k], "--clients")) clients = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--seconds")) seconds = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--jobs")) jobs = std::atoi(argv[k + 1]);
  }
  const fs::path dir = fs::temp_directory_path() / ("runout_bench_service_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);

  // (1) One job run to completion.
  Child server = start(runout, dir, {"--workers", "1", "--threads-per-job", "1"});
  {
    httplib::Client c("127.0.0.1", server.port);
    auto r = c.Post("/api/v1/jobs", json{{"scene", tiny_scene("bench-0")}}.dump(), "application/json");
    if (!r || r->status != 201) return 1;
    for (;;) {
      auto j = c.Get("/api/v1/jobs/1");
      if (j && json::parse(j->body).value("status", "") == "done") break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  stop(server);

  // (2) Submissions, queue only.
  server = start(runout, dir, {"--workers", "0"});
  const std::string body_prefix = "bench-";
  std::vector<double> single;
  const int sequential = std::min(jobs / 2, 200);
  {
    httplib::Client c("127.0.0.1", server.port);
    for (int i = 1; i <= sequential; ++i) {
      const std::string body = json{{"scene", tiny_scene(body_prefix + std::to_string(i))}}.dump();
      const auto t0 = Clock::now();
      auto r = c.Post("/api/v1/jobs", {{"Idempotency-Key", "bench-" + std::to_string(i)}}, body, "application/json");
      single.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (!r || r->status != 201) return 1;
    }
  }
  std::vector<double> concurrent;
  std::mutex mutex;
  const auto c0 = Clock::now();
  {
    std::vector<std::thread> pool;
    std::atomic<int> next{sequential + 1};
    for (int t = 0; t < 16; ++t)
      pool.emplace_back([&] {
        httplib::Client c("127.0.0.1", server.port);
        std::vector<double> mine;
        for (int i; (i = next++) < jobs;) {
          const std::string body = json{{"scene", tiny_scene(body_prefix + std::to_string(i))}}.dump();
          const auto t0 = Clock::now();
          auto r = c.Post("/api/v1/jobs", {{"Idempotency-Key", "bench-" + std::to_string(i)}}, body, "application/json");
          mine.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
          if (!r || r->status != 201) std::fprintf(stderr, "submission %d failed\n", i);
        }
        std::lock_guard lock(mutex);
        concurrent.insert(concurrent.end(), mine.begin(), mine.end());
      });
    for (auto& t : pool) t.join();
  }
  const double concurrent_s = std::chrono::duration<double>(Clock::now() - c0).count();
  std::printf("runout serve benchmark (%s), %d jobs in the queue, read clients: %d, %.1f s per endpoint\n\n",
              runout.c_str(), jobs, clients, seconds);
  std::printf("POST /api/v1/jobs (tiny 2D scene, validated and resolved, one fsync'd transaction)\n");
  std::printf("  1 client,   %4d submissions: p50 %.2f ms, p95 %.2f ms, p99 %.2f ms, max %.2f ms\n", sequential,
              percentile(single, 0.5), percentile(single, 0.95), percentile(single, 0.99), percentile(single, 1.0));
  std::printf("  16 clients, %4zu submissions: %.0f submissions/s; p50 %.2f ms, p95 %.2f ms, p99 %.2f ms\n\n",
              concurrent.size(), concurrent.size() / concurrent_s, percentile(concurrent, 0.5),
              percentile(concurrent, 0.95), percentile(concurrent, 0.99));

  // (3) Reads.
  const std::vector<std::string> endpoints = {"/api/v1/health",
                                              "/api/v1/jobs/1",
                                              "/api/v1/jobs/500",
                                              "/api/v1/jobs?status=queued&limit=100",
                                              "/api/v1/jobs/1/metrics",
                                              "/api/v1/jobs/1/series/run.csv",
                                              "/api/v1/compare?jobs=1,1",
                                              "/api/v1/openapi.json"};
  std::printf("%-40s %10s %9s %9s %8s\n", "GET", "req/s", "p50 ms", "p99 ms", "errors");
  for (const auto& path : endpoints) {
    std::vector<double> lat;
    std::atomic<long> errors{0};
    const auto t0 = Clock::now();
    const auto end = t0 + std::chrono::duration<double>(seconds);
    std::vector<std::thread> pool;
    for (int t = 0; t < clients; ++t)
      pool.emplace_back([&] {
        httplib::Client c("127.0.0.1", server.port);
        c.set_keep_alive(true);
        c.set_tcp_nodelay(true);
        std::vector<double> mine;
        while (Clock::now() < end) {
          const auto s = Clock::now();
          auto r = c.Get(path.c_str());
          mine.push_back(std::chrono::duration<double, std::milli>(Clock::now() - s).count());
          if (!r || r->status != 200) ++errors;
        }
        std::lock_guard lock(mutex);
        lat.insert(lat.end(), mine.begin(), mine.end());
      });
    for (auto& t : pool) t.join();
    const double el = std::chrono::duration<double>(Clock::now() - t0).count();
    std::printf("%-40s %10.0f %9.2f %9.2f %8ld\n", path.c_str(), lat.size() / el, percentile(lat, 0.5),
                percentile(lat, 0.99), errors.load());
  }
  stop(server);
  fs::remove_all(dir);
  return 0;
}
