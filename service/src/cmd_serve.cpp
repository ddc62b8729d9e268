// `runout serve`: the HTTP service until SIGINT/SIGTERM (running jobs go back to the queue; docs/service.md).
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "server.hpp"

namespace runout::cli {
namespace {

struct ServeArgs {
  service::ServeOptions opt;
  std::string token_file, db = "runout.db", runs = "runs", scene_dir, web_root, shipped = "on";
  bool verbose = false;
};

#ifndef RUNOUT_SCENARIOS_DIR
#define RUNOUT_SCENARIOS_DIR ""
#endif

// The shipped studies' folder: scenarios/ of the source tree this binary was built from, if it is still there.
std::filesystem::path shipped_root() {
  const std::filesystem::path p = RUNOUT_SCENARIOS_DIR;
  std::error_code ec;
  return !p.empty() && std::filesystem::is_directory(p, ec) ? p : std::filesystem::path();
}

// The build copies the page (web/, with uPlot) next to the binary: BUILD/webroot beside BUILD/runout.
std::filesystem::path default_web_root(const char* argv0) {
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) exe = std::filesystem::absolute(argv0, ec);
  return exe.parent_path() / "webroot";
}

// The bearer tokens: one per line of the file (each with its own work budget; surrounding whitespace and
// empty lines dropped), else env RUNOUT_TOKEN, else none (writes open). False (logged) if the file fails.
bool read_tokens(service::ServeOptions& opt, const std::string& token_file) {
  if (token_file.empty()) {
    if (const char* env = std::getenv("RUNOUT_TOKEN"); env && *env) opt.token = env;
    return true;
  }
  std::ifstream in(token_file, std::ios::binary);
  if (!in) {
    spdlog::error("serve: cannot read the token file {}", token_file);
    return false;
  }
  for (std::string line; std::getline(in, line);) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.erase(0, 1);
    if (line.empty()) continue;
    if (opt.token.empty()) opt.token = line;
    else opt.tokens.push_back(line);
  }
  if (opt.token.empty()) {
    spdlog::error("serve: the token file {} is empty", token_file);
    return false;
  }
  return true;
}

void print_listening(const service::ServeOptions& opt, int port) {
  // The token itself is never printed.
  std::printf("runout serve: listening on http://%s:%d/api/v1 (db %s, %d workers, writes %s)\n", opt.host.c_str(), port,
              opt.db.c_str(), opt.workers, opt.token.empty() ? "open" : "need the bearer token");
  if (std::filesystem::is_regular_file(opt.web_root / "index.html"))
    std::printf("runout serve: web page at http://%s:%d/ (from %s)\n", opt.host.c_str(), port, opt.web_root.c_str());
  else
    std::printf("runout serve: no web page (%s has no index.html; --web-root DIR)\n", opt.web_root.c_str());
  std::fflush(stdout);
}

int serve(service::ServeOptions opt, const std::string& token_file, bool verbose) {
  if (verbose) spdlog::set_level(spdlog::level::debug);
  if (!read_tokens(opt, token_file)) return 2;
  std::unique_ptr<service::Server> server;
  int port = 0;
  try {
    server = std::make_unique<service::Server>(opt);
    port = server->start();
  } catch (const std::exception& e) {
    spdlog::error("serve: {}", e.what());
    return 2;
  }
  stop_on_signals();
  std::signal(SIGPIPE, SIG_IGN);
  print_listening(opt, port);
  std::thread watcher([&] {
    while (!g_stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    server->stop();
  });
  const bool ok = server->serve();
  g_stop.store(true);
  watcher.join();
  server.reset();
  if (!ok) {
    spdlog::error("serve: listening on {}:{} failed", opt.host, port);
    return 1;
  }
  spdlog::info("serve: stopped");
  return 0;
}

// An option with its accepted range, its default shown in --help.
template <class T, class B>
void bounded(CLI::App* cmd, const char* name, T& value, const char* doc, B lo, B hi) {
  cmd->add_option(name, value, doc)->check(CLI::Range(lo, hi))->capture_default_str();
}

// The limits the server keeps to (request sizes and times, connections, work budgets).
void add_limits(CLI::App* cmd, service::ServeOptions& o) {
  bounded(cmd, "--max-body", o.max_body, "Largest request body in bytes", static_cast<size_t>(1024),
          static_cast<size_t>(1) << 30);
  bounded(cmd, "--particle-budget", o.particle_budget, "Most particles a job may have", static_cast<int64_t>(100),
          static_cast<int64_t>(200'000'000));
  bounded(cmd, "--header-timeout", o.header_timeout,
          "Seconds for a whole request head, however slowly it arrives (408 after)", 0.1, 3600.0);
  bounded(cmd, "--body-timeout", o.body_timeout, "Seconds for a whole request body (408 after)", 0.1, 3600.0);
  bounded(cmd, "--idle-timeout", o.idle_timeout, "Seconds a kept-alive connection waits for a request", 0.1, 3600.0);
  bounded(cmd, "--max-connections", o.max_connections, "Open connections in all (503 above)", 4, 100000);
  bounded(cmd, "--max-connections-per-client", o.max_connections_per_client,
          "Open connections of one client address (429 above)", 1, 100000);
  bounded(cmd, "--http-threads", o.http_threads, "Threads that run API requests (health has its own)", 2, 256);
  bounded(cmd, "--budget-token-cpu-s", o.budget_token_cpu_s,
          "Most predicted CPU-seconds queued or running per token (0: no limit; 429 above)", 0.0, 1e12);
  bounded(cmd, "--budget-total-cpu-s", o.budget_total_cpu_s,
          "Most predicted CPU-seconds queued or running in all (0: no limit; 429 above)", 0.0, 1e12);
}

}  // namespace

Action add_serve(CLI::App& app) {
  auto a = std::make_shared<ServeArgs>();
  auto& o = a->opt;
  auto* cmd = app.add_subcommand("serve", "Run the HTTP service: a job queue and the run store over a JSON API");
  cmd->footer("Example (then open http://127.0.0.1:8080/: the shipped studies are offered as base scenes):\n  runout serve --port 8080 --db runout.db --workers 1");
  cmd->add_option("--host", o.host, "Address to bind (loopback by default)")->capture_default_str();
  bounded(cmd, "--port", o.port, "Port (0: any free port, printed on stdout)", 0, 65535);
  cmd->add_option("--db", a->db, "Run store and job queue (SQLite)")->capture_default_str();
  bounded(cmd, "--workers", o.workers, "Jobs run at once (0: queue only)", 0, 64);
  cmd->add_option("--threads-per-job", o.threads_per_job, "OpenMP threads per job (0: the cores divided among the jobs running)")
      ->check(CLI::Range(0, 1024));
  bounded(cmd, "--checkpoint-every", o.checkpoint_interval,
          "Seconds of wall time between a running job's checkpoints; a restarted service resumes the job from "
          "its last one (0: a requeued job starts over)", 0.0, 1e6);
  cmd->add_option("--token-file", a->token_file, "File holding the bearer token that writes need, or several, one per line (else env RUNOUT_TOKEN)");
  add_limits(cmd, o);
  cmd->add_option("--runs", a->runs, "Job outputs go to RUNS/service/job-<id>")->capture_default_str();
  cmd->add_option("--scene-dir", a->scene_dir,
                  "Relative file names in submitted scenes (terrain.dem) resolve here, and must stay inside it "
                  "(default: the shipped scenarios folder, " RUNOUT_SCENARIOS_DIR ", or . without it)");
  cmd->add_option("--shipped-studies", a->shipped,
                  "on: when the scene dir is the shipped scenarios folder, store its studies' base scenes (flume, "
                  "catchments) in the background at start; off: do not")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_flag("--verbose,-v", a->verbose, "Log every request (method, path, status, time)");
  cmd->add_option("--web-root", a->web_root,
                  "The web page's files, served at / and /web/ (default: webroot/ next to this binary, where the "
                  "build puts it)");
  return [a](const char* argv0) {
    service::ServeOptions o = a->opt;
    o.db = a->db;
    o.runs_dir = a->runs;
    o.shipped_root = shipped_root();
    o.scene_dir = !a->scene_dir.empty() ? std::filesystem::path(a->scene_dir)
                  : !o.shipped_root.empty() ? o.shipped_root : std::filesystem::path(".");
    o.shipped_studies = a->shipped == "on";
    o.web_root = !a->web_root.empty() ? std::filesystem::path(a->web_root) : default_web_root(argv0);
    return serve(o, a->token_file, a->verbose);
  };
}

}  // namespace runout::cli
