// `runout calibrate-material`: one number of a scene over a list of values, each run stored, fitted to an
// observed runout and/or affected area (scenarios/calibration.hpp, docs/study.md "Calibration as a command").
#include <cstdio>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/calibration.hpp"
#include "runout/scenarios/scene.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout::cli {
namespace {

using json = nlohmann::ordered_json;

struct CalibrateMaterialArgs {
  std::string path, variant, parameter = "/materials/0/friction_angle", range, db = "runout.db", out = "runs";
  std::string format = "table";
  std::vector<double> values;
  FidelityArgs fidelity;
  CalibrationTarget target;
  double runout_m = -1, tolerance_m = -1, min_csi = -1;
  int jobs = 1, threads = 0;
};

// --range MIN:MAX:COUNT as COUNT evenly spaced values, both ends included.
std::vector<double> range_values(const std::string& text) {
  double lo = 0, hi = 0;
  int n = 0;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  if (!(in >> lo >> c1 >> hi >> c2 >> n) || c1 != ':' || c2 != ':' || !in.eof() || n < 2 || n > 64 || !(hi > lo))
    throw SceneError("--range", "must be MIN:MAX:COUNT with MAX > MIN and COUNT in [2, 64], got '" + text + "'");
  std::vector<double> v;
  for (int k = 0; k < n; ++k) v.push_back(lo + (hi - lo) * k / (n - 1));
  return v;
}

json opt_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

json fit_json(const std::optional<CalibrationFit>& f) {
  if (!f) return nullptr;
  return {{"best", opt_number(f->best)}, {"best_how", f->best_how}, {"band", f->band_lo ? json::array({*f->band_lo, *f->band_hi}) : json(nullptr)},
          {"band_how", f->band_how}};
}

void print(const CalibrationResult& r, const CalibrateMaterialArgs& a) {
  if (a.format == "json") {
    json points = json::array();
    for (const auto& p : r.points)
      points.push_back({{"value", p.value}, {"variant", p.variant}, {"status", p.status}, {"run_id", p.run_id},
                        {"runout_m", opt_number(p.runout_m)},
                        {"csi", p.area ? json(p.area->csi) : json(nullptr)},
                        {"hits", p.area ? json(p.area->hits) : json(nullptr)},
                        {"misses", p.area ? json(p.area->misses) : json(nullptr)},
                        {"false_alarms", p.area ? json(p.area->false_alarms) : json(nullptr)}});
    const json out = {{"sweep", r.sweep}, {"parameter", r.pointer}, {"points", points},
                      {"runout", fit_json(r.runout_fit)}, {"area", fit_json(r.area_fit)}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("%-12s %-10s %12s %8s\n", "value", "status", "runout [m]", "CSI");
  for (const auto& p : r.points) {
    char runout[32] = "-", csi[32] = "-";
    if (p.runout_m) std::snprintf(runout, sizeof runout, "%.1f", *p.runout_m);
    if (p.area) std::snprintf(csi, sizeof csi, "%.3f", p.area->csi);
    std::printf("%-12g %-10s %12s %8s\n", p.value, p.status.c_str(), runout, csi);
  }
  for (const auto& [what, fit] : {std::pair{"runout", &r.runout_fit}, std::pair{"area", &r.area_fit}}) {
    if (!*fit) continue;
    const CalibrationFit& f = **fit;
    if (f.best) std::printf("\n%s: best %.4g (%s)", what, *f.best, f.best_how.c_str());
    else std::printf("\n%s: no best (%s)", what, f.best_how.c_str());
    if (f.band_lo) std::printf("; band %g to %g (%s)", *f.band_lo, *f.band_hi, f.band_how.c_str());
    else if (!f.band_how.empty()) std::printf("; %s", f.band_how.c_str());
    std::printf("\n");
  }
}

int calibrate_material(CalibrateMaterialArgs a) {
  try {
    if (!a.range.empty()) a.values = range_values(a.range);
    if (a.values.empty()) throw SceneError("--values", "give --values V1,V2,... or --range MIN:MAX:COUNT");
    if (a.runout_m > 0) a.target.runout_m = a.runout_m;
    if (a.tolerance_m >= 0) {
      if (!a.target.runout_m) throw SceneError("--tolerance-m", "only with --runout-m");
      a.target.runout_tolerance_m = a.tolerance_m;
    }
    if (a.min_csi >= 0) {
      if (a.target.area.empty()) throw SceneError("--min-csi", "only with --area");
      a.target.min_csi = a.min_csi;
    }
    if (!a.target.runout_m && a.target.area.empty())
      throw SceneError("--runout-m", "give an observation: --runout-m (with --tolerance-m) and/or --area");
    const Sweep sweep = calibration_sweep(a.path, a.variant, a.parameter, a.values);
    SweepOptions opt;
    opt.fidelity_override = true;
    opt.fidelity = a.fidelity.chosen().value_or(Fidelity{"screening", std::nullopt});
    opt.out_root = a.out;
    opt.jobs = a.jobs;
    opt.threads = a.threads;
    stop_on_signals();
    opt.stop = &g_stop;
    opt.on_event = [](const SweepEvent& e) {
      if (e.kind == SweepEvent::finished)
        std::fprintf(stderr, "[%zu/%zu] %s %s%s %.1f s\n", e.index + 1, e.total, e.variant.c_str(),
                     e.result.status.c_str(), e.result.reused ? " (already stored)" : "", e.result.wall_seconds);
    };
    RunStore store(a.db);
    print(calibrate_material(store, sweep, a.target, opt), a);
    if (g_stop.load()) return 130;
  } catch (const SceneError& e) {
    spdlog::error("calibrate-material refused: {}", e.what());
    return 2;
  } catch (const terrain::TerrainError& e) {
    spdlog::error("calibrate-material: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("calibrate-material: {}", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

Action add_calibrate_material(CLI::App& app) {
  auto a = std::make_shared<CalibrateMaterialArgs>();
  auto* cmd = app.add_subcommand("calibrate-material",
                                 "Run one number of a scene (the friction angle) over a range and fit it to an "
                                 "observed runout and/or affected area");
  cmd->footer("Example (the Alr design basis: G0's runout against the relation's 3 094 m, docs/study.md):\n"
              "  runout calibrate-material scenarios/catchment/alr_g0_g7.json --variant G0 --range 17:23:4 \\\n"
              "      --runout-m 3094 --tolerance-m 774");
  cmd->add_option("file", a->path, "Scene file, or a sweep file with --variant")->required();
  cmd->add_option("--variant", a->variant, "The sweep's layout to calibrate on");
  cmd->add_option("--parameter", a->parameter, "JSON pointer of the number varied")->capture_default_str();
  auto* values = cmd->add_option("--values", a->values, "The values, ascending (comma-separated)")->delimiter(',');
  cmd->add_option("--range", a->range, "MIN:MAX:COUNT evenly spaced values instead")->excludes(values);
  cmd->add_option("--runout-m", a->runout_m, "Observed runout [m] (terrain.inundation.runout_m)")
      ->check(CLI::Range(1e-6, 1e7));
  cmd->add_option("--tolerance-m", a->tolerance_m, "Its scatter [m]: the band is where the runout lies within it")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--area", a->target.area, "Observed affected-area polygons (GeoPackage, GeoJSON, Shapefile, ...)");
  cmd->add_option("--area-layer", a->target.area_layer, "Its layer (when the file has several)");
  cmd->add_option("--min-csi", a->min_csi, "The band for the area: values whose CSI reaches this")
      ->check(CLI::Range(0.0, 1.0));
  a->fidelity.add_to(cmd, "screening");
  cmd->add_option("--jobs", a->jobs, "Runs at once")->check(CLI::Range(1, 64));
  cmd->add_option("--threads,-j", a->threads, "OpenMP threads per run (default: cores / jobs)")->check(CLI::Range(0, 1024));
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  cmd->add_option("--out,-o", a->out, "Outputs go to OUT/<sweep>/<variant>")->capture_default_str();
  cmd->add_option("--format", a->format, "table | json")->check(CLI::IsMember({"table", "json"}))->capture_default_str();
  return [a](const char*) { return calibrate_material(*a); };
}

}  // namespace runout::cli
