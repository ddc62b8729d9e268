// An ensemble's decision metrics per layout: quantiles over the members and how often each layout ranks first
// (ensemble_summary.hpp).
#include "runout/scenarios/ensemble_summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "runout/scenarios/decision_metrics.hpp"

namespace runout {
namespace {

using json = nlohmann::ordered_json;

// As the report prints a ranking value (4 significant digits): values equal as printed tie.
std::string printed(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

// member -> layout -> the run's flattened metrics
using MemberMetrics = std::map<int, std::map<std::string, std::map<std::string, double>>>;

// The layouts sharing first place in one member (lowest ranking value; empty when a layout lacks it).
std::vector<std::string> first_places(const std::map<std::string, std::map<std::string, double>>& by_layout,
                                      const std::string& key) {
  std::optional<double> best;
  for (const auto& [layout, m] : by_layout) {
    const auto it = m.find(key);
    if (it == m.end() || means_never(key, it->second)) return {};
    if (!best || it->second < *best) best = it->second;
  }
  std::vector<std::string> out;
  for (const auto& [layout, m] : by_layout)
    if (printed(m.at(key)) == printed(*best)) out.push_back(layout);
  return out;
}

void add_quantiles(EnsembleSummary& s, const MemberMetrics& complete) {
  for (const auto& layout : s.layouts)
    for (const auto& metric : s.metrics) {
      std::vector<double> values;
      MetricQuantiles q;
      for (const auto& [member, by_layout] : complete) {
        const auto& m = by_layout.at(layout);
        const auto it = m.find(metric);
        if (it == m.end()) continue;
        if (means_never(metric, it->second)) ++q.never;
        else values.push_back(it->second);
      }
      q.count = values.size();
      if (!values.empty()) q.p10 = quantile(values, 0.1), q.p50 = quantile(values, 0.5), q.p90 = quantile(values, 0.9);
      if (q.count + q.never > 0) s.quantiles[layout][metric] = q;
    }
}

}  // namespace

std::optional<MemberName> split_member_name(const std::string& variant) {
  static const std::regex pattern(R"(^(.+)-e([0-9]{3,})$)");
  std::smatch m;
  if (!std::regex_match(variant, m, pattern)) return std::nullopt;
  return MemberName{m[1].str(), std::stoi(m[2].str())};
}

double quantile(std::vector<double> values, double p) {
  if (values.empty()) throw std::invalid_argument("quantile: no values");
  if (!(p >= 0.0 && p <= 1.0)) throw std::invalid_argument("quantile: p must be in [0, 1]");
  std::sort(values.begin(), values.end());
  const double h = (static_cast<double>(values.size()) - 1.0) * p;
  const size_t lo = static_cast<size_t>(std::floor(h));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (h - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

std::optional<EnsembleSummary> summarise_ensemble(const RunStore& store, const std::string& sweep,
                                                  const std::string& fidelity) {
  std::map<std::string, int64_t> latest;  // variant -> latest completed run
  for (const auto& r : store.list_runs(sweep))
    if (r.status == "completed" && split_member_name(r.variant) && (fidelity.empty() || r.fidelity == fidelity))
      latest[r.variant] = r.id;
  return summarise_ensemble_runs(store, sweep, latest);
}

std::optional<EnsembleSummary> summarise_ensemble_runs(const RunStore& store, const std::string& sweep,
                                                       const std::map<std::string, int64_t>& runs) {
  std::map<std::string, int64_t> latest;
  for (const auto& [variant, id] : runs)
    if (split_member_name(variant)) latest[variant] = id;
  if (latest.empty()) return std::nullopt;
  EnsembleSummary s;
  s.sweep = sweep;
  std::set<std::string> layouts;
  MemberMetrics all;
  std::set<std::string> names;
  for (const auto& [variant, id] : latest) {
    const MemberName mn = *split_member_name(variant);
    layouts.insert(mn.layout);
    auto& m = all[mn.member][mn.layout] = store.metrics(id);
    for (const auto& kv : m) names.insert(kv.first);
  }
  s.layouts.assign(layouts.begin(), layouts.end());
  std::sort(s.layouts.begin(), s.layouts.end(), natural_less);
  MemberMetrics complete;
  for (auto& [member, by_layout] : all)
    if (by_layout.size() == s.layouts.size()) complete[member] = std::move(by_layout);
  s.members = complete.size();
  s.incomplete = all.size() - complete.size();
  const DecisionMetrics decision(std::vector<std::string>(names.begin(), names.end()));
  s.ranking_metric = decision.ranking_metric();
  s.metrics = decision.order(std::vector<std::string>(names.begin(), names.end()), false);
  add_quantiles(s, complete);
  for (const auto& l : s.layouts) s.first_share[l] = 0.0;
  if (!s.ranking_metric.empty())
    for (const auto& [member, by_layout] : complete) {
      const auto firsts = first_places(by_layout, s.ranking_metric);
      if (firsts.empty()) continue;
      ++s.ranked_members;
      for (const auto& l : firsts) s.first_share[l] += 1.0 / static_cast<double>(firsts.size());
    }
  if (s.ranked_members > 0)
    for (auto& [l, share] : s.first_share) share /= static_cast<double>(s.ranked_members);
  return s;
}

std::string ensemble_summary_json(const EnsembleSummary& s) {
  json out = {{"sweep", s.sweep},
              {"layouts", s.layouts},
              {"members", s.members},
              {"incomplete", s.incomplete},
              {"ranking_metric", s.ranking_metric.empty() ? json(nullptr) : json(s.ranking_metric)},
              {"ranked_members", s.ranked_members},
              {"layouts_detail", json::object()}};
  for (const auto& l : s.layouts) {
    json metrics = json::object();
    const auto q = s.quantiles.find(l);
    for (const auto& name : s.metrics) {
      if (q == s.quantiles.end() || !q->second.count(name)) continue;
      const MetricQuantiles& m = q->second.at(name);
      const bool any = m.count > 0;
      metrics[name] = {{"p10", any ? json(m.p10) : json(nullptr)},
                       {"p50", any ? json(m.p50) : json(nullptr)},
                       {"p90", any ? json(m.p90) : json(nullptr)},
                       {"count", m.count},
                       {"never", m.never}};
    }
    out["layouts_detail"][l] = {{"first_share", s.first_share.at(l)}, {"metrics", metrics}};
  }
  return out.dump(2);
}

}  // namespace runout
