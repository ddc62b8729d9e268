// `runout study`: the multi-fidelity study of an ensemble sweep (scenarios/multi_fidelity.hpp, docs/study.md
// "The multi-fidelity study").
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "runout/scenarios/decision_metrics.hpp"
#include "runout/scenarios/multi_fidelity.hpp"
#include "runout/scenarios/scene.hpp"

namespace runout::cli {
namespace {

struct StudyArgs {
  std::string path, db = "runout.db", out = "runs", screening = "screening";
  FidelityArgs detailed;
  int jobs = 1, threads = 0;
};

std::string value_text(const std::optional<double>& v) {
  if (!v) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", *v);
  return buf;
}

void print(const MultiFidelityResult& r) {
  const DecisionMetrics d(std::vector<std::string>{r.ranking_metric});
  std::printf("Stage 1, screening: %zu members of %zu layouts; ranked by %s (lowest first)\n", r.screening.members,
              r.screening.layouts.size(), d.label(r.ranking_metric).c_str());
  for (const auto& l : r.screening.layouts)
    std::printf("  %-8s first in %3.0f %%  %s\n", l.c_str(), 100.0 * r.screening.first_share.at(l),
                r.selection.why.count(l) ? r.selection.why.at(l).c_str() : "");
  std::printf("\nStage 2, %s: the chosen layouts at the median member\n", r.detailed_sweep.name.c_str());
  for (const auto& v : r.detailed_sweep.variants.empty() ? std::vector<ParameterValue>{} : r.detailed_sweep.variants.front().parameters)
    std::printf("  %s = %g\n", v.pointer.c_str(), v.value);
  std::printf("  %-8s %14s %14s\n", "layout", "screening p50", "3D");
  for (const auto& l : r.detailed_ranking)
    std::printf("  %-8s %14s %14s\n", l.c_str(), value_text(r.screening_p50.at(l)).c_str(),
                value_text(r.detailed_value.at(l)).c_str());
  if (r.detailed_ranking.empty()) return;
  // Layouts whose values print alike tie (the ranking's rule): all of them are named, not the first by name.
  const std::string top = value_text(r.detailed_value.at(r.detailed_ranking.front()));
  std::string best;
  for (const auto& l : r.detailed_ranking)
    if (value_text(r.detailed_value.at(l)) == top) best += (best.empty() ? "" : ", ") + l;
  std::printf("\nBest in 3D: %s%s\n", best.c_str(), best.find(',') == std::string::npos ? "" : " (tied)");
}

int study(const StudyArgs& a) {
  try {
    const Sweep sweep = load_sweep(a.path);
    if (!sweep.ensemble) throw SceneError("ensemble", "runout study needs a sweep with an ensemble (docs/scene-format.md)");
    MultiFidelityOptions o;
    o.screening = {a.screening, std::nullopt};
    if (const auto f = a.detailed.chosen()) o.detailed = *f;
    o.run.out_root = a.out;
    o.run.jobs = a.jobs;
    o.run.threads = a.threads;
    stop_on_signals();
    o.run.stop = &g_stop;
    o.run.on_event = [](const SweepEvent& e) {
      if (e.kind == SweepEvent::finished)
        std::fprintf(stderr, "[%zu/%zu] %s %s%s %.1f s\n", e.index + 1, e.total, e.variant.c_str(),
                     e.result.status.c_str(), e.result.reused ? " (already stored)" : "", e.result.wall_seconds);
    };
    RunStore store(a.db);
    const MultiFidelityResult r = run_multi_fidelity_study(store, sweep, o);
    if (r.stopped) {
      spdlog::warn("stopped: finished runs are stored; run the same command again to resume");
      return 130;
    }
    print(r);
    const std::filesystem::path file = std::filesystem::path(a.out) / sweep.name / "study.json";
    std::filesystem::create_directories(file.parent_path());
    std::ofstream(file) << multi_fidelity_json(r) << "\n";
    spdlog::info("study: wrote {}", file.string());
  } catch (const SceneError& e) {
    spdlog::error("study refused: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("study: {}", e.what());
    return 1;
  }
  return 0;
}

}  // namespace

Action add_study(CLI::App& app) {
  auto a = std::make_shared<StudyArgs>();
  auto* cmd = app.add_subcommand("study",
                                 "Screen every layout over an ensemble, then run in 3D, at the median material, the "
                                 "layouts that can still be best");
  cmd->footer("Example:\n  runout study scenarios/flume/c0_c7_ensemble.json --screening-fidelity draft --fidelity standard");
  cmd->add_option("sweep", a->path, "Sweep file with an ensemble (JSON)")->required();
  cmd->add_option("--screening-fidelity", a->screening, "The first stage's rung")
      ->check(CLI::IsMember(fidelity_names()))
      ->capture_default_str();
  a->detailed.add_to(cmd, "standard");
  cmd->add_option("--jobs", a->jobs, "Runs at once")->check(CLI::Range(1, 64));
  cmd->add_option("--threads,-j", a->threads, "OpenMP threads per run (default: cores / jobs)")->check(CLI::Range(0, 1024));
  cmd->add_option("--db", a->db, "Run store (SQLite)")->capture_default_str();
  cmd->add_option("--out,-o", a->out, "Outputs go to OUT/<sweep>/<variant>; the result to OUT/<sweep>/study.json")
      ->capture_default_str();
  return [a](const char*) { return study(*a); };
}

}  // namespace runout::cli
