// `runout tradeoff` and `runout calibrate` (tradeoff_cli.hpp, docs/tradeoff.md).
#include "tradeoff_cli.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <omp.h>
#include <spdlog/spdlog.h>

#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"
#include "runout/scenarios/tradeoff.hpp"

namespace runout::service {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw SceneError("(file)", "cannot read " + p.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The scene of a tradeoff: a sweep's base with one variant's structures, or a scene with all of its own.
TradeoffSpec tradeoff_spec(const TradeoffCommand& c) {
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
    if (j.contains("structures") && j["structures"].is_array())
      for (const auto& s : j["structures"])
        if (s.contains("name") && s["name"].is_string()) spec.variant.structures.push_back(s["name"]);
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

}  // namespace

int run_tradeoff_command(const TradeoffCommand& c, const std::atomic<bool>* stop) {
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

int run_calibrate_command(const CalibrateCommand& c) {
  std::vector<CostObservation> runs;
  std::vector<std::string> names;
  try {
    for (const auto& db : c.dbs) {
      RunStore store(db);
      for (const auto& r : store.list_runs()) {
        if (r.status != "completed" || r.sweep.rfind(c.sweep_prefix, 0) != 0) continue;
        CostObservation o;
        if (!cost_observation_from_metrics(store.metrics_json(r.id), o)) continue;
        o.label = (r.sweep.empty() ? r.scene : r.sweep + "/" + r.variant) + " #" + std::to_string(r.id);
        runs.push_back(o);
      }
    }
  } catch (const std::exception& e) {
    spdlog::error("calibrate: {}", e.what());
    return 2;
  }
  if (runs.size() < 2) {
    spdlog::error("calibrate: {} completed run(s) with cost features in {} (need at least 2; runs stored before the "
                  "cost model have none)",
                  runs.size(), c.dbs.empty() ? std::string() : c.dbs.front());
    return 2;
  }
  const CostModel shipped = CostModel::calibrated();
  const CostModel fitted = fit_cost_model(runs, shipped);
  // Leave-one-out: each run predicted by a model fitted without it, the honest figure for a run not seen.
  std::printf("%-44s %2s %8s %8s %8s %9s %9s %8s %8s %8s\n", "run", "D", "fluid", "boundary", "steps", "wall [s]",
              "shipped", "err %", "fitted", "LOO %");
  double worst_shipped = 0, worst_loo = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    std::vector<CostObservation> others = runs;
    others.erase(others.begin() + i);
    const CostModel loo = fit_cost_model(others, shipped);
    const auto& r = runs[i];
    const double ps = shipped.predict(r.features, r.threads).seconds;
    const double pf = fitted.predict(r.features, r.threads).seconds;
    const double pl = loo.predict(r.features, r.threads).seconds;
    const double es = 100 * (ps - r.wall_seconds) / r.wall_seconds, el = 100 * (pl - r.wall_seconds) / r.wall_seconds;
    worst_shipped = std::max(worst_shipped, std::abs(es));
    worst_loo = std::max(worst_loo, std::abs(el));
    std::printf("%-44s %2d %8.0f %8.0f %8.0f %9.1f %9.1f %+8.1f %8.1f %+8.1f\n", r.label.substr(0, 44).c_str(),
                r.features.dimensions, r.features.fluid, r.features.boundary, r.steps, r.wall_seconds, ps, es, pf, el);
  }
  auto coef = [](const CostCoefficients& k) {
    return json{{"step_ratio", k.step_ratio}, {"a_fluid_s", k.a_fluid}, {"b_boundary_s", k.b_boundary}, {"c_step_s", k.c_step}};
  };
  const json out = {{"runs", runs.size()},
                    {"two_d", coef(fitted.two_d)},
                    {"three_d", coef(fitted.three_d)},
                    {"parallel_efficiency", fitted.parallel_efficiency},
                    {"parallel_half_fluid", fitted.parallel_half_fluid},
                    {"worst_error_percent_shipped", worst_shipped},
                    {"worst_error_percent_leave_one_out", worst_loo}};
  std::printf("\nfitted on %zu runs: %s\n", runs.size(), out.dump().c_str());
  std::printf("worst |error|: shipped model %.1f %%, leave-one-out refit %.1f %%\n", worst_shipped, worst_loo);
  if (!c.json_out.empty()) std::ofstream(c.json_out) << out.dump(2) << "\n";
  return 0;
}

}  // namespace runout::service
