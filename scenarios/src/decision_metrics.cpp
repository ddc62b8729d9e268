#include "runout/scenarios/decision_metrics.hpp"

#include <algorithm>
#include <array>
#include <cctype>

namespace runout {
namespace {

const std::string kSection = "monitors.section.";

// The middle of `name` between `prefix` and `suffix` (names of sections or structures may hold dots), if any.
std::optional<std::string> between(const std::string& name, const std::string& prefix, const std::string& suffix) {
  if (name.size() <= prefix.size() + suffix.size()) return std::nullopt;
  if (name.compare(0, prefix.size(), prefix) != 0) return std::nullopt;
  if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return std::nullopt;
  return name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// A per-subject group: the metric is PREFIX<subject>SUFFIX for one of the suffixes (its field).
struct SubjectGroup {
  int group;
  std::string prefix;
  std::vector<std::string> suffixes;
};

const std::array<SubjectGroup, 3>& subject_groups() {
  static const std::array<SubjectGroup, 3> groups = {{
      {3, "monitors.structure_load.", {".peak_force_n", ".peak_mean_pressure_pa"}},
      {4, "terrain.structures.", {".retained_volume_m3", ".upstream_volume_m3"}},
      {6, "terrain.protected_zones.", {".inundated_area_m2", ".max_depth_m", ".arrival_time_s"}},
  }};
  return groups;
}

}  // namespace

bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])), db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      // Without leading zeros the longer run is the larger number.
      std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

bool operator<(const DecisionRank& a, const DecisionRank& b) {
  if (a.group != b.group) return a.group < b.group;
  if (a.subject != b.subject) return natural_less(a.subject, b.subject);
  return a.field < b.field;
}

DecisionMetrics::DecisionMetrics(const std::vector<std::string>& metric_names) {
  std::vector<std::string> sections;
  for (const auto& n : metric_names)
    if (auto s = between(n, kSection, ".peak_discharge_m3_s")) sections.push_back(*s);
  std::sort(sections.begin(), sections.end(), natural_less);
  sections.erase(std::unique(sections.begin(), sections.end()), sections.end());
  for (const auto& s : sections)
    if (lower(s).find("outlet") != std::string::npos) {
      outlet_ = s;
      return;
    }
  if (!sections.empty()) outlet_ = sections.back();
}

std::string DecisionMetrics::ranking_metric() const {
  return outlet_.empty() ? std::string() : kSection + outlet_ + ".peak_discharge_m3_s";
}

std::optional<DecisionRank> DecisionMetrics::rank(const std::string& metric) const {
  if (!outlet_.empty()) {
    if (metric == kSection + outlet_ + ".peak_discharge_m3_s") return DecisionRank{1, {}, 0};
    if (metric == kSection + outlet_ + ".volume_passed_m3") return DecisionRank{2, {}, 0};
  }
  if (metric == "terrain.inundation.inundated_area_m2") return DecisionRank{5, {}, 0};
  if (metric == "terrain.inundation.runout_m") return DecisionRank{7, {}, 0};
  for (const auto& g : subject_groups())
    for (size_t f = 0; f < g.suffixes.size(); ++f)
      if (auto subject = between(metric, g.prefix, g.suffixes[f])) {
        // terrain.structures.<type>.<name>: the structure's name ranks, not its type.
        // (Unnamed structures are keyed by position: "terrain.structures.0.".)
        if (g.group == 4) {
          const size_t dot = subject->find('.');
          if (dot != std::string::npos) subject = subject->substr(dot + 1);
        }
        return DecisionRank{g.group, *subject, static_cast<int>(f)};
      }
  return std::nullopt;
}

std::vector<std::string> DecisionMetrics::order(const std::vector<std::string>& names, bool all) const {
  std::vector<std::pair<DecisionRank, std::string>> decision;
  std::vector<std::string> rest;
  for (const auto& n : names) {
    if (auto r = rank(n)) decision.push_back({*r, n});
    else if (all) rest.push_back(n);
  }
  std::stable_sort(decision.begin(), decision.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> out;
  for (auto& [r, n] : decision) out.push_back(std::move(n));
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

std::string DecisionMetrics::label(const std::string& metric) const {
  const auto r = rank(metric);
  if (!r) return metric;
  switch (r->group) {
    case 1: return outlet_ + " Q_m [m³/s]";
    case 2: return outlet_ + " volume [m³]";
    case 3: return r->subject + (r->field == 0 ? " peak force [N]" : " peak mean pressure [Pa]");
    case 4: return r->subject + (r->field == 0 ? " retained [m³]" : " upstream [m³]");
    case 5: return "inundated area [m²]";
    case 6: return r->subject + (r->field == 0 ? " area [m²]" : r->field == 1 ? " max depth [m]" : " arrival [s]");
    case 7: return "runout [m]";
    default: return metric;
  }
}

bool DecisionMetrics::higher_is_better(const std::string& metric) {
  auto ends = [&](const std::string& e) {
    return metric.size() >= e.size() && metric.compare(metric.size() - e.size(), e.size(), e) == 0;
  };
  return ends("arrival_time_s") || ends("retained_volume_m3") || ends("upstream_volume_m3");
}

}  // namespace runout
