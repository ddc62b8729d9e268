#pragma once
// Internal to the HTTP service: Server::Impl and the helpers that server.cpp and the route files
// (routes_<resource>.cpp, one per resource) share. Included by those files only: it pulls in httplib.h and
// nlohmann-json, which server.hpp keeps out.
#include "server.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
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
#include "runout/scenarios/raster_map.hpp"
#include "requests.hpp"
#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"
#include "runout/scenarios/thread_share.hpp"
#include "sweep_launcher.hpp"
#include "web_files.hpp"

#include "http_front.hpp"  // httplib.h
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#ifndef RUNOUT_VERSION
#define RUNOUT_VERSION "unknown"
#endif

namespace runout::service {

namespace srv {

using json = nlohmann::json;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

inline const std::string kPrefix = "/api/v1";
inline const std::set<std::string> kStates = {"queued", "running", "done", "failed", "cancelled"};

inline std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

inline void send_json(httplib::Response& res, int status, const json& j) {
  res.status = status;
  res.set_content(dump(j), "application/json");
}

// A refusal as an RFC 9457 problem document (http_front.hpp): every invalid field of `e` (one, or those a
// FieldErrors collected) in `errors`, each message passed through `scrub`; the budget's object as `budget`.
template <class Scrub>
void send_problem(httplib::Response& res, const std::string& instance, const ApiError& e, Scrub&& scrub) {
  std::vector<FieldError> errors;
  if (e.errors.empty()) errors.push_back({e.field, scrub(e.what())});
  for (const auto& [field, message] : e.errors) errors.push_back({field, scrub(message)});
  const std::string extra = e.budget_json.empty() ? std::string() : json{{"budget", json::parse(e.budget_json)}}.dump();
  res.status = e.status;
  res.set_content(problem_body(e.status, instance, errors, extra), kProblemMediaType);
}

inline std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

inline std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

// A job's simulated fraction of its duration.
inline double run_fraction(const Job& j) { return j.duration > 0 ? std::min(1.0, j.sim_time / j.duration) : 0.0; }
// What a job adds to its sweep's progress: a finished job (done, failed, cancelled) counts 1.
inline double sweep_share(const Job& j) {
  return j.status == "done" || j.status == "failed" || j.status == "cancelled" ? 1.0 : run_fraction(j);
}

inline json job_json(const Job& j, bool full) {
  auto or_null = [](const auto& o) -> json { return o ? json(*o) : json(nullptr); };
  json progress = {{"simulated_time", j.sim_time},
                   {"duration", j.duration},
                   {"fraction", run_fraction(j)},
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
              {"stage", j.stage > 0 ? json(j.stage) : json(nullptr)},
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

inline json scene_json(const SceneRow& s, bool full) {
  json out = {{"id", s.id},
              {"name", s.name},
              {"content_hash", s.content_hash},
              {"structures", json::parse(s.structures_json, nullptr, false)},
              {"created_at", s.created_at}};
  if (full) out["scene"] = json::parse(s.scene_json, nullptr, false);
  return out;
}

// A positive integer from a query parameter; 400 naming the parameter otherwise.
inline int64_t int_param(const std::string& name, const std::string& v, int64_t lo, int64_t hi) {
  const std::string range = "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (v.empty() || v.size() > 18 || !std::all_of(v.begin(), v.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw ApiError(400, name, "must be " + range);
  const int64_t x = std::stoll(v);
  if (x < lo || x > hi) throw ApiError(400, name, "must be " + range + " (got " + v + ")");
  return x;
}

// A number from a query parameter in [lo, hi]; 400 naming the parameter otherwise.
inline double number_param(const std::string& name, const std::string& v, double lo, double hi) {
  std::ostringstream range;
  range << "a number in [" << lo << ", " << hi << "]";
  char* end = nullptr;
  const double x = v.empty() || v.size() > 40 ? std::nan("") : std::strtod(v.c_str(), &end);
  if (!std::isfinite(x) || end != v.c_str() + v.size() || x < lo || x > hi)
    throw ApiError(400, name, "must be " + range.str() + " (got '" + v.substr(0, 40) + "')");
  return x;
}

// 1 to `most` positive integer ids separated by commas; 400 naming the parameter otherwise.
inline std::vector<int64_t> id_list(const std::string& name, const std::string& v, size_t most) {
  std::vector<int64_t> ids;
  std::stringstream ss(v);
  for (std::string part; std::getline(ss, part, ',');) ids.push_back(int_param(name, part, 1, INT64_MAX / 2));
  if (ids.empty() || ids.size() > most)
    throw ApiError(400, name, "must list 1 to " + std::to_string(most) + " job ids separated by commas");
  return ids;
}

// Every unknown query parameter, each its own error, into `errors` (or thrown at once without).
inline void only_params(const httplib::Request& req, const std::set<std::string>& allowed, FieldErrors& errors) {
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  for (const auto& [k, v] : req.params)
    if (!allowed.count(k))
      errors.add(ApiError(400, k, "unknown query parameter (accepted: " + (list.empty() ? std::string("none") : list) + ")"));
}
inline void only_params(const httplib::Request& req, const std::set<std::string>& allowed) {
  FieldErrors errors;
  only_params(req, allowed, errors);
  errors.raise();
}

// Lists come in pages (docs/service.md, "Lists"): `limit` items from an opaque `cursor` (the `next` of the
// previous page), which is the key, an id, the page continues after: pages stay exact while items are added.
// The cursor is base64url of "id:<key>", opaque to clients so that its form may change.
inline std::string encode_cursor(int64_t key) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  const std::string in = "id:" + std::to_string(key);
  std::string out;
  for (size_t i = 0; i < in.size(); i += 3) {
    uint32_t n = static_cast<uint32_t>(static_cast<unsigned char>(in[i])) << 16;
    if (i + 1 < in.size()) n |= static_cast<uint32_t>(static_cast<unsigned char>(in[i + 1])) << 8;
    if (i + 2 < in.size()) n |= static_cast<unsigned char>(in[i + 2]);
    const size_t chars = std::min<size_t>(4, in.size() - i + 1);
    for (size_t k = 0; k < chars; ++k) out += abc[(n >> (18 - 6 * k)) & 63];
  }
  return out;
}

inline int64_t decode_cursor(const std::string& cursor) {
  const ApiError bad(400, "cursor", "is not a cursor of this list (accepted: the `next` of a previous page, as it was given)");
  if (cursor.empty() || cursor.size() > 40) throw bad;
  std::string out;
  uint32_t n = 0;
  int bits = 0;
  for (const char c : cursor) {
    const int v = c >= 'A' && c <= 'Z' ? c - 'A' : c >= 'a' && c <= 'z' ? c - 'a' + 26 : c >= '0' && c <= '9' ? c - '0' + 52
                : c == '-' ? 62 : c == '_' ? 63 : -1;
    if (v < 0) throw bad;
    n = (n << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((n >> bits) & 0xff);
    }
  }
  const std::string digits = out.rfind("id:", 0) == 0 ? out.substr(3) : std::string();
  if (digits.empty() || digits.size() > 18 || digits.find_first_not_of("0123456789") != std::string::npos) throw bad;
  return std::stoll(digits);
}

struct PageRequest {
  int64_t limit = 0;
  std::optional<int64_t> cursor;  // the key the page continues after
};

// `limit` in [1, max_limit] (default_limit without it) and `cursor`; their errors into `errors`.
inline PageRequest page_request(const httplib::Request& req, int64_t default_limit, int64_t max_limit,
                                FieldErrors& errors) {
  PageRequest p{default_limit, std::nullopt};
  if (req.has_param("limit"))
    errors.check([&] {
      const std::string range = "an integer in [1, " + std::to_string(max_limit) + "]; default " +
                                std::to_string(default_limit);
      const std::string v = req.get_param_value("limit");
      if (v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos)
        throw ApiError(400, "limit", "must be " + range + " (got '" + v.substr(0, 20) + "')");
      const int64_t x = std::stoll(v);
      if (x < 1 || x > max_limit) throw ApiError(400, "limit", "must be " + range + " (got " + v + ")");
      p.limit = x;
    });
  if (req.has_param("cursor")) errors.check([&] { p.cursor = decode_cursor(req.get_param_value("cursor")); });
  return p;
}

// A page query fetches limit + 1 rows: the extra one only says that a next page exists. Drops it; the key the
// next page continues after (the last row's id), or nothing on the last page.
template <class Row>
std::optional<int64_t> trim_page(std::vector<Row>& rows, int64_t limit) {
  if (static_cast<int64_t>(rows.size()) <= limit) return std::nullopt;
  rows.resize(static_cast<size_t>(limit));
  return rows.back().id;
}

// The next page's URL (this request with `cursor` for `key` in place of cursor and offset) in the `Link`
// header (RFC 8288) and as the list's `next`; null without a next page.
inline json next_page(const httplib::Request& req, httplib::Response& res, const std::optional<int64_t>& key) {
  if (!key) return nullptr;
  httplib::Params params;
  for (const auto& [k, v] : req.params)
    if (k != "cursor" && k != "offset") params.emplace(k, v);
  params.emplace("cursor", encode_cursor(*key));
  const std::string url = req.path + "?" + httplib::detail::params_to_query_str(params);
  res.set_header("Link", "<" + url + ">; rel=\"next\"");
  return url;
}

// Content-Disposition for a download; names are made of safe_file_name characters, so no quoting is needed.
inline std::string attachment(const std::string& filename) { return "attachment; filename=\"" + filename + "\""; }

inline bool constant_time_equal(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i % std::max<size_t>(b.size(), 1)]);
  return diff == 0 && a.size() == b.size();
}

inline std::string read_file(const fs::path& p) {
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

}  // namespace srv

using namespace srv;

// The base scenes of the shipped studies under ROOT, relative to it, in the order they are stored: the `base`
// of every sweep file in ROOT's folders (flume/ first, then by name), each once (shipped_studies.cpp).
std::vector<fs::path> shipped_base_scenes(const fs::path& root);

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
  int threads_per_job = 1;  // the planning figure (estimates, ETA): --threads-per-job, else cores / workers
  ThreadShare cores{omp_get_num_procs()};  // without --threads-per-job, running jobs divide the cores between them
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
      send_problem(res, req.path, e, [](const std::string& m) { return m; });
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

  Job require_job(const std::string& id_text, const char* field = "id") const {
    const int64_t id = std::stoll(id_text);
    auto j = queue->get(id);
    if (!j) throw ApiError(404, field, "no job with id " + id_text);
    return *j;
  }

  // The stored run of a job, for its results (409 while it has none).
  int64_t run_of(const Job& j, const char* field = "status") const {
    if (!j.run_id || (j.status != "done" && j.status != "failed"))
      throw ApiError(409, field, "job " + std::to_string(j.id) + " is " + j.status +
                                        "; results exist once it is done (or failed after running)");
    return *j.run_id;
  }

  fs::path out_dir_of(const Job& j) const {
    if (j.reused && j.run_id)
      if (auto d = queue->out_dir_of_run(*j.run_id)) return *d;
    return j.out_dir;
  }

  void setup_routes();  // the route table: one function per resource, routes_*.cpp
  void routes_health();
  void routes_scenes();
  void routes_jobs();
  void routes_sweeps();
  void routes_estimate();
  void routes_results();
  void routes_maps();
  std::vector<ColourScale> raster_scales(const fs::path& out_dir);
  json map_layers_json(const Job& j, const std::string& self, const std::vector<int64_t>& shared);
  std::mutex scales_mutex;
  std::map<std::string, std::vector<ColourScale>> scales_cache;  // a run's output folder -> its colour scales
  void send_run_file(const std::string& id, const std::string& file, httplib::Response& res, const char* type,
                     bool download);
  void routes_compare();
  json sweep_of(int64_t base_job, const std::vector<int64_t>& job_ids) const;
  json ensemble_of(const std::vector<Job>& jobs, const std::string& sweep) const;
  void serve_web(const httplib::Request& req, httplib::Response& res) const;
  void dispatch(const httplib::Request& req, httplib::Response& res);
  void worker_loop(int index);
  void run_job(const Job& job);
  void write_sweep_differences(const Job& finished);
  // The shipped studies' base scenes, stored in the background at start (shipped_studies.cpp); GET /health
  // reports `shipped`: {status: off | storing | done, offered: [{file, scene_id, name}], failed: [{file, message}]}.
  void seed_shipped_studies();
  json shipped_status() const;
  json shipped = {{"status", "off"}, {"offered", json::array()}, {"failed", json::array()}};
  mutable std::mutex shipped_mutex;
  std::thread seeder;
  std::mutex differences_mutex;
  // Multi-fidelity studies (studies.cpp): deciding their screening stage, and GET /sweeps/{id}'s `study`.
  bool decide_studies();  // true when one was decided (its detailed jobs queued)
  bool decide_study(int64_t sweep_id);
  json study_of(const SweepRow& row, const std::vector<Job>& jobs) const;
  std::mutex studies_mutex;
};

// A study sweep's plan as the queue stores it (studies.cpp): its detailed stage's candidate jobs, layouts,
// ensemble and base scene.
std::string study_plan_json(const NewSweep& s);

}  // namespace runout::service
