// The `runout` command.
#include <csignal>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "mpi_sweep.hpp"
#include "progress.hpp"
#include "server.hpp"
#include "tradeoff_cli.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/schema.hpp"
#include <nlohmann/json.hpp>
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

int cmd_run(const std::string& scene_path, const std::string& out_dir, bool snapshots, int threads, bool quiet,
            const std::string& db_file) {
  runout::Scene scene;
  try {
    scene = runout::load_scene(scene_path);
  } catch (const runout::SceneError& e) {
    spdlog::error("scene refused: {}", e.what());
    return 2;
  }
  std::unique_ptr<runout::RunStore> store;
  if (!db_file.empty()) {
    try {
      store = std::make_unique<runout::RunStore>(db_file);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      return 2;
    }
  }
  std::filesystem::path out = out_dir.empty() ? std::filesystem::path("runs") / scene.name : std::filesystem::path(out_dir);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  runout::ProgressBar bar(scene.name);
  runout::RunOptions opt;
  opt.out_dir = out;
  opt.snapshots = snapshots;
  opt.threads = threads;
  opt.stop = &g_stop;
  if (!quiet) opt.on_progress = [&](const runout::RunProgress& p) { bar.update(p); };
  runout::RunSummary s;
  try {
    s = runout::run_scene(scene, opt);
  } catch (const std::exception& e) {
    bar.finish();
    spdlog::error("run could not start: {}", e.what());
    return 1;
  }
  bar.finish();
  if (store) {
    // The scene as written is the run's identity (fidelity "scene": no preset applied).
    runout::Fidelity as_written;
    as_written.name = "scene";
    const auto manifest = runout::make_manifest(read_text(scene_path), std::filesystem::path(scene_path).parent_path(),
                                                as_written);
    runout::RunStore::RunRecord r;
    r.manifest_hash = manifest.hash;
    r.manifest_json = manifest.json;
    r.scene = scene.name;
    r.fidelity = as_written.name;
    r.status = s.status;
    r.metrics_json = s.metrics_json;
    r.series_csv = runout::read_series(out);
    try {
      const int64_t id = store->put_run(r);
      spdlog::info("stored as run {} in {}", id, db_file);
    } catch (const std::exception& e) {
      spdlog::error("could not store the run: {}", e.what());
    }
  }
  if (s.status == "failed") {
    spdlog::error("run failed: {}", s.error);
    spdlog::info("partial metrics in {}", (out / "metrics.json").string());
    return 3;
  }
  spdlog::info("{} {}: {} steps, {:.4g} s simulated in {:.1f} s wall ({:.3g} particle-steps/s); outputs in {}",
               scene.name, s.status, s.steps, s.simulated_time, s.wall_seconds, s.particle_steps_per_second,
               out.string());
  return s.status == "completed" ? 0 : 130;
}

std::string fmt_value(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// A table of every stored metric of the runs against the baseline, with differences in per cent.
void print_comparison(const runout::Comparison& c, const std::string& filter, bool all) {
  std::vector<std::string> header{"metric", c.baseline + " (base)"};
  for (const auto& r : c.runs) header.push_back(r);
  std::vector<std::vector<std::string>> rows;
  for (const auto& row : c.rows) {
    if (!filter.empty() && row.metric.find(filter) == std::string::npos) continue;
    bool differs = false;
    for (const auto& v : row.values) differs = differs || v != row.baseline;
    if (!all && !differs) continue;  // the same in every run (settings, particle counts): not a difference
    std::vector<std::string> cells{row.metric, row.baseline ? fmt_value(*row.baseline) : "-"};
    for (size_t k = 0; k < row.values.size(); ++k) {
      std::string cell = row.values[k] ? fmt_value(*row.values[k]) : "-";
      if (row.percent[k]) {
        char buf[32];
        std::snprintf(buf, sizeof buf, " (%+.1f%%)", *row.percent[k]);
        cell += buf;
      }
      cells.push_back(cell);
    }
    rows.push_back(cells);
  }
  std::vector<size_t> width(header.size());
  for (size_t k = 0; k < header.size(); ++k) width[k] = header[k].size();
  for (const auto& r : rows)
    for (size_t k = 0; k < r.size(); ++k) width[k] = std::max(width[k], r[k].size());
  auto line = [&](const std::vector<std::string>& cells) {
    for (size_t k = 0; k < cells.size(); ++k) {
      std::printf(k == 0 ? "%-*s" : "  %*s", static_cast<int>(width[k]), cells[k].c_str());
    }
    std::printf("\n");
  };
  line(header);
  for (const auto& r : rows) line(r);
}

int cmd_compare(const std::string& db_file, const std::string& sweep, const std::string& baseline,
                const std::vector<int64_t>& ids, const std::string& filter, bool all) {
  try {
    runout::RunStore store(db_file);
    std::vector<int64_t> runs = ids;
    int64_t base = 0;
    if (runs.empty()) {
      if (sweep.empty()) {
        spdlog::error("compare: name a --sweep or give --runs");
        return 2;
      }
      // The latest stored run of each variant of the sweep, in variant order of first appearance.
      std::vector<std::string> order;
      std::map<std::string, int64_t> latest;
      for (const auto& r : store.list_runs(sweep)) {
        if (r.status != "completed") continue;
        if (!latest.count(r.variant)) order.push_back(r.variant);
        latest[r.variant] = r.id;
      }
      if (order.empty()) {
        spdlog::error("compare: no completed runs of sweep '{}' in {}", sweep, db_file);
        return 2;
      }
      std::sort(order.begin(), order.end());
      const std::string base_name = baseline.empty() ? order.front() : baseline;
      if (!latest.count(base_name)) {
        spdlog::error("compare: --baseline '{}' is not a completed variant of sweep '{}'", base_name, sweep);
        return 2;
      }
      base = latest[base_name];
      for (const auto& v : order)
        if (v != base_name) runs.push_back(latest[v]);
    } else {
      base = runs.front();
      if (!baseline.empty()) base = std::stoll(baseline);
      runs.erase(std::remove(runs.begin(), runs.end(), base), runs.end());
    }
    print_comparison(runout::compare_runs(store, runs, base), filter, all);
  } catch (const std::exception& e) {
    spdlog::error("compare: {}", e.what());
    return 2;
  }
  return 0;
}

int cmd_sweep(const std::string& sweep_path, const std::string& fidelity, double dp, int jobs, int threads,
              const std::string& db_file, const std::string& out_root, bool compare, double heartbeat_timeout) {
  // Under mpirun/srun the sweep's runs are spread over the ranks (mpi_sweep.hpp, docs/cluster.md); MPI is
  // initialised only then, so a plain `runout sweep` is unchanged and starts no MPI singleton.
#ifdef RUNOUT_HAVE_MPI
  std::unique_ptr<runout::cluster::MpiWorld> mpi;
  const runout::cluster::MpiSweepOptions mpi_opt{heartbeat_timeout, threads};
  if (runout::cluster::launched_by_mpi()) {
    mpi = std::make_unique<runout::cluster::MpiWorld>();
    if (mpi->rank() > 0) {  // a worker: runs what rank 0 hands out; never opens the store
      std::signal(SIGINT, on_signal);
      std::signal(SIGTERM, on_signal);
      return mpi->finish(runout::cluster::run_worker(*mpi, mpi_opt, &g_stop));
    }
  }
  // Rank 0 leaving before any run was handed out lets the workers go first.
  auto leave = [&](int code) {
    if (!mpi) return code;
    if (mpi->size() > 1) runout::cluster::release_workers(*mpi);
    return mpi->finish(code);
  };
#else
  if (runout::cluster::launcher_world_size() > 1) {
    spdlog::error("sweep: this runout was built without MPI, so `mpirun -np {}` would run the whole sweep {} times; "
                  "run it without mpirun, or build with Open MPI (libopenmpi-dev, docs/cluster.md)",
                  runout::cluster::launcher_world_size(), runout::cluster::launcher_world_size());
    return 2;
  }
  (void)heartbeat_timeout;
  auto leave = [](int code) { return code; };
#endif
  runout::Sweep sweep;
  runout::SweepOptions opt;
  try {
    if (!fidelity.empty() || dp > 0) {
      opt.fidelity_override = true;
      opt.fidelity.name = fidelity.empty() ? "custom" : fidelity;
      if (dp > 0) opt.fidelity.dp = dp;
    }
    sweep = runout::load_sweep(sweep_path);
    if (opt.fidelity_override)  // validate the variants at the fidelity that will run
      for (const auto& v : sweep.variants)
        (void)runout::parse_scene(runout::resolve_variant(sweep.base_json, v, opt.fidelity), sweep.base_path.parent_path());
  } catch (const runout::SceneError& e) {
    spdlog::error("sweep refused: {}", e.what());
    return leave(2);
  }
  std::unique_ptr<runout::RunStore> store;
  try {
    store = std::make_unique<runout::RunStore>(db_file);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return leave(2);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  opt.out_root = out_root;
  opt.jobs = jobs;
  opt.threads = threads;
  opt.stop = &g_stop;
  const auto t0 = std::chrono::steady_clock::now();
  size_t done = 0;
  double run_wall = 0;
  size_t ran = 0;
  std::map<size_t, runout::RunProgress> live;
  opt.on_event = [&](const runout::SweepEvent& e) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (e.kind == runout::SweepEvent::finished) {
      ++done;
      live.erase(e.index);
      if (!e.result.reused) {
        run_wall += e.result.wall_seconds;
        ++ran;
      }
      const size_t left = e.total - done;
      const double per_run = ran ? run_wall / ran : 0;
      const double eta = per_run * left / std::max(1, opt.jobs);
      std::fprintf(stderr, "[%zu/%zu] %s %s%s (run %lld) %.1f s%s%s   sweep %.0f s elapsed, ETA %.0f s\n", done,
                   e.total, e.variant.c_str(), e.result.status.c_str(), e.result.reused ? ", already stored" : "",
                   static_cast<long long>(e.result.run_id), e.result.wall_seconds, e.result.error.empty() ? "" : ": ",
                   e.result.error.c_str(), elapsed, eta);
    } else if (e.kind == runout::SweepEvent::started) {
      live[e.index] = {};
    }
  };
  runout::SweepResult result;
#ifdef RUNOUT_HAVE_MPI
  if (mpi && mpi->size() > 1) {
    opt.jobs = mpi->size() - 1;  // for the ETA: one run at a time per worker rank
    result = runout::cluster::coordinate_sweep(*mpi, *store, sweep, opt, mpi_opt);
  } else {
    result = runout::run_sweep(*store, sweep, opt);  // -np 1: rank 0 runs the sweep itself
  }
#else
  result = runout::run_sweep(*store, sweep, opt);
#endif
  size_t completed = 0;
  for (const auto& r : result.runs) completed += r.status == "completed";
  spdlog::info("sweep {}: {} of {} runs completed; stored in {}", sweep.name, completed, result.runs.size(), db_file);
  store.reset();  // closed (committed) before MPI ends: a lost worker makes rank 0 leave without MPI_Finalize
  int code = completed == result.runs.size() ? 0 : 3;
  if (g_stop.load()) {
    spdlog::warn("stopped: finished runs are stored; run the same command again to resume");
    code = 130;
  } else if (compare && completed > 0) {
    std::printf("\n");
    cmd_compare(db_file, sweep.name, "", {}, "", false);
  }
#ifdef RUNOUT_HAVE_MPI
  if (mpi) return mpi->finish(code);
#endif
  return code;
}

// The build copies the page (web/, with uPlot) next to the binary: BUILD/webroot beside BUILD/runout.
std::filesystem::path default_web_root(const char* argv0) {
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) exe = std::filesystem::absolute(argv0, ec);
  return exe.parent_path() / "webroot";
}

// `runout serve`: the HTTP service until SIGINT/SIGTERM (running jobs go back to the queue).
int cmd_serve(runout::service::ServeOptions opt, const std::string& token_file, bool verbose) {
  if (verbose) spdlog::set_level(spdlog::level::debug);
  if (!token_file.empty()) {
    std::ifstream in(token_file, std::ios::binary);
    if (!in) {
      spdlog::error("serve: cannot read the token file {}", token_file);
      return 2;
    }
    // One token per line (each with its own work budget); surrounding whitespace and empty lines dropped.
    for (std::string line; std::getline(in, line);) {
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.erase(0, 1);
      if (line.empty()) continue;
      if (opt.token.empty()) opt.token = line;
      else opt.tokens.push_back(line);
    }
    if (opt.token.empty()) {
      spdlog::error("serve: the token file {} is empty", token_file);
      return 2;
    }
  } else if (const char* env = std::getenv("RUNOUT_TOKEN"); env && *env) {
    opt.token = env;
  }
  std::unique_ptr<runout::service::Server> server;
  int port = 0;
  try {
    server = std::make_unique<runout::service::Server>(opt);
    port = server->start();
  } catch (const std::exception& e) {
    spdlog::error("serve: {}", e.what());
    return 2;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
  // The token itself is never printed.
  std::printf("runout serve: listening on http://%s:%d/api/v1 (db %s, %d workers, writes %s)\n", opt.host.c_str(), port,
              opt.db.c_str(), opt.workers, opt.token.empty() ? "open" : "need the bearer token");
  if (std::filesystem::is_regular_file(opt.web_root / "index.html"))
    std::printf("runout serve: web page at http://%s:%d/ (from %s)\n", opt.host.c_str(), port, opt.web_root.c_str());
  else
    std::printf("runout serve: no web page (%s has no index.html; --web-root DIR)\n", opt.web_root.c_str());
  std::fflush(stdout);
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

// `runout serve`'s options (docs/service.md).
struct ServeArgs {
  runout::service::ServeOptions opt;
  std::string token_file, db = "runout.db", runs = "runs", scene_dir = ".", web_root;
  bool verbose = false;
};

CLI::App* add_serve_command(CLI::App& app, ServeArgs& a) {
  auto& serve_opt = a.opt;
  auto& token_file = a.token_file;
  auto& serve_db = a.db;
  auto& serve_runs = a.runs;
  auto& scene_dir = a.scene_dir;
  auto& verbose = a.verbose;
  auto* serve = app.add_subcommand("serve", "Run the HTTP service: a job queue and the run store over a JSON API");
  serve->add_option("--host", serve_opt.host, "Address to bind (loopback by default)")->capture_default_str();
  serve->add_option("--port", serve_opt.port, "Port (0: any free port, printed on stdout)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  serve->add_option("--db", serve_db, "Run store and job queue (SQLite)")->capture_default_str();
  serve->add_option("--workers", serve_opt.workers, "Jobs run at once (0: queue only)")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  serve->add_option("--threads-per-job", serve_opt.threads_per_job, "OpenMP threads per job (0: cores / workers)")
      ->check(CLI::Range(0, 1024));
  serve->add_option("--token-file", token_file, "File holding the bearer token that writes need, or several, one per line (else env RUNOUT_TOKEN)");
  serve->add_option("--max-body", serve_opt.max_body, "Largest request body in bytes")
      ->check(CLI::Range(static_cast<size_t>(1024), static_cast<size_t>(1) << 30))
      ->capture_default_str();
  serve->add_option("--particle-budget", serve_opt.particle_budget, "Most particles a job may have")
      ->check(CLI::Range(static_cast<int64_t>(100), static_cast<int64_t>(200'000'000)))
      ->capture_default_str();
  serve->add_option("--header-timeout", serve_opt.header_timeout,
                    "Seconds for a whole request head, however slowly it arrives (408 after)")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  serve->add_option("--body-timeout", serve_opt.body_timeout, "Seconds for a whole request body (408 after)")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  serve->add_option("--idle-timeout", serve_opt.idle_timeout, "Seconds a kept-alive connection waits for a request")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  serve->add_option("--max-connections", serve_opt.max_connections, "Open connections in all (503 above)")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  serve->add_option("--max-connections-per-client", serve_opt.max_connections_per_client,
                    "Open connections of one client address (429 above)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  serve->add_option("--http-threads", serve_opt.http_threads, "Threads that run API requests (health has its own)")
      ->check(CLI::Range(2, 256))
      ->capture_default_str();
  serve->add_option("--budget-token-cpu-s", serve_opt.budget_token_cpu_s,
                    "Most predicted CPU-seconds queued or running per token (0: no limit; 429 above)")
      ->check(CLI::Range(0.0, 1e12))
      ->capture_default_str();
  serve->add_option("--budget-total-cpu-s", serve_opt.budget_total_cpu_s,
                    "Most predicted CPU-seconds queued or running in all (0: no limit; 429 above)")
      ->check(CLI::Range(0.0, 1e12))
      ->capture_default_str();
  serve->add_option("--runs", serve_runs, "Job outputs go to RUNS/service/job-<id>")->capture_default_str();
  serve->add_option("--scene-dir", scene_dir, "Relative file names in submitted scenes (terrain.dem) resolve here")
      ->capture_default_str();
  serve->add_flag("--verbose,-v", verbose, "Log every request (method, path, status, time)");
  serve->add_option("--web-root", a.web_root,
                    "The web page's files, served at / and /web/ (default: webroot/ next to this binary, where the "
                    "build puts it)");
  return serve;
}

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_default_logger(spdlog::stderr_color_mt("runout"));  // messages on stderr, like the progress bar
  CLI::App app{"Runout: debris-flow hazard-mitigation design studies with SPH"};
  app.set_version_flag("--version", std::string(RUNOUT_VERSION));
  app.require_subcommand(1);

  std::string scene_path, out_dir;
  bool snapshots = false, quiet = false;
  int threads = 0;
  auto* run = app.add_subcommand("run", "Run one scene and write metrics.json, series/ and snapshots/");
  run->add_option("scene", scene_path, "Scene file (JSON)")->required();  // unreadable: refused by load_scene (2)
  run->add_option("--out,-o", out_dir, "Output directory (default runs/<scene name>)");
  run->add_flag("--snapshots", snapshots, "Write particle snapshots (.vtp) under OUT/snapshots/");
  run->add_option("--threads,-j", threads, "OpenMP threads (default: all cores)")->check(CLI::Range(0, 1024));
  run->add_flag("--quiet,-q", quiet, "No progress bar");
  std::string db_file = "runout.db";
  bool no_db = false;
  run->add_option("--db", db_file, "Run store (SQLite) the run is put in")->capture_default_str();
  run->add_flag("--no-db", no_db, "Do not store the run");

  std::string sweep_path, fidelity, sweep_out = "runs";
  double dp = 0;
  int jobs = 1;
  bool no_compare = false;
  auto* sweep = app.add_subcommand("sweep", "Run every layout of a sweep, store each run, print the comparison");
  sweep->add_option("sweep", sweep_path, "Sweep file (JSON)")->required();
  sweep->add_option("--fidelity", fidelity, "draft | standard | fine (default: the sweep's)")
      ->check(CLI::IsMember({"draft", "standard", "fine"}));
  sweep->add_option("--dp", dp, "Explicit particle spacing [m] instead of a preset")->check(CLI::Range(1e-4, 1e3));
  sweep->add_option("--jobs", jobs, "Runs at once (each gets the cores divided among the jobs)")->check(CLI::Range(1, 64));
  sweep->add_option("--threads,-j", threads, "OpenMP threads per run (default: cores / jobs)")->check(CLI::Range(0, 1024));
  sweep->add_option("--db", db_file, "Run store (SQLite)")->capture_default_str();
  sweep->add_option("--out,-o", sweep_out, "Outputs go to OUT/<sweep>/<variant>")->capture_default_str();
  sweep->add_flag("--no-compare", no_compare, "Do not print the comparison at the end");
  double heartbeat_timeout = 60;
  sweep->add_option("--heartbeat-timeout", heartbeat_timeout,
                    "Under mpirun/srun: seconds without a word from a worker rank before its run goes to another "
                    "(docs/cluster.md)")
      ->check(CLI::Range(1.0, 86400.0))
      ->capture_default_str();

  std::string compare_sweep, baseline, filter;
  std::vector<int64_t> compare_ids;
  bool all_rows = false;
  auto* compare = app.add_subcommand("compare", "Print every stored metric of runs against a baseline, in per cent");
  compare->add_option("--sweep", compare_sweep, "Compare the latest completed run of each variant of this sweep");
  compare->add_option("--baseline", baseline, "Baseline variant (default: the first by name, C0 / G0) or run id");
  compare->add_option("--runs", compare_ids, "Run ids instead of a sweep (the first is the baseline)");
  compare->add_option("--filter", filter, "Only metrics whose name contains this");
  compare->add_flag("--all", all_rows, "Also rows that are the same in every run");
  compare->add_option("--db", db_file, "Run store (SQLite)")->capture_default_str();

  ServeArgs serve_args;
  auto* serve = add_serve_command(app, serve_args);

  runout::service::TradeoffCommand tradeoff_cmd;
  auto* tradeoff = app.add_subcommand(
      "tradeoff", "Run a scene at a ladder of resolutions: cost and deviation of every metric from the finest");
  tradeoff->add_option("file", tradeoff_cmd.file, "Scene or sweep file (JSON)")->required();
  tradeoff->add_option("--variant", tradeoff_cmd.variant, "The sweep's layout to run (default: its first)");
  tradeoff->add_option("--levels", tradeoff_cmd.levels, "draft, standard, fine or dp values [m] (default: all three presets)")
      ->delimiter(',');
  tradeoff->add_option("--option", tradeoff_cmd.options,
                       "A numerics choice run at one rung, PATH=VALUE (numerics.kernel=cubic); repeatable");
  tradeoff->add_option("--option-level", tradeoff_cmd.option_level, "The rung the options run at (default: the coarsest)");
  tradeoff->add_option("--threads,-j", tradeoff_cmd.threads, "OpenMP threads (default: all cores)")->check(CLI::Range(0, 1024));
  tradeoff->add_option("--out,-o", tradeoff_cmd.out_dir, "levels.csv, metrics.csv, tradeoff.svg and each level's outputs "
                                                         "(default runs/tradeoff/<name>)");
  tradeoff->add_option("--db", tradeoff_cmd.db, "Run store (SQLite); stored levels are reused")->capture_default_str();
  tradeoff->add_flag("--predict-only", tradeoff_cmd.predict_only,
                     "Build each level and print its particles and the cost model's steps and time; run nothing");

  runout::service::CalibrateCommand calibrate_cmd;
  auto* calibrate = app.add_subcommand("calibrate", "Fit the cost model to the completed runs of a store; print "
                                                    "predicted against measured run times");
  calibrate->add_option("--db", calibrate_cmd.dbs, "Run store (SQLite); repeat to fit the runs of several")
      ->capture_default_str();
  calibrate->add_option("--sweep", calibrate_cmd.sweep_prefix, "Only runs whose sweep name starts with this");
  calibrate->add_option("--json", calibrate_cmd.json_out, "Write the fitted coefficients to this file");

  auto* schema = app.add_subcommand("schema", "Print the JSON Schema of a scene, generated from the models' "
                                              "descriptors (example: runout schema > scene.schema.json)");

  CLI11_PARSE(app, argc, argv);
  if (schema->parsed()) {
    std::cout << runout::scene_schema().dump(2) << "\n";
    return 0;
  }
  if (tradeoff->parsed()) {
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    return runout::service::run_tradeoff_command(tradeoff_cmd, &g_stop);
  }
  if (calibrate->parsed()) return runout::service::run_calibrate_command(calibrate_cmd);
  if (serve->parsed()) {
    auto& o = serve_args.opt;
    o.db = serve_args.db;
    o.runs_dir = serve_args.runs;
    o.scene_dir = serve_args.scene_dir;
    o.web_root = !serve_args.web_root.empty() ? std::filesystem::path(serve_args.web_root) : default_web_root(argv[0]);
    return cmd_serve(o, serve_args.token_file, serve_args.verbose);
  }
  if (run->parsed()) return cmd_run(scene_path, out_dir, snapshots, threads, quiet, no_db ? "" : db_file);
  if (sweep->parsed()) return cmd_sweep(sweep_path, fidelity, dp, jobs, threads, db_file, sweep_out, !no_compare, heartbeat_timeout);
  if (compare->parsed()) return cmd_compare(db_file, compare_sweep, baseline, compare_ids, filter, all_rows);
  return 0;
}
