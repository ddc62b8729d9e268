// The service's own tables (issue 19): a file whose service tables were made by the run store's old
// migration 2 (before the service created its own) opens unchanged, keeps its jobs and scenes, and gains the
// service's later columns; a file made by `runout run`/`sweep` alone gets the service's tables on first serve.
#include "service/service_harness.hpp"

#include "runout/scenarios/store.hpp"

using namespace runout_test;

namespace {

// The service's tables exactly as scenarios/src/store.cpp's migration 2 created them before issue 19.
const char* kOldServiceTables = R"sql(
CREATE TABLE service_scenes (
  id           INTEGER PRIMARY KEY,
  name         TEXT NOT NULL,
  content_hash TEXT NOT NULL UNIQUE,
  scene_json   TEXT NOT NULL,
  structures   TEXT NOT NULL DEFAULT '[]',
  created_at   TEXT NOT NULL
);
CREATE TABLE service_sweeps (
  id              INTEGER PRIMARY KEY,
  name            TEXT NOT NULL,
  scene_id        INTEGER REFERENCES service_scenes(id),
  fidelity        TEXT NOT NULL,
  idempotency_key TEXT UNIQUE,
  created_at      TEXT NOT NULL
);
CREATE TABLE jobs (
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
CREATE INDEX jobs_status ON jobs(status, id);
CREATE INDEX jobs_sweep ON jobs(sweep_id, id);
CREATE INDEX jobs_run ON jobs(run_id);
)sql";

void exec(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &h), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(h);
  ASSERT_EQ(rc, SQLITE_OK) << msg;
}

class Schema : public ServiceTest {};

TEST_F(Schema, AFileWithTheRunStoresOldServiceTablesOpensAndKeepsItsJobs) {
  { runout::RunStore store(db_); }  // versions 1 and 2 of the run store
  exec(db_, kOldServiceTables);
  exec(db_, "INSERT INTO service_scenes(name, content_hash, scene_json, structures, created_at) "
            "VALUES ('old', 'h1', '{}', '[]', '2026-11-01T00:00:00Z');"
            "INSERT INTO jobs(status, scene_name, scene_json, fidelity, particles, duration, created_at, updated_at) "
            "VALUES ('done', 'old-job', '{}', 'draft', 268, 0.05, '2026-11-01T00:00:00Z', '2026-11-01T00:00:00Z');");
  start({"--workers", "0"});
  const Reply job = get("/jobs/1");
  ASSERT_EQ(job.status, 200) << job.text;
  EXPECT_EQ(job.body.at("scene_name"), "old-job");
  EXPECT_EQ(job.body.at("status"), "done");
  EXPECT_EQ(get("/scenes/1").body.at("name"), "old");
  const Reply health = get("/health");
  ASSERT_EQ(health.status, 200);
  EXPECT_EQ(health.body.at("backlog").at("jobs"), 0);  // a done job is no backlog
  // Version 3 (2026-12-07) added the studies: an old job is no study's.
  EXPECT_EQ(query_int("SELECT MAX(version) FROM service_schema_migrations"), 3);
  EXPECT_EQ(query_int("SELECT cpu_seconds FROM jobs WHERE id = 1"), 0);
  EXPECT_TRUE(job.body.at("stage").is_null()) << job.text;
  // New jobs go on after the old ones.
  const Reply next = post("/jobs", {{"scene", tiny_scene("new")}});
  ASSERT_EQ(next.status, 201) << next.text;
  EXPECT_EQ(next.body.at("id"), 2);
  EXPECT_GT(query_int("SELECT cpu_seconds * 1e9 FROM jobs WHERE id = 2"), 0);
}

TEST_F(Schema, ARunStoreWithoutServiceTablesGetsThemFromTheService) {
  { runout::RunStore store(db_); }
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM sqlite_master WHERE name IN ('jobs', 'service_scenes', 'service_sweeps')"), 0);
  start({"--workers", "0"});
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM sqlite_master WHERE name IN ('jobs', 'service_scenes', 'service_sweeps')"), 3);
  EXPECT_EQ(post("/jobs", {{"scene", tiny_scene("fresh")}}).status, 201);
  server_.terminate();
  start({"--workers", "0"});  // a second start migrates nothing and keeps the job
  EXPECT_EQ(query_int("SELECT COUNT(*) FROM service_schema_migrations"), 3);
  EXPECT_EQ(get("/jobs/1").status, 200);
}

}  // namespace
