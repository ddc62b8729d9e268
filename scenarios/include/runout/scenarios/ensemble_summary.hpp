#pragma once
// What an ensemble says of each layout (docs/study.md, "Ensembles"): the decision metrics' quantiles over the
// members, how often each layout ranks first, and maps of the probability that a hazard raster reaches a
// threshold. An ensemble's runs are named LAYOUT-eNNN (sweep.hpp); a layout's members are those runs.
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/sweep.hpp"

namespace runout {

// "G3-e017" -> {"G3", 17}; nullopt for a name that is not an ensemble member's.
struct MemberName {
  std::string layout;
  int member = -1;
};
std::optional<MemberName> split_member_name(const std::string& variant);

// The p-quantile of `values` (p in [0, 1]), linear between order statistics (Hyndman and Fan's type 7, numpy's
// and R's default): x[(n-1)p] interpolated. Throws std::invalid_argument for no values or p outside [0, 1].
double quantile(std::vector<double> values, double p);

struct MetricQuantiles {
  double p10 = 0, p50 = 0, p90 = 0;
  size_t count = 0;  // members with a value (an arrival that never happened is no value)
  size_t never = 0;  // members whose arrival never happened
};

struct EnsembleSummary {
  std::string sweep;
  std::vector<std::string> layouts;  // natural order; the first is the baseline
  size_t members = 0;                // members with a completed run of every layout: those summarised
  size_t incomplete = 0;             // members left out: some layout not (yet) completed
  std::string ranking_metric;        // the outlet's peak discharge (decision_metrics.hpp); empty: no outlet
  std::vector<std::string> metrics;  // the decision metrics, by rank
  std::map<std::string, std::map<std::string, MetricQuantiles>> quantiles;  // layout -> metric -> quantiles
  // Layout -> the share of the members in which it ranks first on ranking_metric (lowest first). Values equal as
  // printed (4 significant digits, the report's rule for ties) tie; a member's first place is shared equally
  // among the layouts tied for it, so the shares sum to 1. Members without the metric for every layout are not
  // counted (ranked_members says how many were).
  std::map<std::string, double> first_share;
  size_t ranked_members = 0;
};

// The summary of the stored ensemble sweep `sweep`: the latest completed run of each LAYOUT-eNNN (at `fidelity`
// when it is not empty: the store's fidelity name, "screening", "draft", "custom"). nullopt when the sweep has no
// completed run named as an ensemble member.
std::optional<EnsembleSummary> summarise_ensemble(const RunStore& store, const std::string& sweep,
                                                  const std::string& fidelity = "");
// The same from the runs given, variant -> completed run id (the service's sweep: its own jobs' runs, not every
// stored run of a sweep name); variants that are not member names are left out.
std::optional<EnsembleSummary> summarise_ensemble_runs(const RunStore& store, const std::string& sweep,
                                                       const std::map<std::string, int64_t>& runs);

// The summary as JSON text ({sweep, layouts, members, incomplete, ranking_metric, ranked_members, layouts_detail:
// {LAYOUT: {first_share, metrics: {METRIC: {p10, p50, p90, count, never}}}}}).
std::string ensemble_summary_json(const EnsembleSummary& s);

// One exceedance map: the probability over an ensemble's members that `raster` reaches `threshold`.
struct ExceedanceThreshold {
  std::string raster;  // a run's hazard raster: "max_depth", "max_hv", "max_pressure", "intensity"
  std::string level;   // the threshold's name in the file: "medium", "high", "3kPa"
  double threshold = 0;
  std::string unit;    // of the threshold
};
// The thresholds an ensemble's maps use: the base scene's output.intensity (medium and high depth, h v and
// class; their defaults where the scene gives none) and the ensemble's pressure_thresholds_pa.
std::vector<ExceedanceThreshold> exceedance_thresholds(const Sweep& sweep);

// For each layout of the ensemble sweep: SWEEP_DIR/<layout>/exceedance/p_<raster>_<level>.tif (Float32 in
// [0, 1], nodata where no member reaches the threshold; band description "P(max_depth >= 0.2 m)", metadata
// RUNOUT_LAYOUT, RUNOUT_THRESHOLD, RUNOUT_MEMBERS) and its .qml, from the rasters of every member run found in
// SWEEP_DIR/<variant>/rasters. A threshold no member reaches anywhere gets no file; a layout with no member's
// rasters there is skipped. Returns the layouts written.
std::vector<std::string> write_exceedance_maps(const std::filesystem::path& sweep_dir, const Sweep& sweep);

// What a finished ensemble sweep writes beside its runs: the exceedance maps and SWEEP_DIR/ensemble.json (the
// summary of the stored runs). Nothing for a sweep without an ensemble. Returns the layouts given maps.
std::vector<std::string> write_ensemble_outputs(const RunStore& store, const std::filesystem::path& sweep_dir,
                                                const Sweep& sweep);

}  // namespace runout
