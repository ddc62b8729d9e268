// Routes: GET /compare: stored metrics of done jobs side by side (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_compare() {
  add("/compare", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {"jobs", "baseline"});
    if (!req.has_param("jobs")) throw ApiError(400, "jobs", "missing (required: 1 to 50 job ids separated by commas)");
    std::vector<int64_t> ids;
    std::stringstream ss(req.get_param_value("jobs"));
    for (std::string part; std::getline(ss, part, ',');) ids.push_back(int_param("jobs", part, 1, INT64_MAX / 2));
    if (ids.empty() || ids.size() > 50) throw ApiError(400, "jobs", "must list 1 to 50 job ids separated by commas");
    const int64_t base_id =
        req.has_param("baseline") ? int_param("baseline", req.get_param_value("baseline"), 1, INT64_MAX / 2) : ids.front();
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
      runs.push_back(run_for(id, "jobs"));
    }
    const Comparison c = compare_runs(*store, runs, base_run);
    auto num = [](const std::optional<double>& v) -> json { return v ? json(*v) : json(nullptr); };
    json rows = json::array();
    for (const auto& r : c.rows) {
      json values = json::array(), diffs = json::array(), pct = json::array();
      for (size_t k = 0; k < r.values.size(); ++k) {
        values.push_back(num(r.values[k]));
        diffs.push_back(r.values[k] && r.baseline ? json(*r.values[k] - *r.baseline) : json(nullptr));
        pct.push_back(num(r.percent[k]));
      }
      rows.push_back({{"metric", r.metric}, {"baseline", num(r.baseline)}, {"values", values}, {"difference", diffs},
                      {"percent", pct}});
    }
    json columns = json::array();
    for (size_t k = 0; k < job_ids.size(); ++k) columns.push_back({{"job", job_ids[k]}, {"run_id", runs[k]}, {"label", c.runs[k]}});
    send_json(res, 200,
              {{"baseline", {{"job", base_id}, {"run_id", base_run}, {"label", c.baseline}}},
               {"jobs", columns},
               {"metrics", rows}});
  });
}

}  // namespace runout::service
