// Service benchmark (not a test): requests per second on the read endpoints and the latency of submissions,
// against the real `runout serve` started as a child process on a loopback port with a scratch database.
//
//   build/bench/bench_service [--runout build/runout] [--clients 4] [--seconds 3] [--jobs 1000]
//                             [--phase all|reads|hostile|estimate] [--budget-total-cpu-s X]
//
// Phases: (1) one tiny job is run to completion (so /metrics, /series and /compare have a stored run);
// (2) the server is restarted with --workers 0 and `--jobs` tiny jobs are submitted, first one at a time
// (latency of a single client), then from 16 clients at once (throughput); (3) each read endpoint is hammered
// by `--clients` keep-alive clients for `--seconds`, on a queue of that many jobs; (4, "hostile") a fresh
// server runs a long job on one worker while 100 clients, each from its own loopback address (127.0.1.x),
// submit 1000 tiny jobs in all, 20 slow clients from one address (127.0.2.1) trickle a header byte a second
// (reconnecting when cut), and /health is polled every 20 ms: accepted / refused / errors and /health's
// latency; (5, "estimate") POST /estimate of the two catchment scenes on a fresh server: the server's CPU for
// the first estimate, for each of the next ones and for a refusal in the scene's last-read section, then
// answers/s from 8 clients with /health's p99 meanwhile. docs/performance.md.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
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
#include <fstream>
#include <map>
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
  std::vector<std::string> args = {runout, "serve", "--port", "0", "--db", (dir / "bench.db").string(), "--runs", (dir / "runs").string(),
                                   "--shipped-studies", "off"};  // no background scene checks in the timings
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

// A keep-alive HTTP/1.1 client on a raw socket bound to a chosen loopback address (httplib's client cannot
// pick its source address, and the server counts connections per address).
class RawClient {
 public:
  RawClient(int port, std::string from) : port_(port), from_(std::move(from)) {}
  ~RawClient() { drop(); }
  // The status of one request (0: no answer), reconnecting once if the kept-alive connection was closed.
  int request(const std::string& method, const std::string& path, const std::string& body,
              const std::vector<std::string>& headers) {
    std::string req = method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n";
    for (const auto& h : headers) req += h + "\r\n";
    req += "Content-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
    for (int attempt = 0; attempt < 2; ++attempt) {
      if (fd_ < 0 && !connect_now()) return 0;
      if (!send_all(req)) {
        drop();
        continue;
      }
      const int status = read_response();
      if (status > 0) return status;
      drop();
    }
    return 0;
  }

 private:
  bool connect_now() {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from_.c_str(), &local.sin_addr);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port_));
    ::inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    timeval tv{30, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0 ||
        ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      drop();
      return false;
    }
    return true;
  }
  void drop() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    buf_.clear();
  }
  bool send_all(const std::string& s) {
    for (size_t off = 0; off < s.size();) {
      const ssize_t n = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (n <= 0) return false;
      off += static_cast<size_t>(n);
    }
    return true;
  }
  int read_response() {
    for (;;) {
      const size_t h = buf_.find("\r\n\r\n");
      if (h != std::string::npos) {
        const std::string head = buf_.substr(0, h);
        size_t len = 0;
        const size_t cl = head.find("Content-Length: ");
        if (cl != std::string::npos) len = std::stoul(head.substr(cl + 16));
        if (buf_.size() >= h + 4 + len) {
          const int status = head.size() > 12 ? std::atoi(head.c_str() + 9) : 0;
          const bool close = head.find("Connection: close") != std::string::npos;
          buf_.erase(0, h + 4 + len);
          if (close) drop();
          return status;
        }
      }
      char b[65536];
      const ssize_t n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) return 0;
      buf_.append(b, static_cast<size_t>(n));
    }
  }
  int port_;
  std::string from_;
  int fd_ = -1;
  std::string buf_;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
}

// The server's CPU time so far [s] (user + system, all threads), from /proc.
double cpu_seconds(pid_t pid) {
  std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (!f) return 0;
  char buf[2048];
  const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  const char* p = std::strrchr(buf, ')');  // the command name may hold spaces
  unsigned long utime = 0, stime = 0;
  if (!p || std::sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &utime, &stime) != 2) return 0;
  return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// A shipped catchment scene as a request body at draft, its DEM named relative to the scenarios folder (the
// server's --scene-dir).
json catchment_request(const std::string& file) {
  std::ifstream in(fs::path(RUNOUT_SOURCE_DIR) / "scenarios/catchment" / file);
  json scene = json::parse(in);
  std::string dem = scene["terrain"]["dem"];
  scene["terrain"]["dem"] = dem.substr(dem.find("dem/"));
  return {{"scene", scene}, {"fidelity", "draft"}};
}

}  // namespace

// Phase 5: what an estimate and a refusal cost the server, and what 8 estimating clients get.
void estimate_phase(const std::string& runout, const fs::path& dir, double seconds) {
  std::printf("\nPOST /api/v1/estimate (server CPU per request; a refusal: numerics.cfl out of range)\n");
  for (const char* file : {"jacksboro_g.json", "alr.json"}) {
    fs::remove_all(dir / "estimate");
    fs::create_directories(dir / "estimate");
    Child server = start(runout, dir / "estimate", {"--workers", "0", "--scene-dir", RUNOUT_SOURCE_DIR "/scenarios"});
    httplib::Client c("127.0.0.1", server.port);
    c.set_read_timeout(120);
    const json body = catchment_request(file);
    json bad = body;
    bad["scene"]["numerics"]["cfl"] = 7;
    auto timed = [&](const json& b, int n, int want) {
      const double t0 = cpu_seconds(server.pid);
      for (int k = 0; k < n; ++k) {
        auto r = c.Post("/api/v1/estimate", b.dump(), "application/json");
        if (!r || r->status != want) std::fprintf(stderr, "estimate: status %d\n", r ? r->status : -1);
      }
      return (cpu_seconds(server.pid) - t0) / n * 1e3;
    };
    const double first = timed(body, 1, 200), next = timed(body, 20, 200), refusal = timed(bad, 20, 422);
    std::atomic<long> answers{0};
    std::atomic<bool> done{false};
    std::vector<double> health;
    std::thread poll([&] {
      httplib::Client h("127.0.0.1", server.port);
      while (!done.load()) {
        const auto s = Clock::now();
        auto r = h.Get("/api/v1/health");
        if (r) health.push_back(std::chrono::duration<double, std::milli>(Clock::now() - s).count());
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
    const auto t0 = Clock::now();
    std::vector<std::thread> pool;
    for (int t = 0; t < 8; ++t)
      pool.emplace_back([&] {
        httplib::Client e("127.0.0.1", server.port);
        e.set_read_timeout(120);
        while (Clock::now() - t0 < std::chrono::duration<double>(seconds))
          if (auto r = e.Post("/api/v1/estimate", body.dump(), "application/json"); r && r->status == 200) ++answers;
      });
    for (auto& t : pool) t.join();
    const double el = std::chrono::duration<double>(Clock::now() - t0).count();
    done = true;
    poll.join();
    std::printf("  %-17s first %7.1f ms, next %7.1f ms, refusal %7.1f ms; 8 clients %6.1f answers/s, /health p99 %.1f ms\n",
                file, first, next, refusal, answers.load() / el, percentile(health, 0.99));
    stop(server);
  }
}

// Phase 4: submissions from 100 addresses, slow clients and a running job at once; /health's latency.
void hostile_phase(const std::string& runout, const fs::path& dir, int jobs, const std::string& budget) {
  fs::remove_all(dir / "hostile");
  fs::create_directories(dir / "hostile");
  std::vector<std::string> args = {"--workers", "1", "--threads-per-job", "1"};
  if (!budget.empty()) args.insert(args.end(), {"--budget-total-cpu-s", budget});
  Child server = start(runout, dir / "hostile", args);
  httplib::Client c("127.0.0.1", server.port);
  // The long job: 60 s simulated of the tiny scene, running on the one worker throughout.
  json longjob = tiny_scene("bench-long");
  longjob["duration"] = 60.0;
  auto r = c.Post("/api/v1/jobs", json{{"scene", longjob}}.dump(), "application/json");
  if (!r || r->status != 201) std::exit(1);
  for (;;) {
    auto j = c.Get("/api/v1/jobs/1");
    if (j && json::parse(j->body).value("status", "") == "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::atomic<bool> done{false};
  std::atomic<long> slow_cut{0};
  std::vector<std::thread> slow;
  for (int k = 0; k < 20; ++k)
    slow.emplace_back([&] {  // one header byte a second; reconnects when the server cuts it
      const std::string head = "GET /api/v1/health HTTP/1.1\r\nX-Pad: " + std::string(4096, 'a');
      while (!done.load()) {
        const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_in local{}, addr{};
        local.sin_family = addr.sin_family = AF_INET;
        ::inet_pton(AF_INET, "127.0.2.1", &local.sin_addr);
        ::inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
        addr.sin_port = htons(static_cast<uint16_t>(server.port));
        if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) == 0 &&
            ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0)
          for (size_t i = 0; i < head.size() && !done.load(); ++i) {
            if (::send(fd, head.data() + i, 1, MSG_NOSIGNAL) != 1) break;
            pollfd p{fd, POLLIN, 0};
            if (::poll(&p, 1, 1000) > 0) break;  // an answer (408) or EOF: cut
          }
        if (!done.load()) ++slow_cut;
        ::close(fd);
      }
    });
  std::this_thread::sleep_for(std::chrono::seconds(2));  // the slow clients hold their connections
  std::vector<double> health;
  std::mutex mutex;
  std::atomic<long> health_bad{0};
  std::thread poller([&] {
    httplib::Client h("127.0.0.1", server.port);
    h.set_keep_alive(true);
    h.set_tcp_nodelay(true);
    h.set_read_timeout(30);
    while (!done.load()) {
      const auto t0 = Clock::now();
      auto res = h.Get("/api/v1/health");
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      if (res && res->status == 200) {
        std::lock_guard lock(mutex);
        health.push_back(ms);
      } else {
        ++health_bad;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  std::map<int, long> statuses;
  std::atomic<int> next{0};
  const auto t0 = Clock::now();
  std::vector<std::thread> pool;
  for (int t = 0; t < 100; ++t)
    pool.emplace_back([&, t] {
      RawClient rc(server.port, "127.0.1." + std::to_string(t + 1));
      std::map<int, long> mine;
      for (int i; (i = next++) < jobs;) {
        const std::string body = json{{"scene", tiny_scene("hostile-" + std::to_string(i))}}.dump();
        mine[rc.request("POST", "/api/v1/jobs", body, {"Idempotency-Key: hostile-" + std::to_string(i)})]++;
      }
      std::lock_guard lock(mutex);
      for (auto [s, n] : mine) statuses[s] += n;
    });
  for (auto& t : pool) t.join();
  const double burst_s = std::chrono::duration<double>(Clock::now() - t0).count();
  // Past the 10 s header deadline, so that every slow client has been cut at least once.
  while (Clock::now() - t0 < std::chrono::seconds(13)) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  done = true;
  poller.join();
  for (auto& t : slow) t.join();
  auto h = c.Get("/api/v1/health");
  long accepted = 0, refused = 0, errors = 0;
  for (auto [s, n] : statuses) (s == 201 ? accepted : (s >= 400 && s < 500) ? refused : errors) += n;
  std::printf("\nHostile load: %d submissions from 100 client addresses in %.2f s, one job running, 20 slow clients "
              "(one header byte/s)\n", jobs, burst_s);
  std::printf("  accepted %ld, refused %ld, errors %ld;", accepted, refused, errors);
  for (auto [s, n] : statuses) std::printf(" [%d: %ld]", s, n);
  std::printf("\n  /health during the burst and 13 s in all: %zu answers, %ld failed; p50 %.2f ms, p99 %.2f ms, max %.2f ms\n",
              health.size(), health_bad.load(), percentile(health, 0.5), percentile(health, 0.99),
              percentile(health, 1.0));
  std::printf("  slow connections cut and reopened: %ld\n", slow_cut.load());
  if (h && h->status == 200) {
    const json j = json::parse(h->body);
    std::printf("  health afterwards: backlog %s, connections %s\n", j.at("backlog").dump().c_str(),
                j.at("connections").dump().c_str());
  }
  stop(server);
}

int main(int argc, char** argv) {
  std::string runout = RUNOUT_BINARY_DIR "/runout";
  int clients = 4, jobs = 1000;
  double seconds = 3;
  std::string phase = "all", budget;
  for (int k = 1; k + 1 < argc; k += 2) {
    if (!std::strcmp(argv[k], "--runout")) runout = argv[k + 1];
    else if (!std::strcmp(argv[k], "--clients")) clients = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--seconds")) seconds = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--jobs")) jobs = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--phase")) phase = argv[k + 1];
    else if (!std::strcmp(argv[k], "--budget-total-cpu-s")) budget = argv[k + 1];
  }
  const fs::path dir = fs::temp_directory_path() / ("runout_bench_service_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  if (phase == "hostile" || phase == "estimate") {
    if (phase == "hostile") hostile_phase(runout, dir, jobs, budget);
    else estimate_phase(runout, dir, seconds);
    fs::remove_all(dir);
    return 0;
  }

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
  if (phase == "all") {
    hostile_phase(runout, dir, jobs, budget);
    estimate_phase(runout, dir, seconds);
  }
  fs::remove_all(dir);
  return 0;
}
