// Routes: /jobs: submit, list, get, cancel (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

void Server::Impl::routes_jobs() {
  // Jobs.
  add("/jobs", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    const auto hkey = header_key(req);
    std::optional<std::string> bkey;
    JobSpec spec = parse_job_request(req.body, limits, *queue, bkey);
    spec.cpu_seconds = cpu_seconds(spec);
    spec.submitted_by = authorize(req);
    auto [job, created] = queue->submit(spec, pick_key(hkey, bkey), budget_check(spec.cpu_seconds));
    if (created) wake.notify_one();
    res.set_header("Location", kPrefix + "/jobs/" + std::to_string(job.id));
    send_json(res, created ? 201 : 200, job_json(job, false));
  });
  add("/jobs", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    // Every invalid parameter is reported; an unknown sweep (404) only once the parameters are valid.
    FieldErrors errors;
    only_params(req, {"status", "sweep", "limit", "offset", "cursor"}, errors);
    std::optional<std::string> status;
    std::optional<int64_t> sweep;
    if (req.has_param("status"))
      errors.check([&] {
        status = req.get_param_value("status");
        if (!kStates.count(*status))
          throw ApiError(400, "status", "unknown status '" + status->substr(0, 40) +
                                            "' (accepted: queued, running, done, failed, cancelled)");
      });
    if (req.has_param("sweep"))
      errors.check([&] { sweep = int_param("sweep", req.get_param_value("sweep"), 1, INT64_MAX / 2); });
    const PageRequest page = page_request(req, 1000, 10000, errors);
    int64_t offset = 0;
    if (req.has_param("offset"))
      errors.check([&] {
        offset = int_param("offset", req.get_param_value("offset"), 0, INT64_MAX / 2);
        if (page.cursor) throw ApiError(400, "offset", "given with cursor (accepted: one of the two)");
      });
    errors.raise();
    if (sweep && !queue->get_sweep(*sweep)) throw ApiError(404, "sweep", "no sweep with id " + std::to_string(*sweep));
    auto rows = queue->list(status, sweep, page.limit + 1, offset, page.cursor);  // one more: a next page?
    const std::optional<int64_t> next_key = trim_page(rows, page.limit);
    json list = json::array();
    for (const auto& j : rows) list.push_back(job_json(j, false));
    const json next = next_page(req, res, next_key);
    send_json(res, 200,
              {{"total", queue->count(status, sweep)}, {"limit", page.limit}, {"offset", offset}, {"jobs", list},
               {"next", next}});
  });
  add(R"(/jobs/(\d{1,18}))", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    send_json(res, 200, job_json(require_job(m[1].str()), true));
  });
  add(R"(/jobs/(\d{1,18}))", "DELETE", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const int64_t id = std::stoll(m[1].str());
    auto r = queue->cancel(id);
    if (!r) throw ApiError(404, "id", "no job with id " + m[1].str());
    auto [outcome, job] = *r;
    switch (outcome) {
      case JobQueue::CancelOutcome::cancelled:
      case JobQueue::CancelOutcome::already_cancelled:
        send_json(res, 200, job_json(job, false));
        return;
      case JobQueue::CancelOutcome::requested: {
        std::lock_guard lock(mutex);
        if (auto it = running.find(id); it != running.end()) {
          it->second->cancel = true;
          it->second->stop = true;
        }
        send_json(res, 202, job_json(job, false));
        return;
      }
      case JobQueue::CancelOutcome::finished:
        throw ApiError(409, "status", "job " + m[1].str() + " is already " + job.status +
                                          " (accepted: a queued or running job)");
    }
  });
}

}  // namespace runout::service
