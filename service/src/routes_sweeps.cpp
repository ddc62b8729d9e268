// Routes: /sweeps: submit a sweep and its jobs in one transaction, list the sweeps, follow one (server_impl.hpp,
// docs/service.md).
#include "server_impl.hpp"

#include "runout/scenarios/ensemble_summary.hpp"
#include "runout/scenarios/report.hpp"

namespace runout::service {

namespace {

// A sweep with its jobs counted by status. `status`: running while a job is queued or running (or a study's
// detailed stage is still to be decided), done when every job is done, incomplete when all finished but some
// failed or were cancelled.
json sweep_summary(const SweepRow& s, const std::map<std::string, int64_t>& counts) {
  json by_status = {{"queued", 0}, {"running", 0}, {"done", 0}, {"failed", 0}, {"cancelled", 0}};
  int64_t total = 0;
  for (const auto& [status, n] : counts) {
    by_status[status] = n;
    total += n;
  }
  const int64_t active = by_status["queued"].get<int64_t>() + by_status["running"].get<int64_t>();
  const bool undecided = s.study && !s.study_released;  // a study's detailed stage is still to come
  const std::string status = active > 0 || undecided                      ? "running"
                             : by_status["done"].get<int64_t>() == total ? "done"
                                                                          : "incomplete";
  const std::string self = kPrefix + "/sweeps/" + std::to_string(s.id);
  return {{"id", s.id},
          {"name", s.name},
          {"scene_id", s.scene_id ? json(*s.scene_id) : json(nullptr)},
          {"fidelity", s.fidelity},
          {"created_at", s.created_at},
          {"status", status},
          {"study", s.study},
          {"jobs_total", total},
          {"jobs_by_status", by_status},
          {"links", {{"self", self}, {"jobs", kPrefix + "/jobs?sweep=" + std::to_string(s.id)}}}};
}

}  // namespace

// An ensemble sweep's summary over its done jobs (scenarios/ensemble_summary.hpp: each layout's decision metrics
// as p10/p50/p90 over the members with every layout done, and its share of first places); null for a sweep
// whose variants are not ensemble members or with no done member.
json Server::Impl::ensemble_of(const std::vector<Job>& jobs, const std::string& sweep) const {
  std::map<std::string, int64_t> runs;
  for (const auto& j : jobs)
    if (j.status == "done" && j.run_id && split_member_name(j.variant)) runs[j.variant] = *j.run_id;
  const auto summary = summarise_ensemble_runs(*store, sweep, runs);
  return summary ? json::parse(ensemble_summary_json(*summary)) : json(nullptr);
}

void Server::Impl::routes_sweeps() {
  add("/sweeps", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    const auto hkey = header_key(req);
    std::optional<std::string> bkey;
    NewSweep s = parse_sweep_request(req.body, limits, *queue, bkey);
    const std::string who = authorize(req);
    double requested = 0;
    for (auto& j : s.jobs) {
      j.cpu_seconds = cpu_seconds(j);
      j.submitted_by = who;
      requested += j.cpu_seconds;
    }
    std::optional<std::string> plan;  // a study: its detailed stage's every candidate counts against the budget
    if (s.study) {
      for (auto& j : s.study->candidates) {
        j.cpu_seconds = cpu_seconds(j);
        j.submitted_by = who;
        requested += j.cpu_seconds;
      }
      plan = study_plan_json(s);
    }
    // Handed to the operator's MPI launch command (sweep_launcher.hpp); a study's stages run on the workers,
    // which decide between them.
    std::optional<std::string> launched;
    if (launcher && !s.study) launched = fs::absolute(opt.runs_dir / "service").string();
    auto [row, created] = queue->submit_sweep(s.name, s.scene_id, s.fidelity, s.jobs, pick_key(hkey, bkey), launched,
                                              budget_check(requested), plan);
    if (created && launched) {
      try {
        launcher->launch({row.id, s.name, s.base_json, s.variants, s.ensemble_json, s.fidelity, s.jobs.front().dp});
      } catch (const std::exception& e) {  // its jobs must not stay `running` for ever
        spdlog::error("sweep {}: could not launch: {}", row.id, e.what());
        for (const auto& j : queue->list(std::nullopt, row.id, 10000, 0))
          queue->finish(j.id, "failed", std::nullopt, false, std::string("could not launch the sweep: ") + e.what());
      }
    } else if (created) {
      wake.notify_all();
    }
    json jobs = json::array();
    const auto rows = queue->list(std::nullopt, row.id, 10000, 0);
    for (const auto& j : rows) jobs.push_back(job_json(j, false));
    res.set_header("Location", kPrefix + "/sweeps/" + std::to_string(row.id));
    send_json(res, created ? 201 : 200,
              {{"id", row.id},
               {"name", row.name},
               {"scene_id", row.scene_id ? json(*row.scene_id) : json(nullptr)},
               {"fidelity", row.fidelity},
               {"created_at", row.created_at},
               {"jobs", jobs},
               {"study", row.study ? study_of(row, rows) : json(nullptr)}});
  });
  // The sweeps submitted, newest first, a page at a time.
  add("/sweeps", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    FieldErrors errors;
    only_params(req, {"limit", "cursor"}, errors);
    const PageRequest page = page_request(req, 100, 1000, errors);
    errors.raise();
    auto rows = queue->list_sweeps(page.limit + 1, page.cursor);  // one more: is there a next page?
    const std::optional<int64_t> next_key = trim_page(rows, page.limit);
    json list = json::array();
    if (!rows.empty()) {
      const auto counts = queue->sweep_job_counts(rows.back().id, rows.front().id);
      for (const auto& s : rows) {
        auto it = counts.find(s.id);
        list.push_back(sweep_summary(s, it == counts.end() ? std::map<std::string, int64_t>{} : it->second));
      }
    }
    const json next = next_page(req, res, next_key);
    send_json(res, 200, {{"sweeps", list}, {"limit", page.limit}, {"next", next}});
  });
  // One sweep: its variants with their jobs' status and progress; once every job is done, the comparison.
  add(R"(/sweeps/(\d{1,18}))", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const int64_t id = std::stoll(m[1].str());
    const auto row = queue->get_sweep(id);
    if (!row) throw ApiError(404, "id", "no sweep with id " + m[1].str());
    const auto counts = queue->sweep_job_counts(id, id);
    json out = sweep_summary(*row, counts.count(id) ? counts.at(id) : std::map<std::string, int64_t>{});
    json variants = json::array();
    double fraction = 0;
    const auto jobs = queue->list(std::nullopt, id, 100000, 0);  // at most 1024 (a sweep's variants)
    for (const auto& j : jobs) {
      const json jj = job_json(j, false);
      fraction += sweep_share(j);
      variants.push_back({{"variant", j.variant},
                          {"stage", jj["stage"]},
                          {"job", j.id},
                          {"status", j.status},
                          {"progress", jj["progress"]},
                          {"run_id", jj["run_id"]},
                          {"error", j.error},
                          {"links", jj["links"]}});
    }
    out["progress"] = {{"fraction", jobs.empty() ? 1.0 : fraction / static_cast<double>(jobs.size())}};
    out["variants"] = variants;
    // Read once the sweep has finished: a poll of a running sweep must not read every member's metrics.
    out["ensemble"] = out["status"] != "running" ? ensemble_of(jobs, row->name) : json(nullptr);
    out["study"] = row->study ? study_of(*row, jobs) : json(nullptr);
    out["links"]["compare"] =
        out["status"] == "done" && !jobs.empty() ? json(kPrefix + "/compare?sweep=" + m[1].str()) : json(nullptr);
    send_json(res, 200, out);
  });
  // The sweep's study report (scenarios/report.hpp): one self-contained HTML page of its done jobs' runs, the
  // baseline its first variant or ?baseline=<variant>.
  add(R"(/sweeps/(\d{1,18})/report\.html)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {"baseline"});
        const int64_t id = std::stoll(m[1].str());
        const auto row = queue->get_sweep(id);
        if (!row) throw ApiError(404, "id", "no sweep with id " + m[1].str());
        StudyReportInput in;
        in.title = row->name;
        std::string variants;
        const std::string baseline = req.has_param("baseline") ? req.get_param_value("baseline") : std::string();
        for (const auto& j : queue->list(std::nullopt, id, 100000, 0)) {
          variants += (variants.empty() ? "" : ", ") + j.variant;
          if (j.status != "done" || !j.run_id) continue;
          in.runs.push_back({*j.run_id, j.variant, out_dir_of(j), j.out_dir});
          if (baseline.empty() ? in.baseline_id == 0 : j.variant == baseline) in.baseline_id = *j.run_id;
        }
        if (in.runs.empty())
          throw ApiError(409, "status", "sweep " + m[1].str() + " has no done job yet; its report exists once one is done");
        if (in.baseline_id == 0)
          throw ApiError(baseline.empty() ? 409 : 400, "baseline",
                         "'" + baseline + "' is not a done variant of sweep " + m[1].str() + " (its variants: " +
                             variants + ")");
        res.status = 200;
        res.set_content(study_report_html(*store, in), "text/html; charset=utf-8");
      });
}

}  // namespace runout::service
