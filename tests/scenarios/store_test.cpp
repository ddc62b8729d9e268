// The run store (scenarios/src/store.cpp): metric flattening, round trips, idempotency by manifest hash,
// comparisons against a baseline, migrations and crash safety (a writer SIGKILLed mid-transaction).
// docs/store.md quotes the crash test's output ("[crash]" lines).
#include <gtest/gtest.h>

#include <signal.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>
#include <string>
#include <thread>
#include <vector>

// The test reads the file behind the store's back (row counts, a forged schema version). runout_scenarios
// links SQLite, so the library is there; only its header is used here.
#include <sqlite3.h>

#include <nlohmann/json.hpp>

#include "runout/scenarios/store.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace runout;

namespace {

const char* kExampleMetrics = R"({"boundary_tags": {"1": "tank"}, "dimensions": 2,
  "dt": {"last_s": 5.58e-05, "min_s": 4.19e-05},
  "energy": {"kinetic_final_j": 618.0, "potential_released_j": 741.5}, "front_x_m": 3.2, "leaks": 0,
  "mass": {"final_kg": 360.0, "initial_kg": 360.0, "relative_error": 0.0},
  "monitors": [{"type":"section","name":"S1","discharge_peak_m3_s":1.5,"arrival_time_s":0.3}],
  "particles": {"boundary": 2064, "fluid_final": 3600}, "scene": "dam-break-2d",
  "settings": {"kernel": "wendland", "dp_m": 0.01}, "status": "completed", "steps": 17380,
  "warnings": ["..."]})";

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("runout_store_test_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path file(const std::string& name) const { return dir_ / name; }

 private:
  fs::path dir_;
};

// Runs one query returning a single integer on a separate connection.
int64_t query_int(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  EXPECT_EQ(sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* s = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(h, sql.c_str(), -1, &s, nullptr), SQLITE_OK) << sqlite3_errmsg(h);
  EXPECT_EQ(sqlite3_step(s), SQLITE_ROW) << sqlite3_errmsg(h);
  const int64_t v = sqlite3_column_int64(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(h);
  return v;
}

void exec_sql(const fs::path& db, const std::string& sql) {
  sqlite3* h = nullptr;
  ASSERT_EQ(sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READWRITE, nullptr), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(h, sql.c_str(), nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(h);
}

RunStore::RunRecord record(const std::string& hash, const std::string& sweep, const std::string& variant,
                           const std::string& metrics) {
  RunStore::RunRecord r;
  r.manifest_hash = hash;
  r.sweep = sweep;
  r.variant = variant;
  r.scene = "flume";
  r.fidelity = "draft";
  r.status = "completed";
  r.metrics_json = metrics;
  r.manifest_json = R"({"scene_sha256": ")" + hash + R"("})";
  return r;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no exception)";
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Flattening

TEST(FlattenMetrics, ExampleGivesDottedNumericLeavesAndMonitorsByName) {
  const std::map<std::string, double> expected = {
      {"dimensions", 2},
      {"dt.last_s", 5.58e-05},
      {"dt.min_s", 4.19e-05},
      {"energy.kinetic_final_j", 618.0},
      {"energy.potential_released_j", 741.5},
      {"front_x_m", 3.2},
      {"leaks", 0},
      {"mass.final_kg", 360.0},
      {"mass.initial_kg", 360.0},
      {"mass.relative_error", 0.0},
      {"monitors.section.S1.arrival_time_s", 0.3},
      {"monitors.section.S1.discharge_peak_m3_s", 1.5},
      {"particles.boundary", 2064},
      {"particles.fluid_final", 3600},
      {"settings.dp_m", 0.01},
      {"steps", 17380},
  };
  // Exact equality: strings ("scene", "status", "settings.kernel", "boundary_tags.1", "warnings.0") are
  // not there, and the monitor is keyed by type and name, not "monitors.0".
  EXPECT_EQ(flatten_metrics(kExampleMetrics), expected);
}

TEST(FlattenMetrics, BooleansNullsPositionalArraysAndUntypedNames) {
  const auto m = flatten_metrics(R"({
    "ok": true, "bad": false, "nan_written_as_null": null,
    "x": [1.5, "s", {"y": 2}, [3]],
    "structures": [{"name": "Dam1", "load_kn": 10}, {"name": "Dam2", "load_kn": 20}],
    "dup": [{"name": "A", "v": 1}, {"name": "A", "v": 2}],
    "mixed": [{"name": "A", "v": 1}, {"v": 2}],
    "empty": [], "nested": {"deeper": {"deepest": -1}}
  })");
  const std::map<std::string, double> expected = {
      {"ok", 1},
      {"bad", 0},
      {"x.0", 1.5},
      {"x.2.y", 2},
      {"x.3.0", 3},
      {"structures.Dam1.load_kn", 10},  // no "type": the name alone
      {"structures.Dam2.load_kn", 20},
      {"dup.0.v", 1},  // repeated names: by position, so nothing is lost
      {"dup.1.v", 2},
      {"mixed.0.v", 1},  // not every element named: by position
      {"mixed.1.v", 2},
      {"nested.deeper.deepest", -1},
  };
  EXPECT_EQ(m, expected);
}

TEST(FlattenMetrics, EmptyTextIsEmptyAndBadJsonIsRefused) {
  EXPECT_TRUE(flatten_metrics("").empty());
  EXPECT_TRUE(flatten_metrics("{}").empty());
  EXPECT_NE(error_of([] { flatten_metrics("{\"a\": "); }).find("not valid"), std::string::npos);
  EXPECT_NE(error_of([] { flatten_metrics("[1, 2]"); }).find("not an object"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------------------
// Round trips

TEST(RunStore, PutThenGetRoundTripsMetricsJsonAndSeriesByteForByte) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);

  auto r = record("aa11", "flume", "C3", kExampleMetrics);
  r.series_csv["run"] = "t_s,front_x_m\r\n0,0.2\r\n0.1,0.35\r\n";  // CRLF kept
  r.series_csv["section_S1"] = std::string("t_s,q\n0,0\n") + "µ,\xce\xbb\n" + std::string(1, '\0') + "tail";
  r.series_csv["empty"] = "";
  const int64_t id = store.put_run(r);

  EXPECT_EQ(store.metrics(id), flatten_metrics(kExampleMetrics));
  EXPECT_EQ(store.metrics_json(id), r.metrics_json);
  EXPECT_EQ(store.manifest_json(id), r.manifest_json);
  EXPECT_EQ(store.series_names(id), (std::vector<std::string>{"empty", "run", "section_S1"}));
  for (const auto& [name, csv] : r.series_csv) {
    const auto got = store.series_csv(id, name);
    ASSERT_TRUE(got.has_value()) << name;
    EXPECT_EQ(*got, csv) << name;
    EXPECT_EQ(got->size(), csv.size()) << name;
  }
  EXPECT_FALSE(store.series_csv(id, "section_S9").has_value());

  const auto row = store.get_run(id);
  ASSERT_TRUE(row.has_value());
  EXPECT_EQ(row->manifest_hash, "aa11");
  EXPECT_EQ(row->sweep, "flume");
  EXPECT_EQ(row->variant, "C3");
  EXPECT_EQ(row->scene, "flume");
  EXPECT_EQ(row->fidelity, "draft");
  EXPECT_EQ(row->status, "completed");
  // UTC ISO 8601 with milliseconds: 2025-01-31T12:00:00.123Z
  ASSERT_EQ(row->created_at.size(), 24u) << row->created_at;
  EXPECT_EQ(row->created_at[10], 'T');
  EXPECT_EQ(row->created_at.back(), 'Z');

  EXPECT_EQ(store.find_run("aa11"), id);
  EXPECT_FALSE(store.find_run("bb22").has_value());
}

TEST(RunStore, ListRunsFiltersBySweepInIdOrder) {
  TempDir tmp;
  RunStore store(tmp.file("runout.db"));
  const int64_t c0 = store.put_run(record("h0", "flume", "C0", "{}"));
  const int64_t g0 = store.put_run(record("h1", "catchment", "G0", "{}"));
  const int64_t c1 = store.put_run(record("h2", "flume", "C1", "{}"));
  const int64_t single = store.put_run(record("h3", "", "", "{}"));

  auto ids = [](const std::vector<RunStore::RunRow>& rows) {
    std::vector<int64_t> out;
    for (const auto& r : rows) out.push_back(r.id);
    return out;
  };
  EXPECT_EQ(ids(store.list_runs("flume")), (std::vector<int64_t>{c0, c1}));
  EXPECT_EQ(ids(store.list_runs("catchment")), (std::vector<int64_t>{g0}));
  EXPECT_EQ(ids(store.list_runs()), (std::vector<int64_t>{c0, g0, c1, single}));
  EXPECT_TRUE(store.list_runs("nope").empty());
  EXPECT_EQ(store.list_runs("flume")[1].variant, "C1");
}

TEST(RunStore, UnknownRunIdAndBadInputAreErrorsNamingTheFile) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);
  const std::string e = error_of([&] { store.metrics(42); });
  EXPECT_NE(e.find("no run with id 42"), std::string::npos) << e;
  EXPECT_NE(e.find(db.string()), std::string::npos) << e;
  EXPECT_NE(error_of([&] { store.metrics_json(42); }).find("no run with id 42"), std::string::npos);
  EXPECT_NE(error_of([&] { store.series_names(42); }).find("no run with id 42"), std::string::npos);
  EXPECT_FALSE(store.get_run(42).has_value());

  // Invalid metrics JSON: refused, nothing written.
  EXPECT_NE(error_of([&] { store.put_run(record("bad", "", "", "{oops")); }).find("not valid"), std::string::npos);
  EXPECT_FALSE(store.find_run("bad").has_value());
  EXPECT_NE(error_of([&] { store.put_run(record("", "", "", "{}")); }).find("empty manifest hash"), std::string::npos);

  const std::string open_err = error_of([&] { RunStore bad(tmp.file("no/such/dir/runout.db")); });
  EXPECT_NE(open_err.find("no/such/dir/runout.db"), std::string::npos) << open_err;
  EXPECT_NE(open_err.find("unable to open"), std::string::npos) << open_err;
}

// ---------------------------------------------------------------------------------------------------------
// Idempotency

TEST(RunStore, SecondPutOfTheSameManifestReturnsTheSameIdAndChangesNothing) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);
  auto first = record("feedface", "flume", "C3", kExampleMetrics);
  first.series_csv["run"] = "t,x\n0,1\n";
  const int64_t id = store.put_run(first);

  auto again = first;
  again.status = "failed";
  again.metrics_json = R"({"steps": 1, "other": 2})";
  again.series_csv = {{"run", "changed"}, {"extra", "x"}};
  EXPECT_EQ(store.put_run(again), id);
  EXPECT_EQ(store.put_run(first), id);

  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM runs"), 1);
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM metrics"),
            static_cast<int64_t>(flatten_metrics(kExampleMetrics).size()));
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM series"), 1);
  EXPECT_EQ(store.get_run(id)->status, "completed");
  EXPECT_EQ(store.metrics_json(id), first.metrics_json);
  EXPECT_EQ(store.series_csv(id, "run"), "t,x\n0,1\n");

  // A second connection (the service next to the CLI) sees the same run and does not duplicate it.
  RunStore other(db);
  EXPECT_EQ(other.put_run(first), id);
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM runs"), 1);
}

TEST(RunStore, AFailedRunIsReplacedByItsRetryAndACompletedOneIsFinal) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);
  auto failed = record("cafe", "flume", "C1", R"({"steps": 10})");
  failed.status = "failed";
  failed.series_csv["run"] = "t\n0\n";
  store.put_run(failed);

  auto retry = record("cafe", "flume", "C1", kExampleMetrics);
  retry.series_csv["run"] = "t,x\n0,1\n1,2\n";
  const int64_t id = store.put_run(retry);
  EXPECT_EQ(store.get_run(id)->status, "completed");
  EXPECT_EQ(store.metrics_json(id), retry.metrics_json);
  EXPECT_EQ(store.series_csv(id, "run"), "t,x\n0,1\n1,2\n");
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM runs"), 1);
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM metrics"),
            static_cast<int64_t>(flatten_metrics(kExampleMetrics).size()));  // the failed run's rows went with it
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM series"), 1);
}

// ---------------------------------------------------------------------------------------------------------
// Comparison

TEST(CompareRuns, PercentAgainstBaselineAndNoneWhenBaseIsZeroOrMissing) {
  TempDir tmp;
  RunStore store(tmp.file("runout.db"));
  const int64_t base = store.put_run(record("b", "flume", "C0", R"({"a": 2, "b": 0, "c": -4, "only_base": 7})"));
  const int64_t r1 = store.put_run(record("r1", "flume", "C3", R"({"a": 3, "b": 1, "c": -2, "d": 5})"));
  const int64_t r2 = store.put_run(record("r2", "flume", "", R"({"b": 0, "c": -6})"));

  const Comparison c = compare_runs(store, {r1, r2}, base);
  EXPECT_EQ(c.baseline, "C0");
  EXPECT_EQ(c.runs, (std::vector<std::string>{"C3", "#" + std::to_string(r2)}));
  ASSERT_EQ(c.rows.size(), 5u);
  std::map<std::string, Comparison::Row> by;
  for (const auto& row : c.rows) by[row.metric] = row;
  EXPECT_EQ(c.rows[0].metric, "a");  // sorted by name
  EXPECT_EQ(c.rows[4].metric, "only_base");

  // a: base 2, run 3 -> +50 %; r2 lacks it.
  EXPECT_EQ(by["a"].baseline, 2.0);
  EXPECT_EQ(by["a"].values[0], 3.0);
  EXPECT_DOUBLE_EQ(*by["a"].percent[0], 50.0);
  EXPECT_FALSE(by["a"].values[1].has_value());
  EXPECT_FALSE(by["a"].percent[1].has_value());
  // b: base 0 -> values but no percent.
  EXPECT_EQ(by["b"].values[0], 1.0);
  EXPECT_FALSE(by["b"].percent[0].has_value());
  EXPECT_FALSE(by["b"].percent[1].has_value());
  // c: negative base divides by |base|: -4 -> -2 is +50 %, -4 -> -6 is -50 %.
  EXPECT_DOUBLE_EQ(*by["c"].percent[0], 50.0);
  EXPECT_DOUBLE_EQ(*by["c"].percent[1], -50.0);
  // d: no baseline value -> no percent.
  EXPECT_FALSE(by["d"].baseline.has_value());
  EXPECT_EQ(by["d"].values[0], 5.0);
  EXPECT_FALSE(by["d"].percent[0].has_value());
  // only_base: a row, with no run values.
  EXPECT_EQ(by["only_base"].baseline, 7.0);
  EXPECT_FALSE(by["only_base"].values[0].has_value());

  EXPECT_NE(error_of([&] { compare_runs(store, {r1, 999}, base); }).find("no run with id 999"), std::string::npos);
}

// An arrival time of -1 is "never", not a number: no value, its flag set, and no per cent against it or of it
// (before, a zone the flow never reached read -1 and -166.7 % against an arrival at 1.5 s).
TEST(CompareRuns, AnArrivalThatNeverHappenedIsNeverNotMinusOne) {
  TempDir tmp;
  RunStore store(tmp.file("runout.db"));
  const char* zone = "terrain.protected_zones.Village.arrival_time_s";
  auto metrics = [](double arrival, double depth) {
    return json{{"terrain", {{"protected_zones", {{{"name", "Village"}, {"arrival_time_s", arrival}, {"max_depth_m", depth}}}}}}}.dump();
  };
  const int64_t base = store.put_run(record("b", "flume", "C0", metrics(1.5, 0.2)));
  const int64_t never = store.put_run(record("n", "flume", "C4", metrics(-1, 0)));
  const int64_t later = store.put_run(record("l", "flume", "C2", metrics(2.0, 0.1)));

  const Comparison c = compare_runs(store, {never, later}, base);
  const auto row = std::find_if(c.rows.begin(), c.rows.end(), [&](const auto& r) { return r.metric == zone; });
  ASSERT_NE(row, c.rows.end());
  EXPECT_EQ(row->baseline, 1.5);
  EXPECT_FALSE(row->baseline_never);
  EXPECT_EQ(row->never, (std::vector<bool>{true, false}));
  EXPECT_FALSE(row->values[0].has_value());
  EXPECT_FALSE(row->percent[0].has_value());
  EXPECT_EQ(row->values[1], 2.0);
  EXPECT_NEAR(*row->percent[1], 33.333, 1e-3);
  // A depth of 0 is a depth, not "never".
  const auto depth = std::find_if(c.rows.begin(), c.rows.end(), [](const auto& r) { return r.metric.find("max_depth_m") != std::string::npos; });
  EXPECT_EQ(depth->never, (std::vector<bool>{false, false}));
  EXPECT_EQ(depth->values[0], 0.0);

  // Against a baseline that never arrived: no per cent, the runs' own times kept.
  const Comparison b = compare_runs(store, {base, never}, never);
  const auto brow = std::find_if(b.rows.begin(), b.rows.end(), [&](const auto& r) { return r.metric == zone; });
  EXPECT_TRUE(brow->baseline_never);
  EXPECT_FALSE(brow->baseline.has_value());
  EXPECT_EQ(brow->values[0], 1.5);
  EXPECT_FALSE(brow->percent[0].has_value());
  EXPECT_EQ(brow->never, (std::vector<bool>{false, true}));

  EXPECT_TRUE(means_never("monitors.section.S1.arrival_time_s", -1));
  EXPECT_FALSE(means_never("monitors.section.S1.arrival_time_s", 0));
  EXPECT_FALSE(means_never("monitors.structure_load.D.late_force_n", -1));  // a pull is a value
}

// ---------------------------------------------------------------------------------------------------------
// Migrations

TEST(RunStore, FreshFileGetsEveryMigrationWithItsRecord) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);
  EXPECT_EQ(store.schema_version(), RunStore::latest_schema_version());
  EXPECT_GE(RunStore::latest_schema_version(), 1);
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM schema_migrations"), RunStore::latest_schema_version());
  EXPECT_EQ(query_int(db, "SELECT MAX(version) FROM schema_migrations"), RunStore::latest_schema_version());
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM sqlite_master WHERE type = 'index' AND sql LIKE '%runs(sweep)%'"), 1);
}

TEST(RunStore, ReopeningKeepsDataAndVersion) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  int64_t id = 0;
  {
    RunStore store(db);
    auto r = record("keep", "flume", "C1", kExampleMetrics);
    r.series_csv["run"] = "t,x\n";
    id = store.put_run(r);
  }
  RunStore again(db);
  EXPECT_EQ(again.schema_version(), RunStore::latest_schema_version());
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM schema_migrations"), RunStore::latest_schema_version());
  EXPECT_EQ(again.find_run("keep"), id);
  EXPECT_EQ(again.metrics(id), flatten_metrics(kExampleMetrics));
  EXPECT_EQ(again.series_csv(id, "run"), "t,x\n");
}

TEST(RunStore, NewerSchemaVersionIsRefusedNamingBothVersions) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  { RunStore store(db); }
  exec_sql(db, "INSERT INTO schema_migrations(version, applied_at) VALUES (99, 'future')");
  const std::string e = error_of([&] { RunStore store(db); });
  EXPECT_NE(e.find("schema version 99"), std::string::npos) << e;
  EXPECT_NE(e.find("(" + std::to_string(RunStore::latest_schema_version()) + ")"), std::string::npos) << e;
  EXPECT_NE(e.find(db.string()), std::string::npos) << e;
}

TEST(RunStore, JournalIsWalAndForeignKeysCascade) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  RunStore store(db);
  auto r = record("fk", "", "", kExampleMetrics);
  r.series_csv["run"] = "x";
  const int64_t id = store.put_run(r);
  EXPECT_EQ(query_int(db, "SELECT journal_mode = 'wal' FROM pragma_journal_mode"), 1);
  // Deleting a run (by hand; the API has no delete) takes its metrics and series with it when foreign
  // keys are on, as they are on the store's connections.
  exec_sql(db, "PRAGMA foreign_keys = ON; DELETE FROM runs WHERE id = " + std::to_string(id));
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM metrics"), 0);
  EXPECT_EQ(query_int(db, "SELECT COUNT(*) FROM series"), 0);
  EXPECT_EQ(store.integrity_check(), "ok");
}

// ---------------------------------------------------------------------------------------------------------
// Crash safety: a child process writes runs with 2 MB series in a loop and is SIGKILLed by the parent
// ~200 ms after its first commit (three rounds wherever the child is, six rounds a few ms after a put
// started, aiming inside its transaction); the parent then opens the file and checks it. Nine rounds on
// the same file, so a recovered file is written and killed again.

namespace {

constexpr std::size_t kCrashCsvBytes = 2u << 20;

std::string crash_hash(int round, int i) { return "crash-" + std::to_string(round) + "-" + std::to_string(i); }

std::string crash_metrics(int round, int i) {
  return R"({"steps": )" + std::to_string(1000 + i) + R"(, "round": )" + std::to_string(round) +
         R"(, "mass": {"final_kg": 360.0, "relative_error": 0.0}, "monitors": [{"type": "section", "name": "S1",
         "discharge_peak_m3_s": )" + std::to_string(i * 0.5) + R"(}, {"type": "section", "name": "S2",
         "discharge_peak_m3_s": 1}], "status": "completed"})";
}

// Distinct per run, and cheap (a 64 KB block of lines repeated), so the child spends its time in put_run.
std::string crash_csv(int round, int i, std::size_t bytes) {
  std::string block;
  for (long k = 0; block.size() < (64u << 10); ++k)
    block += std::to_string(k) + "," + std::to_string(round * 1000 + i) + "," + std::to_string(k * 7 % 1013) + "\n";
  std::string s = "t_s,front_x_m,kinetic_j\n";
  s.reserve(bytes + block.size());
  while (s.size() < bytes) s += block;
  return s;
}

// What the kill left in the WAL (read before recovery): frames of the current WAL generation (salts match
// the header) and how many of them follow the last commit frame, i.e. belong to a transaction the kill
// interrupted and that recovery discards. Checksums are not verified; this is a report, not a check.
struct WalTail {
  bool header = false;  // a WAL header was there
  long frames = 0;
  long uncommitted = 0;
  // Killed inside a write transaction: frames after the last commit, or a new WAL generation begun (the
  // header is rewritten with new salts, and synced, before the transaction's first frame) with no frame yet.
  bool in_transaction() const { return uncommitted > 0 || (header && frames == 0); }
  std::string describe() const {
    if (uncommitted > 0) return "inside a transaction (" + std::to_string(uncommitted) + " uncommitted WAL frames)";
    if (header && frames == 0) return "inside a transaction (new WAL generation, no frame written yet)";
    return "between transactions (" + std::to_string(frames) + " WAL frames, all committed)";
  }
};
WalTail wal_tail(const fs::path& wal) {
  WalTail t;
  std::FILE* f = std::fopen(wal.c_str(), "rb");
  if (!f) return t;
  auto be32 = [](const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
  };
  unsigned char hdr[32];
  if (std::fread(hdr, 1, 32, f) == 32) {
    t.header = true;
    const uint32_t page = be32(hdr + 8), salt1 = be32(hdr + 16), salt2 = be32(hdr + 20);
    std::vector<unsigned char> frame(24 + page);
    while (std::fread(frame.data(), 1, frame.size(), f) == frame.size()) {
      if (be32(&frame[8]) != salt1 || be32(&frame[12]) != salt2) break;  // stale frame of an older generation
      ++t.frames;
      t.uncommitted = be32(&frame[4]) != 0 ? 0 : t.uncommitted + 1;  // non-zero: a commit frame
    }
  }
  std::fclose(f);
  return t;
}

RunStore::RunRecord crash_record(int round, int i) {
  auto r = record(crash_hash(round, i), "crash", "V" + std::to_string(i), crash_metrics(round, i));
  r.series_csv["run"] = crash_csv(round, i, kCrashCsvBytes);
  r.series_csv["section_S1"] = crash_csv(round, i, 4096);
  return r;
}

}  // namespace

TEST(RunStore, WriterKilledMidTransactionLeavesASoundFileWithWholeRuns) {
  TempDir tmp;
  const auto db = tmp.file("runout.db");
  const int rounds = 9;
  int total_committed = 0, interrupted = 0;

  for (int round = 0; round < rounds; ++round) {
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    std::fflush(nullptr);
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {  // child: write until killed; on the pipe, 2i before put i starts and 2i+1 once it returned
      ::close(fds[0]);
      try {
        RunStore store(db);
        for (int i = 0;; ++i) {
          const auto rec = crash_record(round, i);
          const int start = 2 * i, done = 2 * i + 1;
          if (::write(fds[1], &start, sizeof start) != sizeof start) ::_exit(3);
          store.put_run(rec);
          if (::write(fds[1], &done, sizeof done) != sizeof done) ::_exit(3);
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "child: %s\n", e.what());
        ::_exit(2);
      }
      ::_exit(4);
    }
    ::close(fds[1]);
    int acknowledged = 0, msg = -1;
    auto read_msg = [&] {
      const bool got = ::read(fds[0], &msg, sizeof msg) == static_cast<ssize_t>(sizeof msg);
      if (got && msg % 2 == 1) ++acknowledged;
      return got;
    };
    while (acknowledged == 0) ASSERT_TRUE(read_msg()) << "child ended before its first commit";
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    // Rounds 0-2 kill right after ~200 ms, wherever the child is (mostly in the WAL checkpoint that follows
    // a commit, the longest phase). Rounds 3-8 wait for the next put to start and kill 1-8 ms into it,
    // aiming at its write transaction.
    const int kIntoPutMs[] = {1, 2, 3, 4, 6, 8};
    const int into_put_ms = round < 3 ? -1 : kIntoPutMs[round - 3];
    if (into_put_ms >= 0) {
      ::fcntl(fds[0], F_SETFL, O_NONBLOCK);  // drain what is queued (older puts)
      while (read_msg()) {
      }
      ::fcntl(fds[0], F_SETFL, 0);
      do ASSERT_TRUE(read_msg()); while (msg % 2 != 0);
      std::this_thread::sleep_for(std::chrono::milliseconds(into_put_ms));
    }
    ASSERT_EQ(::kill(pid, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "child ended on its own, status " << status;
    ::fcntl(fds[0], F_SETFL, 0);
    while (read_msg()) {
    }
    ::close(fds[0]);
    const std::string when = into_put_ms < 0 ? "200 ms after the first commit"
                                             : std::to_string(into_put_ms) + " ms into a put, ~200 ms in";

    std::error_code ec;
    const auto wal_bytes = fs::file_size(fs::path(db.string() + "-wal"), ec);
    const WalTail tail = wal_tail(fs::path(db.string() + "-wal"));
    if (tail.in_transaction()) ++interrupted;

    RunStore store(db);  // recovery happens here
    const std::string integrity = store.integrity_check();
    EXPECT_EQ(integrity, "ok");

    // Every acknowledged run is there; at most the one in flight more (killed after COMMIT, before the ack).
    std::set<int> present;
    for (const auto& row : store.list_runs("crash")) {
      if (row.manifest_hash.rfind("crash-" + std::to_string(round) + "-", 0) != 0) continue;
      const int idx = std::stoi(row.manifest_hash.substr(row.manifest_hash.rfind('-') + 1));
      present.insert(idx);
      // A whole run: every metric row and every series, byte for byte.
      EXPECT_EQ(store.metrics(row.id), flatten_metrics(crash_metrics(round, idx))) << row.manifest_hash;
      EXPECT_EQ(store.series_names(row.id), (std::vector<std::string>{"run", "section_S1"})) << row.manifest_hash;
      const auto csv = store.series_csv(row.id, "run");
      ASSERT_TRUE(csv.has_value()) << row.manifest_hash;
      EXPECT_TRUE(*csv == crash_csv(round, idx, kCrashCsvBytes)) << row.manifest_hash << " series differs";
    }
    const int committed = static_cast<int>(present.size());
    EXPECT_GE(committed, acknowledged);
    EXPECT_LE(committed, acknowledged + 1);
    EXPECT_EQ(present.empty() ? -1 : *present.rbegin(), committed - 1) << "committed runs are not 0..n-1";
    total_committed += committed;

    std::cout << "[crash] round " << round << ": killed " << when << "; acknowledged "
              << acknowledged << ", committed " << committed << " runs of " << (kCrashCsvBytes >> 20)
              << " MB series; WAL " << wal_bytes << " bytes, killed " << tail.describe()
              << "; integrity_check " << integrity << "\n";

    // The file still takes writes.
    const int64_t id = store.put_run(record("after-" + std::to_string(round), "after", "X", kExampleMetrics));
    EXPECT_EQ(store.metrics(id), flatten_metrics(kExampleMetrics));
  }
  RunStore store(db);
  EXPECT_EQ(static_cast<int>(store.list_runs("crash").size()), total_committed);
  EXPECT_EQ(store.list_runs("after").size(), static_cast<std::size_t>(rounds));
  std::cout << "[crash] total: " << total_committed << " runs committed over " << rounds << " kills, "
            << interrupted << " of them inside a write transaction; file " << fs::file_size(db) << " bytes after reopen\n";
}
