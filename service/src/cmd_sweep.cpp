// `runout sweep`: every layout of a sweep run and stored (resumable), then the comparison. Under mpirun/srun
// the runs are spread over the ranks (mpi_sweep.hpp, docs/cluster.md).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "mpi_sweep.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout::cli {
namespace {

struct SweepArgs {
  std::string path, db = "runout.db", out = "runs";
  FidelityArgs fidelity;
  double heartbeat_timeout = 60;
  int jobs = 1, threads = 0;
  double checkpoint_every = 0;
  bool no_compare = false;
};

// Where the runs go: this process, or rank 0 handing them to worker ranks. MPI is initialised only under
// mpirun/srun, so a plain `runout sweep` is unchanged and starts no MPI singleton.
class Ranks {
 public:
  // A worker rank's whole life, or the refusal of mpirun by a build without MPI: the exit code. Otherwise
  // nothing: this process runs or coordinates the sweep.
  std::optional<int> start(const SweepArgs& a) {
#ifdef RUNOUT_HAVE_MPI
    mpi_opt_ = {a.heartbeat_timeout, a.threads};
    if (!cluster::launched_by_mpi()) return std::nullopt;
    mpi_ = std::make_unique<cluster::MpiWorld>();
    if (mpi_->rank() == 0) return std::nullopt;
    stop_on_signals();  // a worker: runs what rank 0 hands out; never opens the store
    return mpi_->finish(cluster::run_worker(*mpi_, mpi_opt_, &g_stop));
#else
    if (cluster::launcher_world_size() <= 1) return std::nullopt;
    spdlog::error("sweep: this runout was built without MPI, so `mpirun -np {}` would run the whole sweep {} times; "
                  "run it without mpirun, or build with Open MPI (libopenmpi-dev, docs/cluster.md)",
                  cluster::launcher_world_size(), cluster::launcher_world_size());
    return 2;
#endif
  }
  // Rank 0 leaving before any run was handed out lets the workers go first.
  int leave(int code) {
#ifdef RUNOUT_HAVE_MPI
    if (mpi_ && mpi_->size() > 1) cluster::release_workers(*mpi_);
#endif
    return finish(code);
  }
  // The store must be closed (committed) by now: a lost worker makes rank 0 leave without MPI_Finalize.
  int finish(int code) {
#ifdef RUNOUT_HAVE_MPI
    if (mpi_) return mpi_->finish(code);
#endif
    return code;
  }
  SweepResult run(RunStore& store, const Sweep& sweep, SweepOptions& opt) {
#ifdef RUNOUT_HAVE_MPI
    if (mpi_ && mpi_->size() > 1) {
      opt.jobs = mpi_->size() - 1;  // for the ETA: one run at a time per worker rank
      return cluster::coordinate_sweep(*mpi_, store, sweep, opt, mpi_opt_);
    }
#endif
    return run_sweep(store, sweep, opt);  // also -np 1: rank 0 runs the sweep itself
  }

 private:
#ifdef RUNOUT_HAVE_MPI
  std::unique_ptr<cluster::MpiWorld> mpi_;
  cluster::MpiSweepOptions mpi_opt_;
#endif
};

// The sweep file, its variants checked at the fidelity that will run; false (logged) if refused.
bool load(const SweepArgs& a, Sweep& sweep, SweepOptions& opt) {
  try {
    if (const auto f = a.fidelity.chosen()) {
      opt.fidelity_override = true;
      opt.fidelity = *f;
    }
    sweep = load_sweep(a.path);
    if (opt.fidelity_override) {
      const nlohmann::json base = parse_scene_document(sweep.base_json);
      for (const auto& v : sweep.variants)  // checked as the service checks a job: counted, not built
        (void)estimate_scene(read_scene(resolve_variant(base, v, opt.fidelity), sweep.base_path.parent_path()));
    }
  } catch (const SceneError& e) {
    spdlog::error("sweep refused: {}", e.what());
    return false;
  }
  return true;
}

// A line on stderr as each run ends: its status and time, the sweep's elapsed time and ETA; and, for a run
// still going, a line every minute of wall time: where its clock stands and when it should end at its pace so
// far (a long run would otherwise say nothing for hours).
class ProgressLines {
 public:
  explicit ProgressLines(const SweepOptions& opt) : opt_(opt) {}
  void operator()(const SweepEvent& e) {
    if (e.kind == SweepEvent::progress) return running(e);
    if (e.kind != SweepEvent::finished) return;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    ++done_;
    if (!e.result.reused) {
      run_wall_ += e.result.wall_seconds;
      ++ran_;
    }
    const size_t left = e.total - done_;
    const double per_run = ran_ ? run_wall_ / ran_ : 0;
    const double eta = per_run * left / std::max(1, opt_.jobs);  // opt_.jobs as it is when the runs go
    std::fprintf(stderr, "[%zu/%zu] %s %s%s (run %lld) %.1f s%s%s   sweep %.0f s elapsed, ETA %.0f s\n", done_,
                 e.total, e.variant.c_str(), e.result.status.c_str(), e.result.reused ? ", already stored" : "",
                 static_cast<long long>(e.result.run_id), e.result.wall_seconds, e.result.error.empty() ? "" : ": ",
                 e.result.error.c_str(), elapsed, eta);
  }

 private:
  void running(const SweepEvent& e) {
    const RunProgress& p = e.progress_info;
    if (e.index >= last_line_.size()) last_line_.resize(e.index + 1, 0.0);
    if (p.wall_seconds < last_line_[e.index] + 60 || p.time <= 0) return;
    last_line_[e.index] = p.wall_seconds;
    const double left = p.wall_seconds * std::max(0.0, static_cast<double>(p.duration - p.time)) / p.time;
    std::fprintf(stderr, "  %s: t = %.4g of %.4g s, %ld steps, %zu particles, %.0f s, about %.0f s to go\n",
                 e.variant.c_str(), static_cast<double>(p.time), static_cast<double>(p.duration), p.steps, p.particles,
                 p.wall_seconds, left);
  }

  const SweepOptions& opt_;
  std::vector<double> last_line_;  // per variant: the run's wall time at its last progress line
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  size_t done_ = 0, ran_ = 0;
  double run_wall_ = 0;
};

int sweep(const SweepArgs& a) {
  Ranks ranks;
  if (const auto code = ranks.start(a)) return *code;
  Sweep sweep;
  SweepOptions opt;
  if (!load(a, sweep, opt)) return ranks.leave(2);
  std::unique_ptr<RunStore> store;
  try {
    store = std::make_unique<RunStore>(a.db);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return ranks.leave(2);
  }
  stop_on_signals();
  opt.out_root = a.out;
  opt.jobs = a.jobs;
  opt.threads = a.threads;
  opt.checkpoint_interval = a.checkpoint_every;
  opt.stop = &g_stop;
  ProgressLines progress(opt);
  opt.on_event = [&](const SweepEvent& e) { progress(e); };
  const SweepResult result = ranks.run(*store, sweep, opt);
  const size_t completed = std::count_if(result.runs.begin(), result.runs.end(),
                                         [](const auto& r) { return r.status == "completed"; });
  spdlog::info("sweep {}: {} of {} runs completed; stored in {}", sweep.name, completed, result.runs.size(), a.db);
  if (!result.differences.empty()) {
    std::string list;
    for (const auto& v : result.differences) list += (list.empty() ? "" : ", ") + v;
    spdlog::info("difference rasters against {} (rasters/diff_max_depth.tif, diff_max_hv.tif) for {}",
                 sweep.variants.front().name, list);
  }
  store.reset();  // closed before MPI ends (Ranks::finish)
  int code = completed == result.runs.size() ? 0 : 3;
  if (g_stop.load()) {
    spdlog::warn("stopped: finished runs are stored; run the same command again to resume");
    code = 130;
  } else if (!a.no_compare && completed > 0) {
    std::printf("\n");
    CompareArgs c;
    c.db = a.db;
    c.sweep = sweep.name;
    compare(c);
  }
  return ranks.finish(code);
}

}  // namespace

Action add_sweep(CLI::App& app) {
  auto a = std::make_shared<SweepArgs>();
  auto* cmd = app.add_subcommand("sweep", "Run every layout of a sweep, store each run, print the comparison");
  cmd->footer("Example:\n  runout sweep scenarios/flume/c0_c7.json --fidelity draft --jobs 2");
  cmd->add_option("sweep", a->path, "Sweep file (JSON)")->required();
  a->fidelity.add_to(cmd, "the sweep's");
  cmd->add_option("--jobs", a->jobs, "Runs at once (each gets the cores divided among the jobs)")->check(CLI::Range(1, 64));
  cmd->add_option("--threads,-j", a->threads, "OpenMP threads per run (default: cores / jobs)")->check(CLI::Range(0, 1024));
  cmd->add_option("--checkpoint-every", a->checkpoint_every,
                  "Save each run's state every SECONDS of wall time and when stopped; the same command resumes "
                  "an interrupted run from it (default 0: no checkpoints)")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  cmd->add_option("--out,-o", a->out, "Outputs go to OUT/<sweep>/<variant>")->capture_default_str();
  cmd->add_flag("--no-compare", a->no_compare, "Do not print the comparison at the end");
  cmd->add_option("--heartbeat-timeout", a->heartbeat_timeout,
                  "Under mpirun/srun: seconds without a word from a worker rank before its run goes to another "
                  "(docs/cluster.md)")
      ->check(CLI::Range(1.0, 86400.0))
      ->capture_default_str();
  return [a](const char*) { return sweep(*a); };
}

}  // namespace runout::cli
