// The persistent job queue (docs/service.md, "Queue").
#include "jobs.hpp"

#include "runout/scenarios/sqlite.hpp"

#include <map>
#include <mutex>

#include <nlohmann/json.hpp>
#include <vector>
#include <stdexcept>

namespace runout::service {

namespace {

constexpr const char* kNow = "strftime('%Y-%m-%dT%H:%M:%fZ','now')";

// The project's one SQLite wrapper (runout/scenarios/sqlite.hpp), as the run store in the same file uses it.
struct Conn : sqlite::Connection {
  Conn() : sqlite::Connection("job queue") {}
};
using sqlite::Stmt;
using sqlite::Transaction;

// Columns of a job; `full` includes the scene JSON.
std::string job_columns(bool full) {
  return std::string("id, status, scene_name, ") + (full ? "scene_json" : "''") +
         ", scene_id, fidelity, dp, sweep_id, sweep, variant, idempotency_key, particles, sim_time, duration, "
         "steps, wall_seconds, eta_seconds, attempts, cancel_requested, run_id, reused, out_dir, error, created_at, "
         "updated_at, started_at, finished_at, stage";
}

Job read_job(const Stmt& s) {
  Job j;
  j.id = s.int64(0);
  j.status = s.text(1);
  j.scene_name = s.text(2);
  j.scene_json = s.text(3);
  j.scene_id = s.opt_int(4);
  j.fidelity = s.text(5);
  j.dp = s.opt_real(6);
  j.sweep_id = s.opt_int(7);
  j.sweep = s.text(8);
  j.variant = s.text(9);
  j.idempotency_key = s.opt_text(10);
  j.particles = s.int64(11);
  j.sim_time = s.real(12);
  j.duration = s.real(13);
  j.steps = s.int64(14);
  j.wall_seconds = s.real(15);
  j.eta_seconds = s.opt_real(16);
  j.attempts = s.int64(17);
  j.cancel_requested = s.int64(18) != 0;
  j.run_id = s.opt_int(19);
  j.reused = s.int64(20) != 0;
  j.out_dir = s.text(21);
  j.error = s.text(22);
  j.created_at = s.text(23);
  j.updated_at = s.text(24);
  j.started_at = s.opt_text(25);
  j.finished_at = s.opt_text(26);
  j.stage = static_cast<int>(s.int64(27));
  return j;
}

const char* kSweepColumns =
    "id, name, scene_id, fidelity, idempotency_key, created_at, study IS NOT NULL, study_outcome IS NOT NULL";
SweepRow read_sweep(const Stmt& s) {
  return {s.int64(0), s.text(1), s.opt_int(2), s.text(3), s.opt_text(4), s.text(5), s.int64(6) != 0, s.int64(7) != 0};
}

std::optional<Job> get_job(const Conn& c, int64_t id, bool full = true) {
  Stmt s(c, "SELECT " + job_columns(full) + " FROM jobs WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_job(s);
}

int64_t insert_job(Conn& c, const JobSpec& spec, std::optional<int64_t> sweep_id, const std::optional<std::string>& key) {
  Stmt ins(c, std::string("INSERT INTO jobs(status, scene_name, scene_json, scene_id, fidelity, dp, sweep_id, sweep, "
                          "variant, idempotency_key, particles, duration, cpu_seconds, submitted_by, stage, created_at, "
                          "updated_at) VALUES ('queued', ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ") +
                  kNow + ", " + kNow + ")");
  ins.bind(1, spec.scene_name).bind(2, spec.scene_json).bind(3, spec.scene_id).bind(4, spec.fidelity).bind(5, spec.dp);
  ins.bind(6, sweep_id).bind(7, spec.sweep).bind(8, spec.variant).bind(9, key).bind(10, spec.particles);
  ins.bind(11, spec.duration).bind(12, spec.cpu_seconds).bind(13, spec.submitted_by);
  ins.bind(14, static_cast<int64_t>(spec.stage));
  ins.step();
  return sqlite3_last_insert_rowid(c.db);
}

// A running job counts by the fraction it has left.
const char* kRemainingCpu =
    "cpu_seconds * CASE WHEN status = 'running' AND duration > 0 THEN MAX(0.0, 1.0 - sim_time / duration) ELSE 1.0 END";

Backlog read_backlog(const Conn& c, const std::string& submitter) {
  Stmt s(c, std::string("SELECT COALESCE(SUM(") + kRemainingCpu + "), 0), COALESCE(SUM(CASE WHEN submitted_by = ?1 THEN " +
                kRemainingCpu + " ELSE 0 END), 0), COUNT(*) FROM jobs WHERE status IN ('queued', 'running')");
  s.bind(1, submitter);
  s.step();
  return {s.real(0), s.real(1), s.int64(2)};
}

// The service's own schema versions (service_schema_migrations), beside the run store's schema_migrations:
// entry i takes the service's tables from version i to i + 1, each in its own BEGIN IMMEDIATE with its row.
const std::vector<const char*> kServiceMigrations = {
    // 1: stored base scenes, sweeps submitted over HTTP and the job queue. Files made before issue 19 have them
    // from the run store's migration 2 (scenarios/src/store.cpp), hence IF NOT EXISTS: those are left as they are.
    R"sql(
CREATE TABLE IF NOT EXISTS service_scenes (
  id           INTEGER PRIMARY KEY,
  name         TEXT NOT NULL,
  content_hash TEXT NOT NULL UNIQUE,
  scene_json   TEXT NOT NULL,
  structures   TEXT NOT NULL DEFAULT '[]',
  created_at   TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS service_sweeps (
  id              INTEGER PRIMARY KEY,
  name            TEXT NOT NULL,
  scene_id        INTEGER REFERENCES service_scenes(id),
  fidelity        TEXT NOT NULL,
  idempotency_key TEXT UNIQUE,
  created_at      TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS jobs (
  id               INTEGER PRIMARY KEY,
  status           TEXT NOT NULL CHECK (status IN ('queued', 'running', 'done', 'failed', 'cancelled')),
  scene_name       TEXT NOT NULL DEFAULT '',
  scene_json       TEXT NOT NULL,
  scene_id         INTEGER REFERENCES service_scenes(id),
  fidelity         TEXT NOT NULL,
  dp               REAL,
  sweep_id         INTEGER REFERENCES service_sweeps(id),
  sweep            TEXT NOT NULL DEFAULT '',
  variant          TEXT NOT NULL DEFAULT '',
  idempotency_key  TEXT UNIQUE,
  particles        INTEGER NOT NULL DEFAULT 0,
  sim_time         REAL NOT NULL DEFAULT 0,
  duration         REAL NOT NULL DEFAULT 0,
  steps            INTEGER NOT NULL DEFAULT 0,
  wall_seconds     REAL NOT NULL DEFAULT 0,
  eta_seconds      REAL,
  attempts         INTEGER NOT NULL DEFAULT 0,
  cancel_requested INTEGER NOT NULL DEFAULT 0,
  run_id           INTEGER REFERENCES runs(id) ON DELETE SET NULL,
  reused           INTEGER NOT NULL DEFAULT 0,
  out_dir          TEXT NOT NULL DEFAULT '',
  error            TEXT NOT NULL DEFAULT '',
  created_at       TEXT NOT NULL,
  started_at       TEXT,
  finished_at      TEXT,
  updated_at       TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS jobs_status ON jobs(status, id);
CREATE INDEX IF NOT EXISTS jobs_sweep ON jobs(sweep_id, id);
CREATE INDEX IF NOT EXISTS jobs_run ON jobs(run_id);
)sql",
    // 2: the work budget: each job's predicted CPU-seconds and its submitter (a token's label).
    "ALTER TABLE jobs ADD COLUMN cpu_seconds REAL NOT NULL DEFAULT 0;"
    "ALTER TABLE jobs ADD COLUMN submitted_by TEXT NOT NULL DEFAULT '';",
    // 3: multi-fidelity studies (docs/service.md, "Studies"): a study sweep's plan and, once its screening stage
    // is decided, the outcome; each job's stage.
    "ALTER TABLE service_sweeps ADD COLUMN study TEXT;"
    "ALTER TABLE service_sweeps ADD COLUMN study_outcome TEXT;"
    "ALTER TABLE jobs ADD COLUMN stage INTEGER NOT NULL DEFAULT 0;",
};

int service_version(Conn& c) {
  Stmt s(c, "SELECT COALESCE(MAX(version), 0) FROM service_schema_migrations");
  s.step();
  return static_cast<int>(s.int64(0));
}

void migrate_service(Conn& c) {
  c.exec("CREATE TABLE IF NOT EXISTS service_schema_migrations (version INTEGER PRIMARY KEY, applied_at TEXT NOT NULL)");
  const int known = static_cast<int>(kServiceMigrations.size());
  if (service_version(c) > known)
    throw std::runtime_error("job queue " + c.path.string() + ": the service's schema version " +
                             std::to_string(service_version(c)) + " is newer than this program knows (" +
                             std::to_string(known) + ")");
  for (;;) {
    std::lock_guard lock(c.mutex);
    Transaction tx(c);
    const int v = service_version(c);  // re-read under the write lock: another process may have migrated
    if (v >= known) {
      tx.commit();
      return;
    }
    c.exec(kServiceMigrations[static_cast<size_t>(v)]);
    Stmt row(c, std::string("INSERT INTO service_schema_migrations(version, applied_at) VALUES (?, ") + kNow + ")");
    row.bind(1, static_cast<int64_t>(v + 1));
    row.step();
    tx.commit();
  }
}

}  // namespace

struct JobQueue::Impl {
  Conn writer;   // every write, in BEGIN IMMEDIATE transactions
  Conn reader;   // reads (WAL: never blocked by the writer)
  Conn monitor;  // GET /health's reads: not behind a long list on `reader`
  std::mutex documents_mutex;
  std::map<int64_t, std::shared_ptr<const nlohmann::json>> documents;  // scene_document's, by scene id
};

JobQueue::JobQueue(const std::filesystem::path& db_file) : impl_(std::make_unique<Impl>()) {
  impl_->writer.open(db_file, false);  // not created here: the run store makes the file
  impl_->reader.open(db_file, false);
  impl_->monitor.open(db_file, false);
  {
    // The jobs refer to the run store's runs: the file must be a run store (RunStore's constructor made it).
    Stmt has(impl_->reader, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'runs'");
    if (!has.step())
      throw std::runtime_error("job queue " + db_file.string() + ": not a run store (open the file with RunStore first)");
  }
  migrate_service(impl_->writer);
}

Backlog JobQueue::backlog(const std::string& submitter) const {
  std::lock_guard lock(impl_->monitor.mutex);
  return read_backlog(impl_->monitor, submitter);
}

JobQueue::~JobQueue() = default;

std::pair<Job, bool> JobQueue::submit(const JobSpec& spec, const std::optional<std::string>& key,
                                      const BudgetCheck& budget) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  if (key) {
    Stmt f(c, "SELECT id FROM jobs WHERE idempotency_key = ?");
    f.bind(1, *key);
    if (f.step()) {
      const int64_t id = f.int64(0);
      tx.commit();
      return {*get_job(c, id), false};
    }
  }
  if (budget) budget(read_backlog(c, spec.submitted_by));
  const int64_t id = insert_job(c, spec, std::nullopt, key);
  auto job = get_job(c, id);
  tx.commit();
  return {*job, true};
}

std::pair<SweepRow, bool> JobQueue::submit_sweep(const std::string& name, std::optional<int64_t> scene_id,
                                                 const std::string& fidelity, const std::vector<JobSpec>& jobs,
                                                 const std::optional<std::string>& key,
                                                 const std::optional<std::string>& launched_runs_dir,
                                                 const BudgetCheck& budget,
                                                 const std::optional<std::string>& study_plan) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  if (key) {
    Stmt f(c, std::string("SELECT ") + kSweepColumns + " FROM service_sweeps WHERE idempotency_key = ?");
    f.bind(1, *key);
    if (f.step()) {
      SweepRow row = read_sweep(f);
      tx.commit();
      return {row, false};
    }
  }
  if (budget) budget(read_backlog(c, jobs.empty() ? std::string() : jobs.front().submitted_by));
  Stmt ins(c, std::string("INSERT INTO service_sweeps(name, scene_id, fidelity, idempotency_key, study, created_at) "
                          "VALUES (?, ?, ?, ?, ?, ") + kNow + ")");
  ins.bind(1, name).bind(2, scene_id).bind(3, fidelity).bind(4, key).bind(5, study_plan);
  ins.step();
  const int64_t sweep_id = sqlite3_last_insert_rowid(c.db);
  for (const auto& j : jobs) {
    const int64_t id = insert_job(c, j, sweep_id, std::nullopt);
    if (launched_runs_dir) {
      Stmt run(c, std::string("UPDATE jobs SET status = 'running', attempts = 1, out_dir = ?, started_at = ") + kNow +
                      " WHERE id = ?");
      const auto out = std::filesystem::path(*launched_runs_dir) / ("sweep-" + std::to_string(sweep_id)) / "runs";
      run.bind(1, (out / j.sweep / j.variant).string()).bind(2, id);
      run.step();
    }
  }
  Stmt s(c, std::string("SELECT ") + kSweepColumns + " FROM service_sweeps WHERE id = ?");
  s.bind(1, sweep_id);
  s.step();
  SweepRow row = read_sweep(s);
  tx.commit();
  return {row, true};
}

std::vector<int64_t> JobQueue::studies_to_decide() const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader,
         "SELECT id FROM service_sweeps AS w WHERE study IS NOT NULL AND study_outcome IS NULL AND NOT EXISTS "
         "(SELECT 1 FROM jobs WHERE sweep_id = w.id AND stage = 1 AND status IN ('queued', 'running')) ORDER BY id");
  std::vector<int64_t> out;
  while (s.step()) out.push_back(s.int64(0));
  return out;
}

std::optional<StudyRecord> JobQueue::study(int64_t sweep_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT study, study_outcome FROM service_sweeps WHERE id = ? AND study IS NOT NULL");
  s.bind(1, sweep_id);
  if (!s.step()) return std::nullopt;
  return StudyRecord{s.text(0), s.opt_text(1)};
}

bool JobQueue::decide_study(int64_t sweep_id, const std::string& outcome, const std::vector<JobSpec>& jobs) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt set(c, "UPDATE service_sweeps SET study_outcome = ? WHERE id = ? AND study IS NOT NULL AND study_outcome IS NULL");
  set.bind(1, outcome).bind(2, sweep_id);
  set.step();
  if (sqlite3_changes(c.db) == 0) {
    tx.commit();
    return false;
  }
  for (const auto& j : jobs) insert_job(c, j, sweep_id, std::nullopt);
  tx.commit();
  return true;
}

std::optional<Job> JobQueue::get(int64_t id) const {
  std::lock_guard lock(impl_->reader.mutex);
  return get_job(impl_->reader, id);
}

namespace {
std::string where_clause(const std::optional<std::string>& status, const std::optional<int64_t>& sweep_id,
                         const std::optional<int64_t>& after_id = std::nullopt) {
  std::string w;
  auto add = [&](const char* cond) { w += std::string(w.empty() ? " WHERE " : " AND ") + cond; };
  if (status) add("status = ?1");
  if (sweep_id) add("sweep_id = ?2");
  if (after_id) add("id > ?5");
  return w;
}
}  // namespace

std::vector<Job> JobQueue::list(const std::optional<std::string>& status, const std::optional<int64_t>& sweep_id,
                                int64_t limit, int64_t offset, const std::optional<int64_t>& after_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT " + job_columns(false) + " FROM jobs" + where_clause(status, sweep_id, after_id) +
                            " ORDER BY id LIMIT ?3 OFFSET ?4");
  if (status) s.bind(1, *status);
  if (sweep_id) s.bind(2, *sweep_id);
  if (after_id) s.bind(5, *after_id);
  s.bind(3, limit).bind(4, offset);
  std::vector<Job> out;
  while (s.step()) out.push_back(read_job(s));
  return out;
}

int64_t JobQueue::count(const std::optional<std::string>& status, const std::optional<int64_t>& sweep_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT COUNT(*) FROM jobs" + where_clause(status, sweep_id));
  if (status) s.bind(1, *status);
  if (sweep_id) s.bind(2, *sweep_id);
  s.step();
  return s.int64(0);
}

std::vector<SweepRow> JobQueue::list_sweeps(int64_t limit, const std::optional<int64_t>& before_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, std::string("SELECT ") + kSweepColumns + " FROM service_sweeps" +
                            (before_id ? " WHERE id < ?2" : "") + " ORDER BY id DESC LIMIT ?1");
  s.bind(1, limit);
  if (before_id) s.bind(2, *before_id);
  std::vector<SweepRow> out;
  while (s.step()) out.push_back(read_sweep(s));
  return out;
}

std::map<int64_t, std::map<std::string, int64_t>> JobQueue::sweep_job_counts(int64_t min_id, int64_t max_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader,
         "SELECT sweep_id, status, COUNT(*) FROM jobs WHERE sweep_id BETWEEN ?1 AND ?2 GROUP BY sweep_id, status");
  s.bind(1, min_id).bind(2, max_id);
  std::map<int64_t, std::map<std::string, int64_t>> out;
  while (s.step()) out[s.int64(0)][s.text(1)] = s.int64(2);
  return out;
}

std::map<std::string, int64_t> JobQueue::counts_by_status() const {
  std::lock_guard lock(impl_->monitor.mutex);
  std::map<std::string, int64_t> out{{"queued", 0}, {"running", 0}, {"done", 0}, {"failed", 0}, {"cancelled", 0}};
  Stmt s(impl_->monitor, "SELECT status, COUNT(*) FROM jobs GROUP BY status");
  while (s.step()) out[s.text(0)] = s.int64(1);
  return out;
}

std::optional<SweepRow> JobQueue::get_sweep(int64_t id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, std::string("SELECT ") + kSweepColumns + " FROM service_sweeps WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_sweep(s);
}

std::optional<std::string> JobQueue::out_dir_of_run(int64_t run_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT out_dir FROM jobs WHERE run_id = ? AND reused = 0 AND out_dir <> '' ORDER BY id LIMIT 1");
  s.bind(1, run_id);
  if (!s.step()) return std::nullopt;
  return s.text(0);
}

std::pair<SceneRow, bool> JobQueue::put_scene(const std::string& name, const std::string& content_hash,
                                              const std::string& scene_json, const std::string& structures_json) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt ins(c, std::string("INSERT INTO service_scenes(name, content_hash, scene_json, structures, created_at) "
                          "VALUES (?, ?, ?, ?, ") + kNow + ") ON CONFLICT(content_hash) DO NOTHING");
  ins.bind(1, name).bind(2, content_hash).bind(3, scene_json).bind(4, structures_json);
  ins.step();
  const bool created = sqlite3_changes(c.db) > 0;
  Stmt s(c, "SELECT id, name, content_hash, scene_json, structures, created_at FROM service_scenes WHERE content_hash = ?");
  s.bind(1, content_hash);
  if (!s.step()) c.fail("scene vanished");
  SceneRow row{s.int64(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5)};
  tx.commit();
  return {row, created};
}

std::optional<SceneRow> JobQueue::get_scene(int64_t id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT id, name, content_hash, scene_json, structures, created_at FROM service_scenes WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return SceneRow{s.int64(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5)};
}

std::shared_ptr<const nlohmann::json> JobQueue::scene_document(int64_t id) const {
  {
    std::lock_guard lock(impl_->documents_mutex);
    if (auto it = impl_->documents.find(id); it != impl_->documents.end()) return it->second;
  }
  const auto row = get_scene(id);
  if (!row) return nullptr;
  auto doc = std::make_shared<const nlohmann::json>(nlohmann::json::parse(row->scene_json, nullptr, false));
  if (doc->is_discarded()) throw std::runtime_error("stored scene " + std::to_string(id) + " is not JSON");
  std::lock_guard lock(impl_->documents_mutex);
  if (impl_->documents.size() >= 256) impl_->documents.erase(impl_->documents.begin());
  impl_->documents.emplace(id, doc);
  return doc;
}

std::optional<SceneRow> JobQueue::find_scene(const std::string& content_hash) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, "SELECT id, name, content_hash, '', structures, created_at FROM service_scenes WHERE content_hash = ?");
  s.bind(1, content_hash);
  if (!s.step()) return std::nullopt;
  return SceneRow{s.int64(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5)};
}

std::vector<SceneRow> JobQueue::list_scenes(int64_t limit, const std::optional<int64_t>& after_id) const {
  std::lock_guard lock(impl_->reader.mutex);
  Stmt s(impl_->reader, std::string("SELECT id, name, content_hash, '', structures, created_at FROM service_scenes") +
                            (after_id ? " WHERE id > ?2" : "") + " ORDER BY id LIMIT ?1");
  s.bind(1, limit);
  if (after_id) s.bind(2, *after_id);
  std::vector<SceneRow> out;
  while (s.step()) out.push_back({s.int64(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5)});
  return out;
}

std::optional<Job> JobQueue::claim(const std::string& out_root) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt s(c, std::string("UPDATE jobs SET status = 'running', attempts = attempts + 1, sim_time = 0, steps = 0, "
                        "wall_seconds = 0, eta_seconds = NULL, error = '', out_dir = ?1 || '/job-' || id, "
                        "started_at = ") + kNow + ", updated_at = " + kNow +
                " WHERE id = (SELECT id FROM jobs WHERE status = 'queued' ORDER BY id LIMIT 1) AND status = 'queued' "
                "RETURNING " + job_columns(true));
  s.bind(1, out_root);
  std::optional<Job> job;
  if (s.step()) job = read_job(s);
  while (s.step()) {
  }
  s.reset();
  tx.commit();
  return job;
}

void JobQueue::progress(int64_t id, double sim_time, double duration, int64_t steps, double wall_seconds,
                        std::optional<double> eta) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt s(c, std::string("UPDATE jobs SET sim_time = ?, duration = ?, steps = ?, wall_seconds = ?, eta_seconds = ?, "
                        "updated_at = ") + kNow + " WHERE id = ? AND status = 'running'");
  s.bind(1, sim_time).bind(2, duration).bind(3, steps).bind(4, wall_seconds).bind(5, eta).bind(6, id);
  s.step();
  tx.commit();
}

bool JobQueue::finish(int64_t id, const std::string& status, std::optional<int64_t> run_id, bool reused,
                      const std::string& error) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt s(c, std::string("UPDATE jobs SET status = ?, run_id = ?, reused = ?, error = ?, eta_seconds = CASE WHEN ? = "
                        "'done' THEN 0 ELSE NULL END, finished_at = ") + kNow + ", updated_at = " + kNow +
                " WHERE id = ? AND status = 'running'");
  s.bind(1, status).bind(2, run_id).bind(3, static_cast<int64_t>(reused)).bind(4, error).bind(5, status).bind(6, id);
  s.step();
  const bool changed = sqlite3_changes(c.db) > 0;
  tx.commit();
  return changed;
}

bool JobQueue::requeue(int64_t id) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  Stmt s(c, std::string("UPDATE jobs SET status = 'queued', eta_seconds = NULL, updated_at = ") + kNow +
                " WHERE id = ? AND status = 'running'");
  s.bind(1, id);
  s.step();
  const bool changed = sqlite3_changes(c.db) > 0;
  tx.commit();
  return changed;
}

std::optional<std::pair<JobQueue::CancelOutcome, Job>> JobQueue::cancel(int64_t id) {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  auto job = get_job(c, id, false);
  if (!job) return std::nullopt;
  CancelOutcome outcome;
  if (job->status == "queued") {
    Stmt s(c, std::string("UPDATE jobs SET status = 'cancelled', cancel_requested = 1, finished_at = ") + kNow +
                  ", updated_at = " + kNow + " WHERE id = ? AND status = 'queued'");
    s.bind(1, id);
    s.step();
    outcome = CancelOutcome::cancelled;
  } else if (job->status == "running") {
    Stmt s(c, std::string("UPDATE jobs SET cancel_requested = 1, updated_at = ") + kNow +
                  " WHERE id = ? AND status = 'running'");
    s.bind(1, id);
    s.step();
    outcome = CancelOutcome::requested;
  } else if (job->status == "cancelled") {
    outcome = CancelOutcome::already_cancelled;
  } else {
    outcome = CancelOutcome::finished;
  }
  job = get_job(c, id, false);
  tx.commit();
  return std::make_pair(outcome, *job);
}

int JobQueue::recover() {
  Conn& c = impl_->writer;
  std::lock_guard lock(c.mutex);
  Transaction tx(c);
  {
    Stmt s(c, std::string("UPDATE jobs SET status = 'cancelled', finished_at = ") + kNow + ", updated_at = " + kNow +
                  " WHERE status = 'running' AND cancel_requested = 1");
    s.step();
  }
  Stmt s(c, std::string("UPDATE jobs SET status = 'queued', eta_seconds = NULL, updated_at = ") + kNow +
                " WHERE status = 'running'");
  s.step();
  const int n = sqlite3_changes(c.db);
  tx.commit();
  return n;
}

}  // namespace runout::service
