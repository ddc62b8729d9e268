// `runout run`: one scene, its outputs, and the run put in the run store.
#include <filesystem>
#include <memory>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "progress.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout::cli {
namespace {

struct RunArgs {
  std::string scene_path, out_dir, db = "runout.db";
  bool snapshots = false, quiet = false, no_db = false;
  int threads = 0;
};

// A failure to store is logged, not fatal: the outputs are on disk.
void store_run(RunStore& store, const RunArgs& a, const Scene& scene, const RunSummary& s,
               const std::filesystem::path& out) {
  // The scene as written is the run's identity (fidelity "scene": no preset applied).
  Fidelity as_written;
  as_written.name = "scene";
  try {
    const auto manifest =
        make_manifest(read_text(a.scene_path), std::filesystem::path(a.scene_path).parent_path(), as_written);
    const int64_t id = store.put_run(run_record(manifest, scene.name, as_written.name, s, out));
    spdlog::info("stored as run {} in {}", id, a.db);
  } catch (const std::exception& e) {
    spdlog::error("could not store the run: {}", e.what());
  }
}

int run(const RunArgs& a) {
  Scene scene;
  try {
    scene = load_scene(a.scene_path);
  } catch (const SceneError& e) {
    spdlog::error("scene refused: {}", e.what());
    return 2;
  }
  std::unique_ptr<RunStore> store;
  if (!a.no_db) {
    try {
      store = std::make_unique<RunStore>(a.db);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      return 2;
    }
  }
  const std::filesystem::path out =
      a.out_dir.empty() ? std::filesystem::path("runs") / scene.name : std::filesystem::path(a.out_dir);
  stop_on_signals();
  ProgressBar bar(scene.name);
  RunOptions opt;
  opt.out_dir = out;
  opt.snapshots = a.snapshots;
  opt.threads = a.threads;
  opt.stop = &g_stop;
  if (!a.quiet) opt.on_progress = [&](const RunProgress& p) { bar.update(p); };
  RunSummary s;
  try {
    s = run_scene(scene, opt);
  } catch (const std::exception& e) {
    bar.finish();
    spdlog::error("run could not start: {}", e.what());
    return 1;
  }
  bar.finish();
  if (store) store_run(*store, a, scene, s, out);
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

}  // namespace

Action add_run(CLI::App& app) {
  auto a = std::make_shared<RunArgs>();
  auto* run_cmd = app.add_subcommand("run", "Run one scene and write metrics.json, series/ and snapshots/");
  run_cmd->add_option("scene", a->scene_path, "Scene file (JSON)")->required();  // unreadable: refused by load_scene (2)
  run_cmd->add_option("--out,-o", a->out_dir, "Output directory (default runs/<scene name>)");
  run_cmd->add_flag("--snapshots", a->snapshots, "Write particle snapshots (.vtp) under OUT/snapshots/");
  run_cmd->add_option("--threads,-j", a->threads, "OpenMP threads (default: all cores)")->check(CLI::Range(0, 1024));
  run_cmd->add_flag("--quiet,-q", a->quiet, "No progress bar");
  run_cmd->add_option("--db", a->db, "Run store (SQLite) the run is put in")->capture_default_str();
  run_cmd->add_flag("--no-db", a->no_db, "Do not store the run");
  return [a](const char*) { return run(*a); };
}

}  // namespace runout::cli
