#pragma once
// The run store: one SQLite file (default `runout.db`) holding every finished run, its flattened metrics
// and its time series, keyed by the manifest hash (a run with the same inputs is not stored twice). The
// CLI and the HTTP service share it. docs/store.md describes the schema, migrations and crash safety.
// SQLite stays out of this header (pimpl).
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace runout {

class RunStore {
 public:
  // Opens or creates the file: WAL journal, synchronous FULL, busy_timeout 10 s, foreign keys on, then
  // applies the migrations it lacks. Throws std::runtime_error (naming the path) when the file cannot be
  // opened or its schema version is newer than this program knows.
  explicit RunStore(const std::filesystem::path& db_file);
  ~RunStore();
  RunStore(const RunStore&) = delete;
  RunStore& operator=(const RunStore&) = delete;

  const std::filesystem::path& path() const;
  int schema_version() const;       // the version of the opened file (== latest_schema_version() once open)
  static int latest_schema_version();  // the newest version this program knows

  struct RunRecord {
    std::string manifest_hash;  // identity: hex SHA-256 of the manifest
    std::string sweep;          // may be empty
    std::string variant;        // "C3", "G5"
    std::string scene;
    std::string fidelity;
    std::string status;         // completed | failed | stopped
    std::string metrics_json;   // text of metrics.json (may be empty for a run without metrics)
    std::string manifest_json;
    std::map<std::string, std::string> series_csv;  // "run" -> series/run.csv text, "section_S1" -> ...
  };

  // Stores the run, its flattened metrics and its series in one transaction. Idempotent: when a completed
  // run with the same manifest_hash exists, returns its id and changes nothing (even if the record differs);
  // a failed or stopped run with that hash is replaced (a retry).
  // Throws std::runtime_error on invalid metrics JSON (before anything is written) or a database error.
  int64_t put_run(const RunRecord& r);

  // The id of the run with this manifest hash, whatever its status (the caller checks the status).
  std::optional<int64_t> find_run(const std::string& manifest_hash) const;

  struct RunRow {
    int64_t id = 0;
    std::string manifest_hash, sweep, variant, scene, fidelity, status;
    std::string created_at;  // UTC, ISO 8601 ("2025-01-31T12:00:00.123Z")
  };
  std::optional<RunRow> get_run(int64_t run_id) const;
  std::vector<RunRow> list_runs(const std::string& sweep = {}) const;  // all runs, or one sweep's; by id

  // These throw std::runtime_error when no run has this id.
  std::map<std::string, double> metrics(int64_t run_id) const;  // flattened name -> value
  std::string metrics_json(int64_t run_id) const;               // as stored, byte for byte
  std::string manifest_json(int64_t run_id) const;
  std::vector<std::string> series_names(int64_t run_id) const;  // sorted
  // The CSV text of one series, byte for byte; nullopt when the run has no series of that name.
  std::optional<std::string> series_csv(int64_t run_id, const std::string& name) const;

  // `PRAGMA integrity_check`: "ok" for a sound file, otherwise SQLite's list of problems.
  std::string integrity_check() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Flattens metrics JSON (an object; empty text gives an empty map) to dotted names with numeric leaves;
// booleans are 0/1; strings, nulls and non-finite numbers are skipped: {"a":{"b":1}} -> "a.b" = 1.
// An array whose elements are all objects with a string "name", unique within the array, is indexed by
// name, prefixed by the string "type" when present:
//   "monitors":[{"type":"section","name":"S1","discharge_peak_m3_s":2}]
//     -> "monitors.section.S1.discharge_peak_m3_s" = 2
// Other arrays use the position: "x.0". Throws std::runtime_error on invalid JSON or a non-object root.
std::map<std::string, double> flatten_metrics(const std::string& metrics_json);

// Runs side by side against a baseline run. `runs` labels the columns: the variant name ("C3"), "#<id>"
// when it is empty, "C3#<id>" when two runs share it. One row per metric name present in any of the runs
// or the baseline, sorted by name: the baseline's value, each run's value and its difference in per cent,
// (v - base) / |base| * 100, absent when either value is missing or base is 0. An arrival that never happened
// (means_never) is no number: its value is absent and its `never` flag set, and no per cent is taken against it
// or of it (docs/store.md, "Never arrived").
// Throws std::runtime_error when an id is not in the store.
struct Comparison {
  std::string baseline;           // label of the baseline run
  std::vector<int64_t> run_ids;   // as given
  std::vector<std::string> runs;  // column labels, one per run id
  struct Row {
    std::string metric;
    std::optional<double> baseline;              // absent: missing, or never (baseline_never)
    bool baseline_never = false;                 // the baseline's arrival never happened
    std::vector<std::optional<double>> values;   // one per run; absent: missing, or never
    std::vector<bool> never;                     // one per run: its arrival never happened
    std::vector<std::optional<double>> percent;  // one per run
  };
  std::vector<Row> rows;
};

// Whether a stored value says "never" rather than a quantity: an arrival time (a name ending in
// arrival_time_s: sections' t_0, pressure probes, protected zones) of -1, as the monitors write it.
bool means_never(const std::string& metric, double value);
Comparison compare_runs(const RunStore& store, const std::vector<int64_t>& run_ids, int64_t baseline_id);

}  // namespace runout
