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

namespace runout::service {

struct ServeOptions {
  std::string host = "127.0.0.1";
  int port = 8080;               // 0: any free port (printed on stdout as "listening on HOST:PORT")
  std::filesystem::path db = "runout.db";
  std::filesystem::path runs_dir = "runs";  // a job's outputs go to RUNS/service/job-<id>
  std::filesystem::path scene_dir = ".";    // relative file names in scenes (terrain.dem) resolve here
  int workers = 1;               // 0: accept and queue jobs, run none
  int threads_per_job = 0;       // OpenMP threads of one job; 0: the cores divided among the workers
  std::string token;             // bearer token for writes; empty: writes are open
  size_t max_body = 1 << 20;     // bytes
  int64_t particle_budget = 2'000'000;
  int http_threads = 16;         // request handler threads
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
