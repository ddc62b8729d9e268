// The HTTP service (server.hpp, docs/service.md).
#include "server.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

// The project's headers (Eigen) before httplib.h: httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen.
#include "jobs.hpp"
#include "runout/scenarios/cost_model.hpp"
#include "requests.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/terrain/raster.hpp"
#include "sweep_launcher.hpp"
#include "web_files.hpp"

#include "http_front.hpp"  // httplib.h
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#ifndef RUNOUT_VERSION
#define RUNOUT_VERSION "unknown"
#endif

namespace runout::service {

namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const std::string kPrefix = "/api/v1";
const std::set<std::string> kStates = {"queued", "running", "done", "failed", "cancelled"};

std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

void send_json(httplib::Response& res, int status, const json& j) {
  res.status = status;
  res.set_content(dump(j), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& field, const std::string& message) {
  send_json(res, status, {{"error", {{"status", status}, {"field", field}, {"message", message}}}});
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

json job_json(const Job& j, bool full) {
  auto or_null = [](const auto& o) -> json { return o ? json(*o) : json(nullptr); };
  json progress = {{"simulated_time", j.sim_time},
                   {"duration", j.duration},
                   {"fraction", j.duration > 0 ? std::min(1.0, j.sim_time / j.duration) : 0.0},
                   {"steps", j.steps},
                   {"wall_seconds", j.wall_seconds},
                   {"eta_seconds", or_null(j.eta_seconds)}};
  const std::string self = kPrefix + "/jobs/" + std::to_string(j.id);
  json out = {{"id", j.id},
              {"status", j.status},
              {"scene_name", j.scene_name},
              {"scene_id", or_null(j.scene_id)},
              {"fidelity", j.fidelity},
              {"dp", or_null(j.dp)},
              {"sweep_id", or_null(j.sweep_id)},
              {"sweep", j.sweep},
              {"variant", j.variant},
              {"particles", j.particles},
              {"progress", progress},
              {"attempts", j.attempts},
              {"cancel_requested", j.cancel_requested},
              {"run_id", or_null(j.run_id)},
              {"reused_stored_run", j.reused},
              {"error", j.error},
              {"created_at", j.created_at},
              {"started_at", or_null(j.started_at)},
              {"finished_at", or_null(j.finished_at)},
              {"updated_at", j.updated_at},
              {"links", {{"self", self}, {"metrics", self + "/metrics"}}}};
  if (full) out["scene"] = json::parse(j.scene_json, nullptr, false);
  return out;
}

json scene_json(const SceneRow& s, bool full) {
  json out = {{"id", s.id},
              {"name", s.name},
              {"content_hash", s.content_hash},
              {"structures", json::parse(s.structures_json, nullptr, false)},
              {"created_at", s.created_at}};
  if (full) out["scene"] = json::parse(s.scene_json, nullptr, false);
  return out;
}

// A positive integer from a query parameter; 400 naming the parameter otherwise.
int64_t int_param(const std::string& name, const std::string& v, int64_t lo, int64_t hi) {
  const std::string range = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (v.empty() || v.size() > 18 || !std::all_of(v.begin(), v.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw ApiError(400, name, "must be " + range);
  const int64_t x = std::stoll(v);
  if (x < lo || x > hi) throw ApiError(400, name, "must be " + range + " (got " + v + ")");
  return x;
}

void only_params(const httplib::Request& req, const std::set<std::string>& allowed) {
  for (const auto& [k, v] : req.params)
    if (!allowed.count(k)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw ApiError(400, k, "unknown query parameter (accepted: " + (list.empty() ? std::string("none") : list) + ")");
    }
}

bool constant_time_equal(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i % std::max<size_t>(b.size(), 1)]);
  return diff == 0 && a.size() == b.size();
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

using Handler = std::function<void(const httplib::Request&, httplib::Response&, const std::smatch&)>;
struct Route {
  std::string text;
  std::regex pattern;
  std::map<std::string, Handler> methods;  // GET, POST, DELETE
  bool write(const std::string& m) const { return m == "POST" || m == "DELETE"; }
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------

struct Server::Impl {
  ServeOptions opt;
  Limits limits;
  std::vector<std::string> tokens, token_labels;  // accepted bearer tokens; their labels (job.submitted_by)
  std::vector<std::pair<std::string, std::string>> path_labels;  // server paths -> what errors show instead
  std::unique_ptr<RunStore> store;  // reads for the HTTP side
  std::unique_ptr<JobQueue> queue;
  std::unique_ptr<HttpFront> front;
  std::vector<Route> routes;
  std::unique_ptr<WebRoot> web;
  int lock_fd = -1;
  int port = 0;

  // Workers.
  std::vector<std::thread> workers;
  std::mutex mutex;
  std::condition_variable wake;
  bool stopping = false;
  struct Running {
    std::atomic<bool> stop{false};
    std::atomic<bool> cancel{false};
  };
  std::map<int64_t, std::shared_ptr<Running>> running;  // job id -> its stop flags (under mutex)
  std::atomic<int> busy{0};
  int threads_per_job = 1;
  std::unique_ptr<SweepLauncher> launcher;  // RUNOUT_SWEEP_LAUNCHER: sweeps go to an MPI launch command

  void add(const std::string& pattern, const std::string& method, Handler h) {
    const std::string full = "^" + kPrefix + pattern + "$";
    auto it = std::find_if(routes.begin(), routes.end(), [&](const Route& r) { return r.text == full; });
    if (it == routes.end()) {
      routes.push_back(Route{full, std::regex(full), {}});
      it = routes.end() - 1;
    }
    it->methods[method] = std::move(h);
  }

  static std::string allow_of(const Route& r) {
    std::string allow;
    for (const auto& [m, h] : r.methods) {
      allow += (allow.empty() ? "" : ", ") + m;
      if (m == "GET") allow += ", HEAD";
    }
    return allow + ", OPTIONS";
  }

  // Who submits: the label of the request's token ("open" when writes are open). Throws 401 for a write
  // without a valid token. Every token is compared, in constant time.
  std::string authorize(const httplib::Request& req) const {
    if (tokens.empty()) return "open";
    const std::string h = req.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    int found = -1;
    if (h.size() > prefix.size() && h.compare(0, prefix.size(), prefix) == 0)
      for (size_t k = 0; k < tokens.size(); ++k)
        if (constant_time_equal(h.substr(prefix.size()), tokens[k])) found = static_cast<int>(k);
    if (found < 0)
      throw ApiError(401, "Authorization", "a write needs the header 'Authorization: Bearer <token>' with the service's token");
    return token_labels[static_cast<size_t>(found)];
  }

  // Before a body is read (http_front.hpp): writes to the API need the token, so a client without it never
  // costs the server a body.
  bool check_head(const httplib::Request& req, httplib::Response& res) const {
    if (tokens.empty() || (req.method != "POST" && req.method != "DELETE") || req.path.rfind(kPrefix + "/", 0) != 0)
      return false;
    try {
      (void)authorize(req);
      return false;
    } catch (const ApiError& e) {
      res.set_header("WWW-Authenticate", "Bearer");
      send_error(res, e.status, e.field, e.what());
      return true;
    }
  }

  // The media type exactly (case-insensitive), parameters allowed; a charset, if given, must be UTF-8.
  void check_json_body(const httplib::Request& req) const {
    if (!req.has_header("Content-Type")) return;
    const std::string ct = req.get_header_value("Content-Type");
    const std::string accepted = " (accepted: application/json, optionally with '; charset=utf-8')";
    bool ok = lower(trim(ct.substr(0, ct.find(';')))) == "application/json";
    for (size_t semi = ct.find(';'); ok && semi != std::string::npos;) {
      const size_t next = ct.find(';', semi + 1);
      const std::string param = lower(trim(ct.substr(semi + 1, next == std::string::npos ? std::string::npos : next - semi - 1)));
      if (param.rfind("charset=", 0) == 0) {
        std::string v = param.substr(8);
        if (v.size() >= 2 && v.front() == '"' && v.back() == '"') v = v.substr(1, v.size() - 2);
        ok = v == "utf-8" || v == "utf8";
      }
      semi = next;
    }
    if (!ok) throw ApiError(415, "Content-Type", "must be application/json (got '" + ct.substr(0, 80) + "')" + accepted);
  }

  // Error messages never show the server's own paths: the scene directory's prefix is dropped (names are
  // relative to it, as the client wrote them), the other roots are named by their option.
  std::string scrub(std::string msg) const {
    for (const auto& [from, to] : path_labels)
      for (size_t at = msg.find(from); !from.empty() && at != std::string::npos; at = msg.find(from, at + to.size()))
        msg.replace(at, from.size(), to);
    return msg;
  }

  // The cost model's CPU-seconds of a job (run time x threads), what the work budget counts.
  double cpu_seconds(const JobSpec& spec) const {
    const int threads = std::max(1, threads_per_job);
    return CostModel::calibrated().predict(spec.cost, threads).seconds * threads;
  }

  // Refuses a submission of `requested` CPU-seconds that the budget cannot take: 422 when it never could,
  // 429 with Retry-After (how long the workers need to drain the excess) when it could later.
  BudgetCheck budget_check(double requested) const {
    if (opt.budget_token_cpu_s <= 0 && opt.budget_total_cpu_s <= 0) return nullptr;  // no budget: no backlog query
    return [this, requested](const Backlog& b) {
      auto over = [&](const char* scope, double limit, double queued, const char* flag) {
        json budget = {{"scope", scope}, {"limit_cpu_s", limit}, {"queued_cpu_s", queued},
                       {"requested_cpu_s", requested}, {"option", flag}};
        if (requested > limit) {
          ApiError e(422, "(budget)", "the submission is predicted at " + std::to_string(std::lround(requested)) +
                                          " CPU-s, over the work budget (accepted: at most " +
                                          std::to_string(std::lround(limit)) + " CPU-s " + scope + ", " + flag +
                                          "; choose a coarser fidelity or a shorter duration)");
          e.budget_json = budget.dump();
          throw e;
        }
        const double rate = std::max(1, opt.workers) * std::max(1, threads_per_job);  // CPU-s drained per s
        const long retry = std::clamp<long>(std::lround(std::ceil((queued + requested - limit) / rate)), 1, 86400);
        budget["retry_after_s"] = retry;
        ApiError e(429, "(budget)", "the queue holds " + std::to_string(std::lround(queued)) + " predicted CPU-s " +
                                        scope + "; this submission (" + std::to_string(std::lround(requested)) +
                                        " CPU-s) would exceed the work budget (accepted: at most " +
                                        std::to_string(std::lround(limit)) + " CPU-s queued " + scope + ", " + flag +
                                        "); retry after " + std::to_string(retry) + " s");
        e.headers.emplace_back("Retry-After", std::to_string(retry));
        e.budget_json = budget.dump();
        throw e;
      };
      if (opt.budget_token_cpu_s > 0 && b.mine_cpu_s + requested > opt.budget_token_cpu_s)
        over("per token", opt.budget_token_cpu_s, b.mine_cpu_s, "--budget-token-cpu-s");
      if (opt.budget_total_cpu_s > 0 && b.total_cpu_s + requested > opt.budget_total_cpu_s)
        over("in all", opt.budget_total_cpu_s, b.total_cpu_s, "--budget-total-cpu-s");
    };
  }

  std::optional<std::string> header_key(const httplib::Request& req) const {
    if (!req.has_header("Idempotency-Key")) return std::nullopt;
    std::string k = req.get_header_value("Idempotency-Key");
    check_idempotency_key(k, "Idempotency-Key");
    return k;
  }

  std::optional<std::string> pick_key(const std::optional<std::string>& header, const std::optional<std::string>& body) {
    if (header && body && *header != *body)
      throw ApiError(422, "idempotency_key", "differs from the Idempotency-Key header (accepted: the same key, or only one)");
    return header ? header : body;
  }

  Job require_job(const std::string& id_text) const {
    const int64_t id = std::stoll(id_text);
    auto j = queue->get(id);
    if (!j) throw ApiError(404, "id", "no job with id " + id_text);
    return *j;
  }

  // The stored run of a job, for its results (409 while it has none).
  int64_t run_of(const Job& j) const {
    if (!j.run_id || (j.status != "done" && j.status != "failed"))
      throw ApiError(409, "status", "job " + std::to_string(j.id) + " is " + j.status +
                                        "; results exist once it is done (or failed after running)");
    return *j.run_id;
  }

  fs::path out_dir_of(const Job& j) const {
    if (j.reused && j.run_id)
      if (auto d = queue->out_dir_of_run(*j.run_id)) return *d;
    return j.out_dir;
  }

  void setup_routes();
  void serve_web(const httplib::Request& req, httplib::Response& res) const;
  void dispatch(const httplib::Request& req, httplib::Response& res);
  void worker_loop(int index);
  void run_job(const Job& job);
};

void Server::Impl::setup_routes() {
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
  add("/openapi.json", "GET", [](const httplib::Request&, httplib::Response& res, const std::smatch&) {
    res.status = 200;
    res.set_content(openapi_json(), "application/json");
  });

  // Scenes.
  add("/scenes", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    const NewScene s = parse_scene_request(req.body, limits);
    std::string structures = json(s.structures).dump();
    auto [row, created] = queue->put_scene(s.name, s.content_hash, s.scene_json, structures);
    res.set_header("Location", kPrefix + "/scenes/" + std::to_string(row.id));
    send_json(res, created ? 201 : 200, scene_json(row, false));
  });
  add("/scenes", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    json list = json::array();
    for (const auto& s : queue->list_scenes()) list.push_back(scene_json(s, false));
    send_json(res, 200, {{"scenes", list}});
  });
  add(R"(/scenes/(\d{1,18}))", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    auto s = queue->get_scene(std::stoll(m[1].str()));
    if (!s) throw ApiError(404, "id", "no scene with id " + m[1].str());
    send_json(res, 200, scene_json(*s, true));
  });

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
    only_params(req, {"status", "sweep", "limit", "offset"});
    std::optional<std::string> status;
    std::optional<int64_t> sweep;
    if (req.has_param("status")) {
      status = req.get_param_value("status");
      if (!kStates.count(*status))
        throw ApiError(400, "status", "unknown status '" + status->substr(0, 40) +
                                          "' (accepted: queued, running, done, failed, cancelled)");
    }
    if (req.has_param("sweep")) {
      sweep = int_param("sweep", req.get_param_value("sweep"), 1, INT64_MAX / 2);
      if (!queue->get_sweep(*sweep)) throw ApiError(404, "sweep", "no sweep with id " + std::to_string(*sweep));
    }
    const int64_t limit = req.has_param("limit") ? int_param("limit", req.get_param_value("limit"), 1, 10000) : 1000;
    const int64_t offset = req.has_param("offset") ? int_param("offset", req.get_param_value("offset"), 0, INT64_MAX / 2) : 0;
    json list = json::array();
    for (const auto& j : queue->list(status, sweep, limit, offset)) list.push_back(job_json(j, false));
    send_json(res, 200, {{"total", queue->count(status, sweep)}, {"limit", limit}, {"offset", offset}, {"jobs", list}});
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

  // The estimate of a job before it is submitted: the body of POST /jobs, resolved and built the same way
  // (so the particle counts are the job's), and the run time from the calibrated cost model
  // (runout/scenarios/cost_model.hpp, docs/tradeoff.md). Writes nothing.
  add("/estimate", "POST", [this](const httplib::Request& req, httplib::Response& res, const std::smatch&) {
    only_params(req, {});
    check_json_body(req);
    (void)header_key(req);  // checked as for POST /jobs, then unused
    std::optional<std::string> bkey;
    const JobSpec spec = parse_job_request(req.body, limits, *queue, bkey);
    const CostModel model = CostModel::calibrated();
    const int threads = std::max(1, threads_per_job);
    const CostPrediction p = model.predict(spec.cost, threads);
    const CostCoefficients& k = spec.cost.dimensions == 2 ? model.two_d : model.three_d;
    const json resolved = json::parse(spec.scene_json);
    send_json(res, 200,
              {{"scene_name", spec.scene_name},
               {"variant", spec.variant},
               {"fidelity", spec.fidelity},
               {"dp", resolved.contains("dp") ? resolved["dp"] : json(nullptr)},
               {"dimensions", spec.dimensions},
               {"particles",
                {{"fluid", spec.fluid_particles}, {"boundary", spec.boundary_particles}, {"total", spec.particles}}},
               {"particle_budget", opt.particle_budget},
               {"steps_estimate", static_cast<int64_t>(p.steps)},
               {"seconds_estimate", p.seconds},
               {"model",
                {{"formula", "steps = ceil(step_ratio * duration / dt0); seconds = steps * (a_fluid * fluid_mean * "
                             "neighbours * passes + b_boundary * boundary + c_step) / speedup; speedup = 1 + "
                             "parallel_efficiency * fluid_mean / (fluid_mean + parallel_half_fluid) * (threads - 1)"},
                 {"duration_s", spec.cost.duration},
                 {"dt_s", spec.cost.dt0},
                 {"fluid_mean", spec.cost.fluid_mean},
                 {"neighbours", spec.cost.neighbours},
                 {"passes", spec.cost.passes},
                 {"boundary", spec.cost.boundary},
                 {"step_ratio", k.step_ratio},
                 {"a_fluid_s", k.a_fluid},
                 {"b_boundary_s", k.b_boundary},
                 {"c_step_s", k.c_step},
                 {"threads", threads},
                 {"parallel_efficiency", model.parallel_efficiency},
                 {"parallel_half_fluid", model.parallel_half_fluid},
                 {"speedup", p.speedup},
                 {"seconds_per_step", p.seconds_per_step},
                 {"note", "calibrated on measured runs of the shipped scenes; how well it predicts: docs/tradeoff.md"}}}});
  });

  // Results.
  add(R"(/jobs/(\d{1,18})/metrics)", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const Job j = require_job(m[1].str());
    const int64_t run = run_of(j);
    json flat = json::object();
    for (const auto& [k, v] : store->metrics(run)) flat[k] = v;
    const auto row = store->get_run(run);
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"run_status", row ? row->status : ""},
               {"manifest_hash", row ? row->manifest_hash : ""},
               {"metrics", flat},
               {"metrics_json", json::parse(store->metrics_json(run), nullptr, false)},
               {"series", store->series_names(run)}});
  });
  add(R"(/jobs/(\d{1,18})/series/(.+)\.csv)", "GET",
      [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        const std::string name = m[2].str();
        if (!safe_file_name(name))
          throw ApiError(400, "name", "series name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        const Job j = require_job(m[1].str());
        const int64_t run = run_of(j);
        auto csv = store->series_csv(run, name);
        if (!csv) {
          std::string list;
          for (const auto& n : store->series_names(run)) list += (list.empty() ? "" : ", ") + n;
          throw ApiError(404, "name", "job " + m[1].str() + " has no series '" + name + "' (available: " + list + ")");
        }
        res.status = 200;
        res.set_content(*csv, "text/csv");
      });
  auto raster = [this](const std::string& id, const std::string& file, httplib::Response& res, const char* type) {
    const Job j = require_job(id);
    (void)run_of(j);
    const fs::path p = out_dir_of(j) / "rasters" / file;
    if (!fs::is_regular_file(p))
      throw ApiError(404, "name", "job " + id + " has no raster '" + file +
                                      "' (rasters exist for terrain scenes: max_depth, max_speed, deposit_depth; map.png)");
    res.status = 200;
    res.set_content(read_file(p), type);
  };
  add(R"(/jobs/(\d{1,18})/rasters/(.+)\.tif)", "GET",
      [this, raster](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        if (!safe_file_name(m[2].str()))
          throw ApiError(400, "name", "raster name must be 1 to 64 of A-Z a-z 0-9 _ . - without '..'");
        raster(m[1].str(), m[2].str() + ".tif", res, "image/tiff");
      });
  add(R"(/jobs/(\d{1,18})/map\.png)", "GET",
      [this, raster](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
        only_params(req, {});
        raster(m[1].str(), "max_depth.png", res, "image/png");
      });
  // Where map.png lies on the ground, and what to draw over it: the raster's extent and CRS (read from
  // max_depth.tif, whose cells the PNG enlarges by a whole factor), and the map geometry of the job's
  // structures, protected zones, release and cross-sections from its resolved scene (working CRS, metres).
  add(R"(/jobs/(\d{1,18})/map\.json)", "GET", [this](const httplib::Request& req, httplib::Response& res, const std::smatch& m) {
    only_params(req, {});
    const Job j = require_job(m[1].str());
    const int64_t run = run_of(j);
    const fs::path tif = out_dir_of(j) / "rasters" / "max_depth.tif";
    if (!fs::is_regular_file(tif))
      throw ApiError(404, "id", "job " + m[1].str() + " has no map (maps exist for terrain scenes)");
    terrain::Grid g;
    try {
      g = terrain::load_dem(tif.string());
    } catch (const std::exception& e) {
      throw ApiError(500, "id", "cannot read the extent of job " + m[1].str() + "'s max_depth.tif: " + e.what());
    }
    const json scene = json::parse(j.scene_json, nullptr, false);
    auto ring = [](const json& pts, bool close) {
      json c = json::array();
      if (!pts.is_array()) return c;
      for (const auto& p : pts)
        if (p.is_array() && p.size() >= 2 && p[0].is_number() && p[1].is_number()) c.push_back({p[0], p[1]});
      if (close && c.size() > 2 && c.front() != c.back()) c.push_back(c.front());
      return c;
    };
    auto polygon = [&](const json& pts) { return json{{"type", "Polygon"}, {"coordinates", json::array({ring(pts, true)})}}; };
    auto line = [&](const json& pts) { return json{{"type", "LineString"}, {"coordinates", ring(pts, false)}}; };
    auto list = [&](const char* key) { return scene.is_object() && scene.contains(key) && scene[key].is_array() ? scene[key] : json::array(); };
    json structures = json::array(), zones = json::array(), sections = json::array();
    for (const auto& st : list("structures")) {
      json geom = st.contains("polygon") ? polygon(st["polygon"]) : line(st.value("axis", json::array()));
      structures.push_back({{"name", st.value("name", "")}, {"type", st.value("type", "")}, {"geometry", geom}});
    }
    for (const auto& z : list("protected_zones"))
      zones.push_back({{"name", z.value("name", "")}, {"geometry", polygon(z.value("polygon", json::array()))}});
    for (const auto& mon : list("monitors"))
      if (mon.value("type", "") == "section" && mon.contains("line"))
        sections.push_back({{"name", mon.value("name", "")}, {"series", "section_" + mon.value("name", "")},
                            {"geometry", line(mon["line"])}});
    json release = nullptr;
    if (scene.is_object() && scene.contains("release") && scene["release"].is_object() && scene["release"].contains("polygon"))
      release = {{"geometry", polygon(scene["release"]["polygon"])}};
    const std::string self = kPrefix + "/jobs/" + m[1].str();
    send_json(res, 200,
              {{"job", j.id},
               {"run_id", run},
               {"image", self + "/map.png"},
               {"crs", terrain::crs_name(g.crs_wkt)},
               {"raster",
                {{"nx", g.nx}, {"ny", g.ny}, {"dx", g.dx}, {"dy", g.dy},
                 {"west", g.x0}, {"north", g.y0}, {"east", g.x1()}, {"south", g.y1()}}},
               {"structures", structures},
               {"protected_zones", zones},
               {"release", release},
               {"sections", sections}});
  });
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

void Server::Impl::serve_web(const httplib::Request& req, httplib::Response& res) const {
  const std::string allow = "GET, HEAD, OPTIONS";
  if (req.method == "OPTIONS") {
    res.status = 204;
    res.set_header("Allow", allow);
    return;
  }
  if (req.method != "GET" && req.method != "HEAD") {
    res.set_header("Allow", allow);
    throw ApiError(405, "method", req.method + " is not allowed here (accepted: " + allow + ")");
  }
  WebFile f = web->get(req.path);
  res.status = 200;
  // The page talks only to this server and loads nothing from elsewhere.
  res.set_header("Content-Security-Policy",
                 "default-src 'self'; img-src 'self' data: blob:; style-src 'self' 'unsafe-inline'; "
                 "connect-src 'self'; object-src 'none'; base-uri 'none'; frame-ancestors 'none'");
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("Cache-Control", "no-cache");
  res.set_content(std::move(f.body), f.content_type);
}

void Server::Impl::dispatch(const httplib::Request& req, httplib::Response& res) {
  const auto t0 = Clock::now();
  const std::string method = req.method == "HEAD" ? "GET" : req.method;
  try {
    if (web->serves(req.path)) {
      serve_web(req, res);
      spdlog::debug("{} {} {}", req.method, req.path, res.status);
      return;
    }
    const Route* route = nullptr;
    std::smatch m;
    for (const auto& r : routes)
      if (std::regex_match(req.path, m, r.pattern)) {
        route = &r;
        break;
      }
    if (!route) {
      throw ApiError(404, "path", "no such resource: " + req.path.substr(0, 200) + " (the API is under " + kPrefix +
                                      ", see " + kPrefix + "/openapi.json)");
    }
    const std::string allow = allow_of(*route);
    if (method == "OPTIONS") {
      res.status = 204;
      res.set_header("Allow", allow);
    } else {
      auto it = route->methods.find(method);
      if (it == route->methods.end()) {
        res.set_header("Allow", allow);
        throw ApiError(405, "method", req.method + " is not allowed here (accepted: " + allow + ")");
      }
      if (route->write(method)) authorize(req);
      it->second(req, res, m);
    }
  } catch (const ApiError& e) {
    if (e.status == 401) res.set_header("WWW-Authenticate", "Bearer");
    for (const auto& [k, v] : e.headers) res.set_header(k, v);
    json body = {{"error", {{"status", e.status}, {"field", e.field}, {"message", scrub(e.what())}}}};
    if (!e.budget_json.empty()) body["budget"] = json::parse(e.budget_json);
    send_json(res, e.status, body);
  } catch (const std::exception& e) {
    spdlog::error("{} {}: {}", req.method, req.path, e.what());
    send_error(res, 500, "", scrub(std::string("internal error: ") + e.what()));
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  // Method, path and status only: never headers (the token) or bodies.
  spdlog::debug("{} {} {} {:.1f} ms", req.method, req.path, res.status, ms);
}

// ---------------------------------------------------------------------------------------------------------
// Workers

void Server::Impl::worker_loop(int index) {
  for (;;) {
    {
      std::unique_lock lock(mutex);
      if (stopping) return;
    }
    std::optional<Job> job;
    try {
      job = queue->claim((opt.runs_dir / "service").string());
    } catch (const std::exception& e) {
      spdlog::error("worker {}: claiming a job: {}", index, e.what());
    }
    if (!job) {
      std::unique_lock lock(mutex);
      wake.wait_for(lock, std::chrono::seconds(1), [&] { return stopping; });
      continue;
    }
    busy++;
    run_job(*job);
    busy--;
  }
}

void Server::Impl::run_job(const Job& job) {
  auto flags = std::make_shared<Running>();
  {
    std::lock_guard lock(mutex);
    running[job.id] = flags;
    if (stopping) flags->stop = true;
  }
  if (job.cancel_requested) {  // asked between the claim and now
    flags->cancel = true;
    flags->stop = true;
  }
  spdlog::info("job {} ({}{}{}) running, attempt {}", job.id, job.scene_name, job.variant.empty() ? "" : " ",
               job.variant, job.attempts);
  StoreRunOptions o;
  o.sweep = job.sweep;
  o.variant = job.variant;
  o.fidelity.name = job.fidelity;
  o.fidelity.dp = job.dp;
  o.run.out_dir = job.out_dir;
  o.run.threads = threads_per_job;
  o.run.stop = &flags->stop;
  auto last = Clock::now();
  std::optional<RunProgress> latest;
  o.run.on_progress = [&](const RunProgress& p) {
    latest = p;
    const auto now = Clock::now();
    if (now - last < std::chrono::milliseconds(500)) return;
    last = now;
    std::optional<double> eta;
    if (p.time > 0 && p.duration > p.time) eta = p.wall_seconds * (p.duration - p.time) / p.time;
    try {
      queue->progress(job.id, p.time, p.duration, p.steps, p.wall_seconds, eta);
    } catch (const std::exception& e) {
      spdlog::warn("job {}: progress not written: {}", job.id, e.what());
    }
  };
  std::string status, error;
  std::optional<int64_t> run_id;
  bool reused = false;
  try {
    RunStore store(opt.db);  // this worker's own connection
    const StoredRun r = run_and_store(store, job.scene_json, opt.scene_dir, o);
    reused = r.reused;
    if (r.status == "completed") {
      status = "done";
      run_id = r.run_id;
    } else if (r.status == "stopped") {
      status = flags->cancel ? "cancelled" : "requeue";
    } else {
      status = "failed";
      error = r.error.empty() ? "run " + r.status : r.error;
      run_id = r.run_id;
    }
  } catch (const std::exception& e) {
    status = flags->cancel ? "cancelled" : "failed";
    error = e.what();
  }
  {
    std::lock_guard lock(mutex);
    running.erase(job.id);
    if (stopping && status == "cancelled" && !flags->cancel) status = "requeue";
  }
  try {
    if (status == "requeue") {
      queue->requeue(job.id);
      spdlog::info("job {} stopped by shutdown: back in the queue", job.id);
    } else {
      if (latest) queue->progress(job.id, latest->time, latest->duration, latest->steps, latest->wall_seconds, std::nullopt);
      queue->finish(job.id, status, run_id, reused, error);
      spdlog::info("job {} {}{}{}", job.id, status, error.empty() ? "" : ": ", error);
    }
  } catch (const std::exception& e) {
    spdlog::error("job {}: could not record '{}': {} (it is requeued at the next start)", job.id, status, e.what());
  }
}

// ---------------------------------------------------------------------------------------------------------

Server::Server(ServeOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.opt = std::move(options);
  m.limits.particle_budget = m.opt.particle_budget;
  m.limits.scene_dir = m.opt.scene_dir;
  if (!m.opt.token.empty()) m.tokens.push_back(m.opt.token);
  for (const auto& t : m.opt.tokens)
    if (!t.empty() && std::find(m.tokens.begin(), m.tokens.end(), t) == m.tokens.end()) m.tokens.push_back(t);
  for (const auto& t : m.tokens) m.token_labels.push_back("token-" + terrain::sha256_hex(t).substr(0, 12));
  {
    // Longest first, so that a root inside another is replaced before it. The scene directory's prefix goes
    // (file names read as the client wrote them); the rest are named by their option.
    std::error_code ec;
    std::vector<std::pair<std::string, std::string>> labels;
    auto add_root = [&](const fs::path& p, const std::string& label, bool prefix_only) {
      for (const fs::path& q : {fs::absolute(p, ec), fs::weakly_canonical(p, ec)}) {
        std::string text = q.lexically_normal().string();
        while (text.size() > 1 && text.back() == '/') text.pop_back();
        if (text.size() <= 1) continue;
        labels.emplace_back(text + "/", prefix_only ? "" : label + "/");
        labels.emplace_back(text, label);
      }
    };
    add_root(m.opt.scene_dir, "<scene-dir>", true);
    add_root(m.opt.runs_dir, "<runs>", false);
    add_root(m.opt.db, "<db>", false);
    if (!m.opt.web_root.empty()) add_root(m.opt.web_root, "<web-root>", false);
    std::stable_sort(labels.begin(), labels.end(), [](const auto& a, const auto& b) { return a.first.size() > b.first.size(); });
    m.path_labels = labels;
  }
  // One server per database file: the queue's recovery assumes no other server runs its jobs.
  const std::string lock_path = m.opt.db.string() + ".serve-lock";
  m.lock_fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (m.lock_fd < 0) throw std::runtime_error("cannot open the lock file " + lock_path);
  if (::flock(m.lock_fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(m.lock_fd);
    m.lock_fd = -1;
    throw std::runtime_error("another `runout serve` is using " + m.opt.db.string() + " (lock " + lock_path + ")");
  }
  m.store = std::make_unique<RunStore>(m.opt.db);  // creates or migrates the file
  m.queue = std::make_unique<JobQueue>(m.opt.db);
  m.web = std::make_unique<WebRoot>(m.opt.web_root);
  // Sweeps on a cluster (docs/service.md): the operator's launch command, from the environment.
  if (const char* t = std::getenv("RUNOUT_SWEEP_LAUNCHER"); t && *t) {
    int ranks = 2;
    if (const char* r = std::getenv("RUNOUT_SWEEP_RANKS"); r && *r) {
      const std::string text = r;
      if (text.size() > 9 || text.find_first_not_of("0123456789") != std::string::npos)
        throw std::invalid_argument("RUNOUT_SWEEP_RANKS: must be an integer in [1, 100000] (got '" + text.substr(0, 20) + "')");
      ranks = std::stoi(text);
    }
    m.launcher = std::make_unique<SweepLauncher>(t, ranks, m.opt.db, m.opt.runs_dir, m.opt.scene_dir, *m.queue);
    spdlog::info("sweeps go to the launcher: {}", t);
  }
  const int workers = std::max(0, m.opt.workers);
  m.threads_per_job = m.opt.threads_per_job > 0 ? m.opt.threads_per_job
                                                : std::max(1, omp_get_num_procs() / std::max(1, workers));
  m.setup_routes();
}

Server::~Server() {
  stop();
  if (impl_->lock_fd >= 0) ::close(impl_->lock_fd);
}

int Server::start() {
  Impl& m = *impl_;
  FrontOptions f;
  f.host = m.opt.host;
  f.port = m.opt.port;
  f.max_body = m.opt.max_body;
  f.header_timeout = m.opt.header_timeout;
  f.body_timeout = m.opt.body_timeout;
  f.idle_timeout = m.opt.idle_timeout;
  f.max_connections = m.opt.max_connections;
  f.max_connections_per_client = m.opt.max_connections_per_client;
  f.handler_threads = std::max(2, m.opt.http_threads);
  const std::string health = kPrefix + "/health";
  m.front = std::make_unique<HttpFront>(
      f, [&m](const httplib::Request& req, httplib::Response& res) { m.dispatch(req, res); },
      [&m](const httplib::Request& req, httplib::Response& res) { return m.check_head(req, res); },
      [health](const httplib::Request& req) { return (req.method == "GET" || req.method == "HEAD") && req.path == health; });
  m.port = m.front->bind();
  const int requeued = m.queue->recover();
  if (requeued > 0) spdlog::warn("{} job(s) left running by a previous server are back in the queue", requeued);
  for (int k = 0; k < m.opt.workers; ++k) m.workers.emplace_back([&m, k] { m.worker_loop(k); });
  return m.port;
}

bool Server::serve() {
  impl_->front->run();
  return true;
}

void Server::stop() {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.mutex);
    if (m.stopping && m.workers.empty()) return;
    m.stopping = true;
    for (auto& [id, f] : m.running) f->stop = true;
  }
  m.wake.notify_all();
  if (m.front) m.front->stop();
  for (auto& t : m.workers) t.join();
  m.workers.clear();
  if (m.launcher) m.launcher->stop();  // launched sweeps: SIGTERM, unfinished jobs back in the queue
}

}  // namespace runout::service
