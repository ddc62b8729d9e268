// The `runout` command.
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "progress.hpp"
#include "runout/scenarios/run.hpp"
#include "runout/scenarios/scene.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

int cmd_run(const std::string& scene_path, const std::string& out_dir, bool snapshots, int threads, bool quiet) {
  runout::Scene scene;
  try {
    scene = runout::load_scene(scene_path);
  } catch (const runout::SceneError& e) {
    spdlog::error("scene refused: {}", e.what());
    return 2;
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

  CLI11_PARSE(app, argc, argv);
  if (run->parsed()) return cmd_run(scene_path, out_dir, snapshots, threads, quiet);
  return 0;
}
