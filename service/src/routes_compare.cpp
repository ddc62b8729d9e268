// Routes: GET /compare: stored metrics of done jobs (listed, or a sweep's) side by side (server_impl.hpp, docs/service.md).
#include "runout/scenarios/decision_metrics.hpp"
#include "server_impl.hpp"

namespace runout::service {
namespace {

// Every layout of the comparison (the baseline among them) ranked by `metric`, lowest first (less discharge
// at the outlet is the better layout); those without a value last, ties in the order given. Null without a
// ranking metric (no cross-section among the metrics). Equal values share a rank.
json ranking(const Comparison& c, const std::string& metric, int64_t base_job, const std::vector<int64_t>& job_ids) {
  if (metric.empty()) return nullptr;
  const auto row = std::find_if(c.rows.begin(), c.rows.end(), [&](const Comparison::Row& r) { return r.metric == metric; });
  struct Entry {
    int64_t job;
    std::string label;
    std::optional<double> value;
  };
  std::vector<Entry> entries{{base_job, c.baseline, row != c.rows.end() ? row->baseline : std::nullopt}};
  for (size_t k = 0; k < job_ids.size(); ++k)
    entries.push_back({job_ids[k], c.runs[k], row != c.rows.end() ? row->values[k] : std::nullopt});
  std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    if (a.value.has_value() != b.value.has_value()) return a.value.has_value();
    return a.value && *a.value < *b.value;
  });
  // Equal values share a rank (1, 1, 3): a key that cannot tell layouts apart must not seem to.
  json layouts = json::array();
  size_t rank = 1;
  for (size_t k = 0; k < entries.size(); ++k) {
    if (k > 0 && entries[k].value != entries[k - 1].value) rank = k + 1;
    layouts.push_back({{"rank", rank},
                       {"job", entries[k].job},
                       {"label", entries[k].label},
                       {"baseline", entries[k].job == base_job},
                       {"value", entries[k].value ? json(*entries[k].value) : json(nullptr)}});
  }
  return {{"metric", metric}, {"order", "ascending"}, {"unit", "m3/s"},
          {"key", "the outlet's peak discharge, lowest first"}, {"layouts", layouts}};
}

}  // namespace

// The sweep every compared job belongs to, with its report's URL (the baseline's variant as the report's
// baseline); null when they are not all of one sweep.
json Server::Impl::sweep_of(int64_t base_job, const std::vector<int64_t>& job_ids) const {
  std::optional<int64_t> sweep;
  std::string variant;
  for (size_t k = 0; k <= job_ids.size(); ++k) {
    const auto j = queue->get(k == 0 ? base_job : job_ids[k - 1]);
    if (!j || !j->sweep_id || (sweep && *sweep != *j->sweep_id)) return nullptr;
    sweep = j->sweep_id;
    if (k == 0) variant = j->variant;
  }
  const auto row = queue->get_sweep(*sweep);
  if (!row) return nullptr;
  httplib::Params q{{"baseline", variant}};
  return {{"id", row->id}, {"name", row->name},
          {"report", kPrefix + "/sweeps/" + std::to_string(row->id) + "/report.html?" + httplib::detail::params_to_query_str(q)}};
}

void Server::Impl::routes_compare() {
  add("/compare", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    FieldErrors errors;
    only_params(req, {"jobs", "sweep", "baseline"}, errors);
    std::vector<int64_t> ids;
    std::optional<int64_t> sweep;
    if (req.has_param("jobs") == req.has_param("sweep"))
      errors.add(ApiError(400, "jobs", "give one of jobs (1 to 50 job ids separated by commas) or sweep (a sweep's id)"));
    else if (req.has_param("jobs"))
      errors.check([&] {
        std::stringstream ss(req.get_param_value("jobs"));
        for (std::string part; std::getline(ss, part, ',');) ids.push_back(int_param("jobs", part, 1, INT64_MAX / 2));
        if (ids.empty() || ids.size() > 50) throw ApiError(400, "jobs", "must list 1 to 50 job ids separated by commas");
      });
    else
      errors.check([&] { sweep = int_param("sweep", req.get_param_value("sweep"), 1, INT64_MAX / 2); });
    std::optional<int64_t> baseline;
    if (req.has_param("baseline"))
      errors.check([&] { baseline = int_param("baseline", req.get_param_value("baseline"), 1, INT64_MAX / 2); });
    errors.raise();
    if (sweep) {  // every job of the sweep, its first variant the default baseline
      if (!queue->get_sweep(*sweep)) throw ApiError(404, "sweep", "no sweep with id " + std::to_string(*sweep));
      for (const auto& j : queue->list(std::nullopt, *sweep, 100000, 0)) ids.push_back(j.id);
      if (ids.empty()) throw ApiError(404, "sweep", "sweep " + std::to_string(*sweep) + " has no jobs");
    }
    const int64_t base_id = baseline ? *baseline : ids.front();
    const char* jobs_field = sweep ? "sweep" : "jobs";
    auto run_for = [&](int64_t id, const char* field) {
      auto j = queue->get(id);
      if (!j) throw ApiError(404, field, "no job with id " + std::to_string(id));
      if (j->status != "done" || !j->run_id)
        throw ApiError(409, field, "job " + std::to_string(id) + " is " + j->status + " (accepted: done jobs)");
      return *j->run_id;
    };
    const int64_t base_run = run_for(base_id, "baseline");
    std::vector<int64_t> job_ids, runs;
    for (int64_t id : ids) {
      if (id == base_id) continue;
      job_ids.push_back(id);
      runs.push_back(run_for(id, jobs_field));
    }
    const Comparison c = compare_runs(*store, runs, base_run);
    // The decision metrics first, by rank (decision_metrics.hpp, as `runout compare` lists them), then the rest
    // in the store's order (by name); the layouts ranked by the first of them, the outlet's peak discharge.
    std::vector<std::string> names;
    std::map<std::string, const Comparison::Row*> by_name;
    for (const auto& r : c.rows) names.push_back(r.metric), by_name[r.metric] = &r;
    const DecisionMetrics decision(names);
    auto num = [](const std::optional<double>& v) -> json { return v ? json(*v) : json(nullptr); };
    json rows = json::array();
    for (const auto& name : decision.order(names, true)) {
      const Comparison::Row& r = *by_name.at(name);
      json values = json::array(), diffs = json::array(), pct = json::array();
      for (size_t k = 0; k < r.values.size(); ++k) {
        values.push_back(num(r.values[k]));
        diffs.push_back(r.values[k] && r.baseline ? json(*r.values[k] - *r.baseline) : json(nullptr));
        pct.push_back(num(r.percent[k]));
      }
      // An arrival that never happened: null, with its flag in never / baseline_never (docs/service.md).
      // label and better come from decision_metrics.hpp, so the page, the report and the CLI agree on both.
      const bool is_decision = decision.is_decision(r.metric);
      const json better = !is_decision ? json(nullptr)
                          : DecisionMetrics::higher_is_better(r.metric) ? json("higher") : json("lower");
      rows.push_back({{"metric", r.metric}, {"label", decision.label(r.metric)}, {"decision", is_decision},
                      {"better", better}, {"baseline", num(r.baseline)}, {"baseline_never", r.baseline_never},
                      {"values", values}, {"never", r.never}, {"difference", diffs}, {"percent", pct}});
    }
    json columns = json::array();
    for (size_t k = 0; k < job_ids.size(); ++k) columns.push_back({{"job", job_ids[k]}, {"run_id", runs[k]}, {"label", c.runs[k]}});
    send_json(res, 200,
              {{"baseline", {{"job", base_id}, {"run_id", base_run}, {"label", c.baseline}}},
               {"sweep", sweep_of(base_id, job_ids)},
               {"jobs", columns},
               {"outlet", decision.outlet().empty() ? json(nullptr) : json(decision.outlet())},
               {"ranking", ranking(c, decision.ranking_metric(), base_id, job_ids)},
               {"metrics", rows}});
  });
}

}  // namespace runout::service
