// Routes: POST /sweeps: a sweep and its jobs in one transaction (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

namespace runout::service {

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
    std::optional<std::string> launched;  // handed to the operator's MPI launch command (sweep_launcher.hpp)
    if (launcher) launched = fs::absolute(opt.runs_dir / "service").string();
    auto [row, created] = queue->submit_sweep(s.name, s.scene_id, s.fidelity, s.jobs, pick_key(hkey, bkey), launched,
                                              budget_check(requested));
    if (created && launcher) {
      try {
        launcher->launch({row.id, s.name, s.base_json, s.variants, s.fidelity, s.jobs.front().dp});
      } catch (const std::exception& e) {  // its jobs must not stay `running` for ever
        spdlog::error("sweep {}: could not launch: {}", row.id, e.what());
        for (const auto& j : queue->list(std::nullopt, row.id, 10000, 0))
          queue->finish(j.id, "failed", std::nullopt, false, std::string("could not launch the sweep: ") + e.what());
      }
    } else if (created) {
      wake.notify_all();
    }
    json jobs = json::array();
    for (const auto& j : queue->list(std::nullopt, row.id, 10000, 0)) jobs.push_back(job_json(j, false));
    res.set_header("Location", kPrefix + "/jobs?sweep=" + std::to_string(row.id));
    send_json(res, created ? 201 : 200,
              {{"id", row.id},
               {"name", row.name},
               {"scene_id", row.scene_id ? json(*row.scene_id) : json(nullptr)},
               {"fidelity", row.fidelity},
               {"created_at", row.created_at},
               {"jobs", jobs}});
  });
}

}  // namespace runout::service
