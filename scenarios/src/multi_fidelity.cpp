// The multi-fidelity study: screen an ensemble, choose the layouts that can still be best, run those in 3D at the
// median material (multi_fidelity.hpp).
#include "runout/scenarios/multi_fidelity.hpp"

#include <algorithm>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "runout/scenarios/decision_metrics.hpp"
#include "runout/scenarios/scene.hpp"

namespace runout {
namespace {

using json = nlohmann::ordered_json;

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

std::string fidelity_name(const Fidelity& f) { return f.dp ? "custom" : f.name; }

// The 3D runs' ranking: lowest value first, values equal as printed by name, layouts without a value last.
std::vector<std::string> ranked(const std::map<std::string, std::optional<double>>& value) {
  std::vector<std::string> out;
  for (const auto& [l, v] : value) out.push_back(l);
  std::stable_sort(out.begin(), out.end(), [&](const std::string& a, const std::string& b) {
    const auto& va = value.at(a);
    const auto& vb = value.at(b);
    if (va && vb && num(*va) != num(*vb)) return *va < *vb;
    if (va.has_value() != vb.has_value()) return va.has_value();
    return natural_less(a, b);
  });
  return out;
}

}  // namespace

LayoutSelection select_layouts(const EnsembleSummary& s, const std::string& baseline) {
  LayoutSelection out;
  const std::string& key = s.ranking_metric;
  auto q = [&](const std::string& l) -> const MetricQuantiles* {
    const auto it = s.quantiles.find(l);
    if (key.empty() || it == s.quantiles.end() || !it->second.count(key) || it->second.at(key).count == 0) return nullptr;
    return &it->second.at(key);
  };
  for (const auto& l : s.layouts)
    if (q(l) && (out.leader.empty() || q(l)->p50 < q(out.leader)->p50)) out.leader = l;
  for (const auto& l : s.layouts) {
    const MetricQuantiles* m = q(l);
    std::string why;
    if (l == out.leader) why = "the leader (lowest median " + num(m->p50) + ")";
    else if (!m) why = "no screening value of the ranking metric: kept";
    else if (m->p10 <= q(out.leader)->p90)
      why = "can still be best: p10 " + num(m->p10) + " <= the leader's p90 " + num(q(out.leader)->p90);
    if (why.empty() && l == baseline) why = "the baseline";
    if (!why.empty()) out.chosen.push_back(l);
    else why = "dropped: p10 " + num(m->p10) + " > the leader's p90 " + num(q(out.leader)->p90);
    out.why[l] = why;
  }
  return out;
}

std::vector<ParameterValue> median_member(const Ensemble& e) {
  std::vector<ParameterValue> out;
  for (const auto& p : e.parameters)
    out.push_back({p.pointer, p.distribution.empty() ? quantile(p.values, 0.5) : parameter_quantile(p, 0.5)});
  return out;
}

Sweep median_sweep(const Sweep& ensemble_sweep, const std::vector<std::string>& layouts) {
  Sweep out = ensemble_sweep;
  out.name = ensemble_sweep.name + "-median";
  out.ensemble.reset();
  out.variants.clear();
  const auto median = ensemble_sweep.ensemble ? median_member(*ensemble_sweep.ensemble) : std::vector<ParameterValue>{};
  for (const auto& l : layouts)
    for (const auto& v : ensemble_sweep.variants)
      if (v.layout == l) {
        out.variants.push_back({l, v.structures, median, l, -1});
        break;
      }
  return out;
}

MultiFidelityResult screening_outcome(const Sweep& sweep, const EnsembleSummary& summary) {
  MultiFidelityResult r;
  r.screening = summary;
  r.ranking_metric = summary.ranking_metric;
  r.selection = select_layouts(summary, sweep.variants.front().layout);
  r.detailed_sweep = median_sweep(sweep, r.selection.chosen);
  for (const auto& v : r.detailed_sweep.variants) {
    const auto qs = summary.quantiles.find(v.name);
    r.screening_p50[v.name] = std::nullopt;
    if (qs != summary.quantiles.end() && qs->second.count(r.ranking_metric) && qs->second.at(r.ranking_metric).count)
      r.screening_p50[v.name] = qs->second.at(r.ranking_metric).p50;
  }
  return r;
}

void set_detailed_values(MultiFidelityResult& r, const std::map<std::string, std::optional<double>>& values) {
  r.detailed_value.clear();
  for (const auto& v : r.detailed_sweep.variants)
    r.detailed_value[v.name] = values.count(v.name) ? values.at(v.name) : std::nullopt;
  r.detailed_ranking = ranked(r.detailed_value);
}

MultiFidelityResult run_multi_fidelity_study(RunStore& store, const Sweep& sweep, const MultiFidelityOptions& options) {
  if (!sweep.ensemble) throw SceneError("ensemble", "a multi-fidelity study needs a sweep with an ensemble");
  SweepOptions first = options.run;
  first.fidelity_override = true;
  first.fidelity = options.screening;
  (void)run_sweep(store, sweep, first);
  const bool stopped = options.run.stop && options.run.stop->load();
  const auto summary = summarise_ensemble(store, sweep.name, fidelity_name(options.screening));
  if (!summary || stopped) {
    MultiFidelityResult r;
    r.stopped = stopped;
    return r;
  }
  MultiFidelityResult r = screening_outcome(sweep, *summary);
  SweepOptions second = options.run;
  second.fidelity_override = true;
  second.fidelity = options.detailed;
  r.detailed = run_sweep(store, r.detailed_sweep, second);
  r.stopped = options.run.stop && options.run.stop->load();
  std::map<std::string, std::optional<double>> values;
  for (size_t k = 0; k < r.detailed_sweep.variants.size(); ++k) {
    if (r.detailed.runs[k].status != "completed") continue;
    const auto m = store.metrics(r.detailed.runs[k].run_id);
    if (const auto it = m.find(r.ranking_metric); it != m.end()) values[r.detailed_sweep.variants[k].name] = it->second;
  }
  set_detailed_values(r, values);
  return r;
}

std::string multi_fidelity_json(const MultiFidelityResult& r) {
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  json layouts = json::array();
  for (const auto& l : r.screening.layouts) {
    const bool chosen = std::find(r.selection.chosen.begin(), r.selection.chosen.end(), l) != r.selection.chosen.end();
    json row = {{"layout", l}, {"chosen", chosen}, {"why", r.selection.why.count(l) ? r.selection.why.at(l) : ""},
                {"first_share", r.screening.first_share.count(l) ? r.screening.first_share.at(l) : 0.0}};
    if (chosen) {
      row["screening_p50"] = r.screening_p50.count(l) ? opt(r.screening_p50.at(l)) : json(nullptr);
      row["detailed"] = r.detailed_value.count(l) ? opt(r.detailed_value.at(l)) : json(nullptr);
    }
    layouts.push_back(row);
  }
  json median = json::array();
  for (const auto& v : r.detailed_sweep.variants.empty() ? std::vector<ParameterValue>{} : r.detailed_sweep.variants.front().parameters)
    median.push_back({{"pointer", v.pointer}, {"value", v.value}});
  return json{{"sweep", r.screening.sweep},
              {"members", r.screening.members},
              {"ranking_metric", r.ranking_metric},
              {"leader", r.selection.leader},
              {"median_member", median},
              {"detailed_sweep", r.detailed_sweep.name},
              {"layouts", layouts},
              {"ranking", r.detailed_ranking},
              {"stopped", r.stopped}}
      .dump(2);
}

}  // namespace runout
