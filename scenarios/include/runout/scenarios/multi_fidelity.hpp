#pragma once
// The multi-fidelity study (`runout study`, docs/study.md "The multi-fidelity study"): an ensemble sweep screened
// at the cheap rung over every member, the layouts that can still be best chosen from it, and those run in 3D at
// one rung at the ensemble's median material; then screening against 3D for the layouts run in both and the final
// ranking with what decided it.
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout {

// Which layouts go on to 3D, from the screening ensemble's ranking metric (the outlet's Q_m, lowest best): the
// leader is the layout of the lowest median; a layout can still be best when its p10-p90 interval overlaps the
// leader's (its p10 <= the leader's p90). The baseline always goes on (the 3D comparison is against it).
// `why` says for each layout why it was chosen or dropped. Layouts without the metric are kept (nothing rules
// them out).
struct LayoutSelection {
  std::string leader;
  std::vector<std::string> chosen;  // in the summary's layout order
  std::map<std::string, std::string> why;
};
LayoutSelection select_layouts(const EnsembleSummary& screening, const std::string& baseline);

// The ensemble's median material: each parameter at its distribution's median, or a grid axis's median value.
std::vector<ParameterValue> median_member(const Ensemble& e);

// A plain sweep of `layouts` of the ensemble sweep, at the median member's values, named "<sweep>-median".
Sweep median_sweep(const Sweep& ensemble_sweep, const std::vector<std::string>& layouts);

struct MultiFidelityOptions {
  Fidelity screening{"screening", std::nullopt};
  Fidelity detailed{"standard", std::nullopt};  // the 3D rung
  SweepOptions run;                              // out_root, jobs, threads, stop, on_event (its fidelity is set here)
};
struct MultiFidelityResult {
  EnsembleSummary screening;
  LayoutSelection selection;
  Sweep detailed_sweep;
  SweepResult detailed;
  std::string ranking_metric;
  // Per layout run in 3D: its screening p50 and its 3D value of the ranking metric; the 3D ranking (lowest first).
  std::map<std::string, std::optional<double>> screening_p50, detailed_value;
  std::vector<std::string> detailed_ranking;
  bool stopped = false;  // a stage was stopped (Ctrl-C); what ran is stored
};
// The screening stage's outcome, as `runout study` and the service's study sweeps (docs/service.md, "Studies")
// both take it: the layouts chosen from the summary (select_layouts; the baseline is the sweep's first layout),
// the detailed sweep of those at the median member (median_sweep) and each chosen layout's screening p50 of
// the ranking metric. The detailed values are left unset (set_detailed_values).
MultiFidelityResult screening_outcome(const Sweep& ensemble_sweep, const EnsembleSummary& screening);
// Each layout of the detailed sweep's value of the ranking metric (nullopt: its run has none or did not
// complete) and the detailed ranking: lowest first, values equal to 4 significant digits by name, no value last.
void set_detailed_values(MultiFidelityResult& r, const std::map<std::string, std::optional<double>>& values);

// Runs the two stages (each resumable through the store, as sweeps are). Throws SceneError ("ensemble") for a
// sweep without an ensemble.
MultiFidelityResult run_multi_fidelity_study(RunStore& store, const Sweep& sweep, const MultiFidelityOptions& options);

// The result as JSON text (SWEEP_DIR/study.json).
std::string multi_fidelity_json(const MultiFidelityResult& r);

}  // namespace runout
