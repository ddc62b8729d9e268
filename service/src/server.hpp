#pragma once
// `runout serve`: the HTTP service (docs/service.md). A versioned JSON API under /api/v1 (cpp-httplib) over
// the run store and the persistent job queue (jobs.hpp) in one SQLite file, and a pool of workers that run
// jobs through run_and_store, so a job stores exactly what `runout sweep` / run_and_store stores.
// httplib stays out of this header.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace runout::service {

struct ServeOptions {
  std::string host = "127.0.0.1";
  int port = 8080;               // 0: any free port (printed on stdout as "listening on HOST:PORT")
  std::filesystem::path db = "runout.db";
  std::filesystem::path runs_dir = "runs";  // a job's outputs go to RUNS/service/job-<id>
  std::filesystem::path scene_dir = ".";    // relative file names in scenes (terrain.dem) resolve here
  // The shipped scenarios folder (scenarios/ of the source tree the binary was built from). When scene_dir is
  // it and shipped_studies is on, the base scenes of its studies are stored in the background at start.
  std::filesystem::path shipped_root;
  bool shipped_studies = true;
  int workers = 1;               // 0: accept and queue jobs, run none
  int threads_per_job = 0;       // OpenMP threads of one job; 0: the cores divided among the jobs running
  // A running job saves its state every this many seconds of wall time and when the service stops, so a
  // restarted service resumes it where it was (RunOptions::checkpoint_interval); 0: a requeued job starts over.
  double checkpoint_interval = 300;
  std::string token;             // bearer token for writes; empty: writes are open
  std::vector<std::string> tokens;  // more accepted tokens (a token file of several lines); each has its budget
  size_t max_body = 1 << 20;     // bytes
  int64_t particle_budget = 2'000'000;
  int http_threads = 8;          // API handler threads (health has a thread of its own)
  // Limits of the HTTP front (http_front.hpp, docs/service.md "Limits").
  double header_timeout = 10;    // s for a whole request head
  double body_timeout = 30;      // s for a whole body
  double idle_timeout = 5;       // s a kept-alive connection waits for its next request
  int max_connections = 512;
  int max_connections_per_client = 32;
  // The work budget: predicted CPU-seconds (the cost model, × threads per job) of queued and running jobs,
  // per token and in all; 0: no limit. Over it a submission is 429 with Retry-After.
  double budget_token_cpu_s = 86'400;   // 24 CPU-hours per token
  double budget_total_cpu_s = 259'200;  // 72 CPU-hours in all
  // The web page's files (web/ as built: docs/web.md), served at / and /web/...; empty or missing: no page.
  std::filesystem::path web_root;
};

class Server {
 public:
  explicit Server(ServeOptions options);  // opens the store (migrating it) and the queue, takes the lock
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, requeues jobs left running by a crash, starts the workers. Returns the bound port.
  int start();
  // Serves until stop() (blocks). Returns false when listening failed.
  bool serve();
  // Stops accepting requests, stops running jobs (they go back to the queue) and joins the workers.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The OpenAPI document (service/openapi.json, embedded at build time).
const std::string& openapi_json();

}  // namespace runout::service
