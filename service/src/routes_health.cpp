// Routes: GET /health and GET /openapi.json (server_impl.hpp, docs/service.md).
#include "server_impl.hpp"

#include "runout/scenarios/schema.hpp"

namespace runout::service {

void Server::Impl::routes_health() {
  add("/health", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    // Answered on a thread of its own (http_front.hpp) from a database connection of its own (jobs.hpp).
    json counts = queue->counts_by_status();
    const Backlog b = queue->backlog("");
    const double rate = std::max(1, opt.workers) * std::max(1, threads_per_job);
    const FrontStats f = front ? front->stats() : FrontStats{};
    send_json(res, 200,
              {{"status", "ok"},
               {"version", RUNOUT_VERSION},
               {"schema_version", store->schema_version()},
               {"workers", opt.workers},
               {"busy_workers", busy.load()},
               {"threads_per_job", threads_per_job},
               {"particle_budget", opt.particle_budget},
               {"auth", tokens.empty() ? "open" : "bearer token for writes"},
               {"jobs", counts},
               {"shipped_studies", shipped_status()},
               {"backlog",
                {{"jobs", b.jobs},
                 {"cpu_seconds", b.total_cpu_s},
                 {"drain_seconds_estimate", opt.workers > 0 ? json(b.total_cpu_s / rate) : json(nullptr)},
                 {"budget_token_cpu_s", opt.budget_token_cpu_s},
                 {"budget_total_cpu_s", opt.budget_total_cpu_s}}},
               {"connections",
                {{"open", f.open_connections},
                 {"refused", f.refused_connections},
                 {"timed_out", f.timed_out},
                 {"pending_requests", f.pending},
                 {"max_connections", opt.max_connections},
                 {"max_connections_per_client", opt.max_connections_per_client}}},
               {"limits",
                {{"max_body", opt.max_body},
                 {"max_json_depth", kMaxJsonDepth},
                 {"header_timeout_s", opt.header_timeout},
                 {"body_timeout_s", opt.body_timeout},
                 {"idle_timeout_s", opt.idle_timeout}}}});
  });
  // The scene format's JSON Schema, from the models' descriptors (the OpenAPI Scene refers to it).
  add("/schema/scene", "GET", [](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    res.status = 200;
    res.set_content(scene_schema().dump(), "application/schema+json");
  });
  add("/openapi.json", "GET", [](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    res.status = 200;
    res.set_content(openapi_json(), "application/json");
  });
}

}  // namespace runout::service
