// The HTTP service (server.hpp, docs/service.md): dispatch, the web page, workers, start and stop. The routes
// are in routes_<resource>.cpp, Server::Impl and shared helpers in server_impl.hpp.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <omp.h>

#include "server_impl.hpp"

#include "runout/common/sha256.hpp"

namespace runout::service {

namespace {

// A route's pattern ("^/api/v1/jobs/(\d{1,18})/series/(.+)\.csv$") or an OpenAPI path ("/jobs/{id}/series/{name}.csv")
// as one template with anonymous parameters: "/jobs/{}/series/{}.csv".
std::string route_template(const std::string& pattern) {
  std::string t;
  int depth = 0;
  for (size_t i = kPrefix.size() + 1; i + 1 < pattern.size(); ++i) {  // without "^", the prefix and "$"
    const char c = pattern[i];
    if (c == '\\') {
      if (depth == 0) t += pattern[i + 1];
      ++i;
    } else if (c == '(') {
      if (depth++ == 0) t += "{}";
    } else if (c == ')') {
      --depth;
    } else if (depth == 0) {
      t += c;
    }
  }
  return t;
}

std::string openapi_template(const std::string& path) {
  static const std::regex param(R"(\{[^}]*\})");
  return std::regex_replace(path, param, "{}");
}

// The route table is the one list of the API's paths and methods: the OpenAPI document must describe exactly
// these, or the server does not start (so every service test checks it).
void check_routes_against_openapi(const std::vector<Route>& routes) {
  std::map<std::string, std::set<std::string>> table, doc;
  for (const Route& r : routes)
    for (const auto& [method, handler] : r.methods) {
      std::string m = method;
      std::transform(m.begin(), m.end(), m.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      table[route_template(r.text)].insert(m);
    }
  const json d = json::parse(openapi_json());
  for (const auto& [path, item] : d.at("paths").items())
    for (const auto& [key, op] : item.items())
      if (std::set<std::string>{"get", "put", "post", "delete", "patch", "head", "options"}.count(key))
        doc[openapi_template(path)].insert(key);
  if (table == doc) return;
  std::string diff;
  for (const auto& [t, ms] : table)
    for (const auto& m : ms)
      if (!doc.count(t) || !doc.at(t).count(m)) diff += " " + m + " " + t + " (routed, not documented);";
  for (const auto& [t, ms] : doc)
    for (const auto& m : ms)
      if (!table.count(t) || !table.at(t).count(m)) diff += " " + m + " " + t + " (documented, not routed);";
  throw std::logic_error("service/openapi.json and the route table differ:" + diff);
}

}  // namespace

void Server::Impl::setup_routes() {
  routes_health();
  routes_scenes();
  routes_jobs();
  routes_sweeps();
  routes_estimate();
  routes_results();
  routes_maps();
  routes_compare();
  check_routes_against_openapi(routes);
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
    send_problem(res, req.path, e, [this](const std::string& m) { return scrub(m); });
  } catch (const std::exception& e) {
    spdlog::error("{} {}: {}", req.method, req.path, e.what());
    send_problem(res, req.path, ApiError(500, "", std::string("internal error: ") + e.what()),
                 [this](const std::string& m) { return scrub(m); });
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
      if (decide_studies()) continue;  // a study's detailed jobs were queued
      std::unique_lock lock(mutex);
      wake.wait_for(lock, std::chrono::seconds(1), [&] { return stopping; });
      continue;
    }
    busy++;
    run_job(*job);
    busy--;
    if (job->stage == 1) decide_studies();
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
  ThreadShare::Lease lease(cores);
  o.run.threads = threads_per_job;
  if (opt.threads_per_job <= 0) o.run.threads_now = lease.threads_now();
  o.run.stop = &flags->stop;
  o.run.checkpoint_interval = opt.checkpoint_interval;
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
  if (status == "cancelled") {  // nothing will resume it
    std::error_code ec;
    std::filesystem::remove(std::filesystem::path(job.out_dir) / "checkpoint.bin", ec);
  }
  try {
    if (status == "requeue") {
      queue->requeue(job.id);
      spdlog::info("job {} stopped by shutdown: back in the queue", job.id);
    } else {
      if (latest) queue->progress(job.id, latest->time, latest->duration, latest->steps, latest->wall_seconds, std::nullopt);
      if (status == "done" && job.sweep_id) {  // before it reads done, so that a done job has them
        Job done = job;
        done.status = "done";
        done.run_id = run_id;
        done.reused = reused;
        write_sweep_differences(done);
      }
      queue->finish(job.id, status, run_id, reused, error);
      spdlog::info("job {} {}{}{}", job.id, status, error.empty() ? "" : ": ", error);
    }
  } catch (const std::exception& e) {
    spdlog::error("job {}: could not record '{}': {} (it is requeued at the next start)", job.id, status, e.what());
  }
}

// A sweep's difference rasters, as `runout sweep` writes them: each done layout minus the sweep's first layout
// (its baseline), into the layout's own job folder (a reused run's rasters belong to the job that made it, and
// perhaps to another sweep with another baseline), as soon as both are done. `finished`: the job about to be
// recorded done. One writer at a time: two workers finishing together would write the same files.
void Server::Impl::write_sweep_differences(const Job& finished) {
  std::lock_guard lock(differences_mutex);
  const int64_t sweep_id = *finished.sweep_id;
  auto jobs = queue->list(std::nullopt, sweep_id, 100000, 0);
  for (auto& j : jobs)
    if (j.id == finished.id) j = finished;
  // A study's stages are compared within themselves: a detailed layout against the detailed baseline.
  std::erase_if(jobs, [&](const Job& j) { return j.stage != finished.stage; });
  if (jobs.size() < 2 || jobs.front().status != "done") return;
  const Job& base = jobs.front();
  for (const auto& j : jobs) {
    if (j.id == base.id || j.status != "done" || (finished.id != base.id && j.id != finished.id)) continue;
    try {
      write_layout_differences(out_dir_of(j) / "rasters", j.variant, out_dir_of(base) / "rasters", base.variant,
                               fs::path(j.out_dir) / "rasters");
    } catch (const std::exception& e) {
      spdlog::warn("sweep {}: no difference rasters for job {}: {}", sweep_id, j.id, e.what());
    }
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
  for (const auto& t : m.tokens) m.token_labels.push_back("token-" + sha256_hex(t).substr(0, 12));
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
  std::error_code ec;
  if (m.opt.shipped_studies && !m.opt.shipped_root.empty() && fs::equivalent(m.opt.scene_dir, m.opt.shipped_root, ec)) {
    m.shipped["status"] = "storing";
    m.seeder = std::thread([&m] { m.seed_shipped_studies(); });
  }
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
  if (m.seeder.joinable()) m.seeder.join();  // it stops before its next scene
  if (m.launcher) m.launcher->stop();  // launched sweeps: SIGTERM, unfinished jobs back in the queue
}

}  // namespace runout::service
