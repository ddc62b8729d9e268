// `runout run`: one scene, its outputs, and the run put in the run store.
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>
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
  std::string variant;  // with a sweep file: the layout to run
  FidelityArgs fidelity;
  bool snapshots = false, quiet = false, no_db = false;
  int threads = 0;
  double checkpoint_every = 0;
};

// The scene that runs: as written, or resolved at --fidelity / --dp as a sweep resolves its layouts; or one
// layout of a sweep file (--variant), resolved as `runout sweep` resolves it.
struct ResolvedScene {
  std::string json;   // what the manifest hashes
  Fidelity fidelity;  // "scene" (as written: no preset applied), a preset, or "custom" (--dp)
  Scene scene;
  std::filesystem::path base_dir;  // where the scene's relative paths (the DEM, layers) start
  std::string sweep, variant;      // a sweep's layout: stored under the sweep's name, as the sweep stores it
};

// A sweep file names a base scene; a scene has no "base" field (it is refused in a scene).
bool is_sweep_file(const std::string& text) {
  const auto j = nlohmann::json::parse(text, nullptr, false);
  return j.is_object() && j.contains("base");
}

// The layout `a.variant` of the sweep file at the fidelity the sweep would run it (its own, or --fidelity /
// --dp), so that the run is the sweep's run of that layout (the same manifest hash).
ResolvedScene resolve_layout(const RunArgs& a) {
  const Sweep sweep = load_sweep(a.scene_path);
  std::string names;
  const SweepVariant* layout = nullptr;
  for (const auto& v : sweep.variants) {
    names += (names.empty() ? "" : ", ") + v.name;
    if (v.name == a.variant) layout = &v;
  }
  if (a.variant.empty())
    throw SceneError("--variant", a.scene_path + " is a sweep: name the layout to run (accepted: " + names + ")");
  if (!layout)
    throw SceneError("--variant", "'" + a.variant + "' is not a layout of sweep " + sweep.name + " (accepted: " + names + ")");
  ResolvedScene r;
  r.fidelity = a.fidelity.chosen().value_or(sweep.fidelity);
  r.json = resolve_variant(sweep.base_json, *layout, r.fidelity);
  r.base_dir = sweep.base_path.parent_path();
  r.scene = parse_scene(r.json, r.base_dir);
  r.sweep = sweep.name;
  r.variant = layout->name;
  return r;
}

// Throws SceneError (exit 2) for an unreadable or refused scene.
ResolvedScene resolve(const RunArgs& a) {
  ResolvedScene r;
  r.json = read_text(a.scene_path);
  if (is_sweep_file(r.json)) return resolve_layout(a);
  if (!a.variant.empty())
    throw SceneError("--variant", "only for a sweep file (a base scene and its layouts); " + a.scene_path + " is a scene");
  r.base_dir = std::filesystem::path(a.scene_path).parent_path();
  r.fidelity.name = "scene";
  if (const auto f = a.fidelity.chosen()) {
    r.fidelity = *f;
    r.json = resolve_scene(r.json, r.fidelity);
  }
  r.scene = parse_scene(r.json, r.base_dir);
  return r;
}

// A failure to store is logged, not fatal: the outputs are on disk. Recorded as a sweep records its runs
// (execute_run): the manifest of the resolved scene and its fidelity, "custom" for an explicit dp.
void store_run(RunStore& store, const RunArgs& a, const ResolvedScene& r, const RunSummary& s,
               const std::filesystem::path& out) {
  try {
    const auto manifest = make_manifest(r.json, r.base_dir, r.fidelity);
    const std::string fidelity = r.fidelity.dp ? "custom" : r.fidelity.name;
    RunStore::RunRecord record = run_record(manifest, r.scene.name, fidelity, s, out);
    record.sweep = r.sweep;
    record.variant = r.variant;
    const int64_t id = store.put_run(record);
    spdlog::info("stored as run {} in {}", id, a.db);
  } catch (const std::exception& e) {
    spdlog::error("could not store the run: {}", e.what());
  }
}

int run(const RunArgs& a) {
  ResolvedScene resolved;
  try {
    resolved = resolve(a);
  } catch (const SceneError& e) {
    if (e.errors.size() < 2) spdlog::error("scene refused: {}", e.what());
    else
      for (const auto& [field, message] : e.errors) spdlog::error("scene refused: {}: {}", field, message);
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
  const Scene& scene = resolved.scene;
  // A sweep's layout goes where `runout sweep` puts it (runs/<sweep>/<variant>), so `runout report` finds its maps.
  const std::filesystem::path out = !a.out_dir.empty()     ? std::filesystem::path(a.out_dir)
                                    : resolved.sweep.empty() ? std::filesystem::path("runs") / scene.name
                                                             : std::filesystem::path("runs") / resolved.sweep / resolved.variant;
  stop_on_signals();
  ProgressBar bar(scene.name);
  RunOptions opt;
  opt.out_dir = out;
  opt.snapshots = a.snapshots;
  opt.threads = a.threads;
  opt.stop = &g_stop;
  opt.checkpoint_interval = a.checkpoint_every;
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
  if (s.resumed_from >= 0) spdlog::info("resumed from the checkpoint at t = {:.4g} s", s.resumed_from);
  if (s.status == "stopped" && opt.checkpoint_interval > 0 && std::filesystem::exists(out / "checkpoint.bin"))
    spdlog::info("state saved to {}: the same command resumes the run", (out / "checkpoint.bin").string());
  if (store) store_run(*store, a, resolved, s, out);
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
  run_cmd->footer("Examples:\n  runout run scenarios/validation/dam_break_2d.json --dp 0.02 --out runs/dam-break-2d\n"
                  "  runout run scenarios/flume/c0_c7.json --variant C3 --fidelity draft");
  run_cmd->add_option("scene", a->scene_path, "Scene file (JSON), or a sweep file with --variant")->required();  // unreadable: refused by load_scene (2)
  run_cmd->add_option("--variant", a->variant,
                      "With a sweep file: the layout to run, resolved as runout sweep resolves it (its structures, the "
                      "sweep's fidelity unless --fidelity/--dp) and stored under the sweep's name");
  run_cmd->add_option("--out,-o", a->out_dir, "Output directory (default runs/<scene name>; a sweep's layout: runs/<sweep>/<variant>)");
  a->fidelity.add_to(run_cmd, "the scene as written");
  run_cmd->add_flag("--snapshots", a->snapshots, "Write particle snapshots (.vtp) under OUT/snapshots/");
  run_cmd->add_option("--threads,-j", a->threads, "OpenMP threads (default: all cores)")->check(CLI::Range(0, 1024));
  run_cmd->add_option("--checkpoint-every", a->checkpoint_every,
                      "Save the run's state to OUT/checkpoint.bin every SECONDS of wall time and when stopped; "
                      "the same command resumes from it (default 0: no checkpoints)")
      ->check(CLI::Range(0.0, 1e6));
  run_cmd->add_flag("--quiet,-q", a->quiet, "No progress bar");
  run_cmd->add_option("--db", a->db, "Run store (SQLite) the run is put in")->capture_default_str();
  run_cmd->add_flag("--no-db", a->no_db, "Do not store the run");
  return [a](const char*) { return run(*a); };
}

}  // namespace runout::cli
