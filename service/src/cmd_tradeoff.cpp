// `runout tradeoff`: one layout at a ladder of resolutions, the cost and the deviation of every metric from
// the finest (docs/tradeoff.md).
#include <cctype>
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/scene_refs.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/scenarios/tradeoff.hpp"

namespace runout::cli {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

struct TradeoffArgs {
  std::string file;                  // a scene, or a sweep (then `variant` picks the layout)
  std::string variant;               // sweep variant (default: the first)
  std::vector<std::string> levels;   // default: draft, standard, fine
  std::vector<std::string> options;  // PATH=VALUE numerics choices run at option_level
  std::string option_level;
  int threads = 0;
  double checkpoint_every = 0;
  std::string out_dir;               // default runs/tradeoff/<name>
  std::string db = "runout.db";
  bool predict_only = false;
};

// The scene of a tradeoff: a sweep's base with one variant's structures, or a scene with all of its own.
TradeoffSpec tradeoff_spec(const TradeoffArgs& c) {
  TradeoffSpec spec;
  const std::string text = read_text(c.file);
  const json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw SceneError("(file)", c.file + " is not a JSON object");
  if (j.contains("base")) {
    const Sweep sweep = load_sweep(c.file);
    spec.base_json = sweep.base_json;
    spec.base_dir = sweep.base_path.parent_path();
    const SweepVariant* v = &sweep.variants.front();
    if (!c.variant.empty()) {
      v = nullptr;
      std::string names;
      for (const auto& x : sweep.variants) {
        if (x.name == c.variant) v = &x;
        names += (names.empty() ? "" : ", ") + x.name;
      }
      if (!v) throw SceneError("--variant", "'" + c.variant + "' is not a variant of " + sweep.name + " (" + names + ")");
    }
    spec.variant = *v;
    spec.name = sweep.name + "/" + v->name;
  } else {
    if (!c.variant.empty()) throw SceneError("--variant", "only for a sweep file; " + c.file + " is a scene");
    (void)load_scene(c.file);  // refused here, with the field named, if it cannot run
    spec.base_json = text;
    spec.base_dir = fs::path(c.file).parent_path();
    spec.variant.name = "scene";
    spec.variant.structures = structure_names(j);
    spec.name = j.value("name", fs::path(c.file).stem().string());
  }
  spec.levels = c.levels.empty() ? std::vector<std::string>{"draft", "standard", "fine"} : c.levels;
  spec.options = c.options;
  spec.option_level = c.option_level;
  return spec;
}

std::string safe_name(std::string s) {
  for (char& ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_' && ch != '.') ch = '_';
  return s;
}

int tradeoff(const TradeoffArgs& c, const std::atomic<bool>* stop) {
  TradeoffSpec spec;
  try {
    spec = tradeoff_spec(c);
  } catch (const SceneError& e) {
    spdlog::error("tradeoff refused: {}", e.what());
    return 2;
  }
  std::unique_ptr<RunStore> store;
  try {
    store = std::make_unique<RunStore>(c.db);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  TradeoffRunOptions opt;
  opt.out_dir = c.out_dir.empty() ? fs::path("runs") / "tradeoff" / safe_name(spec.name) : fs::path(c.out_dir);
  opt.threads = c.threads;
  opt.checkpoint_interval = c.checkpoint_every;
  opt.stop = stop;
  opt.predict_only = c.predict_only;
  opt.on_line = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  TradeoffResult result;
  try {
    result = run_tradeoff(*store, spec, opt);
  } catch (const SceneError& e) {
    spdlog::error("tradeoff refused: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("tradeoff: {}", e.what());
    return 1;
  }
  if (c.predict_only) {  // the levels' sizes and predicted costs only
    std::printf("%s", format_tradeoff(result).c_str());
    return 0;
  }
  std::printf("%s", format_tradeoff(result).c_str());
  std::fflush(stdout);
  write_tradeoff_csv(result, opt.out_dir);
  write_tradeoff_svg(result, opt.out_dir / "tradeoff.svg", "Speed against accuracy: " + spec.name);
  spdlog::info("tradeoff {}: levels.csv, metrics.csv and tradeoff.svg in {}; runs stored in {} as sweep tradeoff:{}",
               spec.name, opt.out_dir.string(), c.db, spec.name);
  if (stop && stop->load()) return 130;
  for (const auto& l : result.levels)
    if (l.status != "completed") return 3;
  return 0;
}

}  // namespace

Action add_tradeoff(CLI::App& app) {
  auto c = std::make_shared<TradeoffArgs>();
  auto* cmd = app.add_subcommand(
      "tradeoff", "Run a scene at a ladder of resolutions: cost and deviation of every metric from the finest");
  cmd->footer("Example:\n  runout tradeoff scenarios/flume/c0_c7.json --variant C6 --levels draft,standard");
  cmd->add_option("file", c->file, "Scene or sweep file (JSON)")->required();
  cmd->add_option("--variant", c->variant, "The sweep's layout to run (default: its first)");
  cmd->add_option("--levels", c->levels, "draft, standard, fine or dp values [m] (default: all three presets)")
      ->delimiter(',');
  cmd->add_option("--option", c->options,
                  "A numerics choice run at one rung, PATH=VALUE (numerics.kernel=cubic); repeatable");
  cmd->add_option("--option-level", c->option_level, "The rung the options run at (default: the coarsest)");
  cmd->add_option("--threads,-j", c->threads, "OpenMP threads (default: all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--checkpoint-every", c->checkpoint_every,
                  "Save a level's state every SECONDS of wall time and when stopped; the same command resumes the "
                  "level from it (default 0: no checkpoints)")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_option("--out,-o", c->out_dir, "levels.csv, metrics.csv, tradeoff.svg and each level's outputs "
                                          "(default runs/tradeoff/<name>)");
  cmd->add_option("--db", c->db, "Run store (SQLite); stored levels are reused")->capture_default_str();
  cmd->add_flag("--predict-only", c->predict_only,
                "Price each level (its terrain built, its particles counted, not made) and print its particles and "
                "the cost model's steps and time; run nothing");
  return [c](const char*) {
    stop_on_signals();
    return tradeoff(*c, &g_stop);
  };
}

}  // namespace runout::cli
