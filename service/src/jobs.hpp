#pragma once
// The service's persistent job queue, in the same SQLite file as the run store; the service creates and
// migrates its own tables (kServiceMigrations in jobs.cpp, table service_schema_migrations; docs/service.md).
// States: queued -> running -> done | failed | cancelled.
// Every transition is one transaction (BEGIN IMMEDIATE, WAL, synchronous FULL); claiming a job is a single
// UPDATE ... WHERE status = 'queued' ... RETURNING, so two workers never get the same job.
// SQLite stays out of this header.
#include <cstdint>
#include <filesystem>
#include <map>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "runout/scenarios/cost_model.hpp"

namespace runout::service {

// What a new job is: the resolved scene (JSON text) and how it was made.
struct JobSpec {
  std::string scene_name;
  std::string scene_json;            // resolved: layout and fidelity applied
  std::optional<int64_t> scene_id;   // the stored base scene, when it came from one
  std::string fidelity = "standard"; // draft | standard | fine | custom
  std::optional<double> dp;          // custom dp
  std::string sweep, variant;        // sweep name (runs.sweep in the run store) and variant name
  int stage = 0;                     // a study sweep's stage (1 screening, 2 detailed); 0: not a study's job
  int64_t particles = 0;             // particle count of the resolved scene (fluid + boundary)
  double duration = 0;               // simulated seconds
  // From the priced scene (estimate_scene), for POST /estimate (the cost model, docs/tradeoff.md); not stored with the job.
  int64_t fluid_particles = 0, boundary_particles = 0;
  int dimensions = 0;
  double resolved_dp = 0;  // the particle spacing the scene was built at [m]
  CostFeatures cost;
  // The work budget (docs/service.md, "Limits"): the cost model's CPU-seconds (run time x threads) and who
  // submitted it (a label of the token, never the token); both stored with the job.
  double cpu_seconds = 0;
  std::string submitted_by;
};

// Predicted CPU-seconds of the jobs that are queued or running (a running job's by its remaining fraction).
struct Backlog {
  double total_cpu_s = 0;  // every submitter's
  double mine_cpu_s = 0;   // the one submitter's asked about
  int64_t jobs = 0;        // queued + running
};
// Called inside a submission's transaction, after the idempotency key was looked up and before anything is
// written: throwing refuses the submission (the transaction is rolled back).
using BudgetCheck = std::function<void(const Backlog&)>;

struct Job {
  int64_t id = 0;
  std::string status;  // queued | running | done | failed | cancelled
  std::string scene_name, scene_json;  // scene_json empty in lists
  std::optional<int64_t> scene_id;
  std::string fidelity;
  std::optional<double> dp;
  std::optional<int64_t> sweep_id;
  std::string sweep, variant;
  int stage = 0;  // JobSpec::stage
  std::optional<std::string> idempotency_key;
  int64_t particles = 0;
  double sim_time = 0, duration = 0;
  int64_t steps = 0;
  double wall_seconds = 0;
  std::optional<double> eta_seconds;
  int64_t attempts = 0;
  bool cancel_requested = false;
  std::optional<int64_t> run_id;
  bool reused = false;
  std::string out_dir, error;
  std::string created_at, updated_at;
  std::optional<std::string> started_at, finished_at;
};

struct SceneRow {
  int64_t id = 0;
  std::string name, content_hash, scene_json, structures_json, created_at;
};

struct SweepRow {
  int64_t id = 0;
  std::string name;
  std::optional<int64_t> scene_id;
  std::string fidelity;
  std::optional<std::string> idempotency_key;
  std::string created_at;
  bool study = false;           // a multi-fidelity study (docs/service.md, "Studies")
  bool study_released = false;  // its screening stage has been decided and its detailed jobs queued
};

// A study sweep's stored record: the plan written at submission (the detailed stage's candidate jobs and what
// deciding needs, JSON made by the server) and, once the screening stage has been decided, its outcome (JSON).
struct StudyRecord {
  std::string plan;
  std::optional<std::string> outcome;
};

class JobQueue {
 public:
  // Opens its own connections to a run store (RunStore's constructor made it) and creates or migrates the
  // service's tables in it.
  explicit JobQueue(const std::filesystem::path& db_file);
  ~JobQueue();
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  // A new queued job, or, when `key` names an existing job, that job (second = false) and nothing written.
  std::pair<Job, bool> submit(const JobSpec& spec, const std::optional<std::string>& key,
                              const BudgetCheck& budget = nullptr);
  // A sweep and its jobs in one transaction; with an existing key, the original sweep (second = false).
  // With `launched_runs_dir` (a sweep handed to an MPI launcher, sweep_launcher.hpp) the jobs start `running`
  // (attempt 1, out_dir DIR/sweep-<id>/runs/<sweep>/<variant>, where `runout sweep --out DIR/sweep-<id>/runs`
  // writes them), in the same transaction, so that no in-process worker claims them.
  std::pair<SweepRow, bool> submit_sweep(const std::string& name, std::optional<int64_t> scene_id,
                                         const std::string& fidelity, const std::vector<JobSpec>& jobs,
                                         const std::optional<std::string>& key,
                                         const std::optional<std::string>& launched_runs_dir = std::nullopt,
                                         const BudgetCheck& budget = nullptr,
                                         const std::optional<std::string>& study_plan = std::nullopt);
  // Study sweeps whose screening stage has ended (no stage-1 job queued or running) and is not yet decided.
  std::vector<int64_t> studies_to_decide() const;
  std::optional<StudyRecord> study(int64_t sweep_id) const;
  // Records the screening stage's outcome and queues the chosen detailed jobs (stage 2), in one transaction;
  // false (nothing written) when the study was already decided.
  bool decide_study(int64_t sweep_id, const std::string& outcome, const std::vector<JobSpec>& jobs);
  // The backlog of `submitter` and of all, from a connection of its own (GET /health: never behind a writer
  // or a long list). counts_by_status likewise.
  Backlog backlog(const std::string& submitter) const;

  std::optional<Job> get(int64_t id) const;
  // Without scene_json, by id; status and sweep filter when given; after_id: only ids above it (a page's cursor).
  std::vector<Job> list(const std::optional<std::string>& status, const std::optional<int64_t>& sweep_id,
                        int64_t limit, int64_t offset, const std::optional<int64_t>& after_id = std::nullopt) const;
  int64_t count(const std::optional<std::string>& status, const std::optional<int64_t>& sweep_id) const;
  std::map<std::string, int64_t> counts_by_status() const;
  std::optional<SweepRow> get_sweep(int64_t id) const;
  // Sweeps newest first; before_id: only ids below it (a page's cursor).
  std::vector<SweepRow> list_sweeps(int64_t limit, const std::optional<int64_t>& before_id) const;
  // Jobs per status of the sweeps with ids in [min_id, max_id]: sweep id -> status -> count.
  std::map<int64_t, std::map<std::string, int64_t>> sweep_job_counts(int64_t min_id, int64_t max_id) const;
  // The directory of a finished job that produced this run's outputs (for a job that reused a stored run).
  std::optional<std::string> out_dir_of_run(int64_t run_id) const;

  // Base scenes, deduplicated by content hash (second = false when already stored).
  std::pair<SceneRow, bool> put_scene(const std::string& name, const std::string& content_hash,
                                      const std::string& scene_json, const std::string& structures_json);
  std::optional<SceneRow> get_scene(int64_t id) const;
  // A stored scene's document, parsed once per process (a stored scene never changes; at most 256 kept, the
  // lowest ids out first), so that a job naming it parses only its own request; nullptr when no scene has this
  // id. Throws std::runtime_error if the stored text is not JSON.
  std::shared_ptr<const nlohmann::json> scene_document(int64_t id) const;
  std::optional<SceneRow> find_scene(const std::string& content_hash) const;  // without scene_json
  // Without scene_json, oldest first; after_id: only ids above it (a page's cursor).
  std::vector<SceneRow> list_scenes(int64_t limit, const std::optional<int64_t>& after_id) const;

  // Worker side. claim: the oldest queued job, now running (attempts + 1), or nothing.
  std::optional<Job> claim(const std::string& out_root);
  void progress(int64_t id, double sim_time, double duration, int64_t steps, double wall_seconds,
                std::optional<double> eta);
  // running -> done | failed | cancelled; false when the job was not running.
  bool finish(int64_t id, const std::string& status, std::optional<int64_t> run_id, bool reused,
              const std::string& error);
  bool requeue(int64_t id);  // running -> queued (shutdown while running)

  // DELETE /jobs/{id}: a queued job is cancelled at once; a running one is marked cancel_requested (its
  // worker stops it); a finished one is left as it is. nullopt: no such job.
  enum class CancelOutcome { cancelled, requested, already_cancelled, finished };
  std::optional<std::pair<CancelOutcome, Job>> cancel(int64_t id);

  // At start: jobs left running by a crash go back to the queue (or to cancelled if a cancel was asked).
  // Returns how many were requeued.
  int recover();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace runout::service
