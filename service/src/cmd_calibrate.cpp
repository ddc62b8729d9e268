// `runout calibrate`: the cost model refitted to the completed runs of run stores, predicted against measured
// run times (docs/tradeoff.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "runout/scenarios/store.hpp"

namespace runout::cli {
namespace {

using json = nlohmann::json;

struct CalibrateArgs {
  std::vector<std::string> dbs = {"runout.db"};  // run stores read (several: their runs together)
  std::string sweep_prefix;  // only runs whose sweep starts with this (empty: all)
  std::string json_out;      // write the fitted coefficients here (JSON)
};

int calibrate(const CalibrateArgs& c) {
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
  std::printf("%-44s %2s %8s %8s %8s %9s %8s %9s %9s %8s %8s %8s\n", "run", "D", "fluid", "boundary", "alive",
              "predicted", "steps", "wall [s]", "shipped", "err %", "fitted", "LOO %");
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
    std::printf("%-44s %2d %8.0f %8.0f %8.0f %9.0f %8.0f %9.1f %9.1f %+8.1f %8.1f %+8.1f\n", r.label.substr(0, 44).c_str(),
                r.features.dimensions, r.features.fluid, r.features.boundary, r.boundary_peak,
                fitted.boundary_peak(r.features), r.steps, r.wall_seconds, ps, es, pf, el);
  }
  auto coef = [](const CostCoefficients& k) {
    return json{{"step_ratio", k.step_ratio}, {"a_fluid_s", k.a_fluid}, {"b_boundary_s", k.b_boundary}, {"b_fluid_s", k.b_fluid},
                {"c_step_s", k.c_step}};
  };
  const json out = {{"runs", runs.size()},
                    {"two_d", coef(fitted.two_d)},
                    {"three_d", coef(fitted.three_d)},
                    {"screening", coef(fitted.screening)},
                    {"parallel_efficiency", fitted.parallel_efficiency},
                    {"parallel_half_fluid", fitted.parallel_half_fluid},
                    {"bed_per_flow_column", fitted.bed_per_flow_column},
                    {"worst_error_percent_shipped", worst_shipped},
                    {"worst_error_percent_leave_one_out", worst_loo}};
  std::printf("\nfitted on %zu runs: %s\n", runs.size(), out.dump().c_str());
  std::printf("worst |error|: shipped model %.1f %%, leave-one-out refit %.1f %%\n", worst_shipped, worst_loo);
  if (!c.json_out.empty()) std::ofstream(c.json_out) << out.dump(2) << "\n";
  return 0;
}

}  // namespace

Action add_calibrate(CLI::App& app) {
  auto c = std::make_shared<CalibrateArgs>();
  auto* cmd = app.add_subcommand("calibrate", "Fit the cost model to the completed runs of a store; print "
                                              "predicted against measured run times");
  cmd->footer("Example (after runout sweep scenarios/flume/c0_c7.json):\n  runout calibrate --db runout.db --sweep flume");
  cmd->add_option("--db", c->dbs, "Run store (SQLite); repeat to fit the runs of several")->capture_default_str();
  cmd->add_option("--sweep", c->sweep_prefix, "Only runs whose sweep name starts with this");
  cmd->add_option("--json", c->json_out, "Write the fitted coefficients to this file");
  return [c](const char*) { return calibrate(*c); };
}

}  // namespace runout::cli
