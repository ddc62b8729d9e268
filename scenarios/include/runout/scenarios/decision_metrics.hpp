#pragma once
// The decision metrics: the few stored metrics (flattened names, store.hpp) a layout is chosen on, ranked in
// the order an engineer weighs them. Defined once here so that `runout compare`, the HTTP /compare and the web
// page list them the same way (docs/store.md, "Decision metrics"):
//   1. the outlet's peak discharge Q_m        monitors.section.<outlet>.peak_discharge_m3_s
//   2. the outlet's passed volume             monitors.section.<outlet>.volume_passed_m3
//   3. peak loads per structure (filtered)    monitors.structure_load.<S>.peak_force_n, .peak_mean_pressure_pa
//   4. retained volumes per structure         terrain.structures.<type>.<S>.retained_volume_m3, .upstream_volume_m3
//   5. inundated area                         terrain.inundation.inundated_area_m2
//   6. protected-zone exposure and arrival    terrain.protected_zones.<Z>.inundated_area_m2, .max_depth_m,
//                                             .arrival_time_s
//   7. runout                                 terrain.inundation.runout_m
// The outlet is the section named like "outlet" (any case), else the last section in natural order of names
// (S1 < S2 < S10): the shipped scenes name their sections down the flow (the flume's Chute, Outlet; the
// catchment's S1-S3).
#include <optional>
#include <string>
#include <vector>

namespace runout {

// Where a decision metric ranks: by group (1-7 above), then by subject (structure or zone, natural order),
// then by field within the group (force before pressure; retained before upstream; area, depth, arrival).
struct DecisionRank {
  int group = 0;
  std::string subject;
  int field = 0;
  bool operator==(const DecisionRank&) const = default;
};
bool operator<(const DecisionRank& a, const DecisionRank& b);

class DecisionMetrics {
 public:
  // The outlet is found among the sections of these metric names (those of the runs compared).
  explicit DecisionMetrics(const std::vector<std::string>& metric_names);

  const std::string& outlet() const { return outlet_; }  // empty: no section among the names
  // The metric layouts are ranked by, the first decision metric: the outlet's peak discharge (lowest first);
  // empty without an outlet.
  std::string ranking_metric() const;
  // Its rank when `metric` is a decision metric, nullopt otherwise.
  std::optional<DecisionRank> rank(const std::string& metric) const;
  bool is_decision(const std::string& metric) const { return rank(metric).has_value(); }
  // The names reordered: decision metrics by rank, then (with `all`) the rest in their given order.
  std::vector<std::string> order(const std::vector<std::string>& names, bool all) const;
  // A heading for people: what the metric is, of which subject, in which unit ("Outlet Q_m [m³/s]",
  // "Village arrival [s]"); the stored name itself for a metric that is not a decision metric.
  std::string label(const std::string& metric) const;
  // Whether a rise from the baseline improves a layout: a later arrival, more held back; for every other
  // decision metric less is better. The report and GET /compare colour differences by it.
  static bool higher_is_better(const std::string& metric);

 private:
  std::string outlet_;
};

// Natural order of names: digit runs compare as numbers ("S2" < "S10"), the rest byte by byte.
bool natural_less(const std::string& a, const std::string& b);

}  // namespace runout
