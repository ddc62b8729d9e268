// The SQLite run store. docs/store.md describes the schema, migrations and crash safety.
#include "runout/scenarios/store.hpp"

#include "runout/scenarios/sqlite.hpp"

#include <cmath>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>

namespace runout {

namespace {

using json = nlohmann::json;

// The schema, one migration per entry: entry i takes the file from version i to version i + 1. Each is
// applied in its own transaction together with its schema_migrations row. Never edit an applied entry:
// append a new one.
const std::vector<std::string_view> kMigrations = {
    // 1: runs, their flattened metrics and their time series.
    R"sql(
CREATE TABLE schema_migrations (
  version    INTEGER PRIMARY KEY,
  applied_at TEXT NOT NULL
);
CREATE TABLE runs (
  id            INTEGER PRIMARY KEY,
  manifest_hash TEXT NOT NULL UNIQUE,
  sweep         TEXT NOT NULL DEFAULT '',
  variant       TEXT NOT NULL DEFAULT '',
  scene         TEXT NOT NULL DEFAULT '',
  fidelity      TEXT NOT NULL DEFAULT '',
  status        TEXT NOT NULL,
  metrics_json  TEXT NOT NULL DEFAULT '',
  manifest_json TEXT NOT NULL DEFAULT '',
  created_at    TEXT NOT NULL
);
CREATE INDEX runs_sweep ON runs(sweep);
CREATE TABLE metrics (
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name   TEXT NOT NULL,
  value  REAL NOT NULL,
  PRIMARY KEY (run_id, name)
) WITHOUT ROWID;
CREATE TABLE series (
  run_id INTEGER NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
  name   TEXT NOT NULL,
  csv    TEXT NOT NULL,
  PRIMARY KEY (run_id, name)
);
)sql",
    // 2: the HTTP service's tables (stored base scenes, sweeps, the job queue) were created here. The service
    // now creates and migrates them itself (service/src/jobs.cpp, kServiceMigrations; issue 19): files that
    // applied the old entry keep their tables, which the service's first migration finds (IF NOT EXISTS). The
    // entry stays, empty, so that the version numbers of existing files keep their meaning.
    R"sql(SELECT 1;)sql",
};

constexpr const char* kNow = "strftime('%Y-%m-%dT%H:%M:%fZ','now')";

void flatten_into(const json& j, const std::string& prefix, std::map<std::string, double>& out) {
  auto join = [&](const std::string& key) { return prefix.empty() ? key : prefix + "." + key; };
  switch (j.type()) {
    case json::value_t::object:
      for (const auto& [key, value] : j.items()) flatten_into(value, join(key), out);
      break;
    case json::value_t::array: {
      // Named elements ({"type": "section", "name": "S1", ...}) are keyed "section.S1" when every element
      // has a string name and the keys are unique; otherwise by position.
      std::vector<std::string> keys;
      std::set<std::string> seen;
      bool named = !j.empty();
      for (const auto& e : j) {
        if (!e.is_object() || !e.contains("name") || !e["name"].is_string()) {
          named = false;
          break;
        }
        std::string key = e["name"].get<std::string>();
        if (e.contains("type") && e["type"].is_string() && !e["type"].get<std::string>().empty())
          key = e["type"].get<std::string>() + "." + key;
        if (!seen.insert(key).second) {
          named = false;
          break;
        }
        keys.push_back(std::move(key));
      }
      for (std::size_t i = 0; i < j.size(); ++i)
        flatten_into(j[i], join(named ? keys[i] : std::to_string(i)), out);
      break;
    }
    case json::value_t::boolean:
      if (!prefix.empty()) out[prefix] = j.get<bool>() ? 1.0 : 0.0;
      break;
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: {
      const double v = j.get<double>();
      if (!prefix.empty() && std::isfinite(v)) out[prefix] = v;
      break;
    }
    default:  // strings, null, binary
      break;
  }
}

}  // namespace

std::map<std::string, double> flatten_metrics(const std::string& metrics_json) {
  std::map<std::string, double> out;
  if (metrics_json.find_first_not_of(" \t\r\n") == std::string::npos) return out;
  json j;
  try {
    j = json::parse(metrics_json);
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("metrics JSON is not valid: ") + e.what());
  }
  if (!j.is_object()) throw std::runtime_error("metrics JSON is not an object");
  flatten_into(j, "", out);
  return out;
}

// ---------------------------------------------------------------------------------------------------------

// The connection (the project's SQLite wrapper, runout/scenarios/sqlite.hpp, shared with the service's job
// queue); RunStore::Impl is this (a named type so the helpers below can take it).
namespace detail {
struct StoreDb : sqlite::Connection {
  StoreDb() : sqlite::Connection("run store") {}
  int version = 0;
};
}  // namespace detail

struct RunStore::Impl : detail::StoreDb {};

namespace {

using sqlite::Stmt;
using sqlite::Transaction;

int read_version(detail::StoreDb& impl) {
  Stmt has(impl, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'schema_migrations'");
  if (!has.step()) return 0;
  Stmt v(impl, "SELECT COALESCE(MAX(version), 0) FROM schema_migrations");
  v.step();
  return static_cast<int>(v.int64(0));
}

void refuse_newer(const detail::StoreDb& impl, int version) {
  throw std::runtime_error("run store " + impl.path.string() + ": schema version " + std::to_string(version) +
                           " is newer than this program knows (" + std::to_string(kMigrations.size()) +
                           "); use a newer runout or another file");
}

std::string run_columns() { return "id, manifest_hash, sweep, variant, scene, fidelity, status, created_at"; }

RunStore::RunRow read_row(const Stmt& s) {
  RunStore::RunRow r;
  r.id = s.int64(0);
  r.manifest_hash = s.text(1);
  r.sweep = s.text(2);
  r.variant = s.text(3);
  r.scene = s.text(4);
  r.fidelity = s.text(5);
  r.status = s.text(6);
  r.created_at = s.text(7);
  return r;
}

void require_run(const detail::StoreDb& impl, int64_t run_id) {
  Stmt s(impl, "SELECT 1 FROM runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step())
    throw std::runtime_error("run store " + impl.path.string() + ": no run with id " + std::to_string(run_id));
}

}  // namespace

RunStore::RunStore(const std::filesystem::path& db_file) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.open(db_file, true);  // WAL, synchronous FULL, busy_timeout 10 s, foreign keys
  try {
    const int known = static_cast<int>(kMigrations.size());
    m.version = read_version(m);
    if (m.version > known) refuse_newer(m, m.version);
    while (m.version < known) {
      Transaction tx(m);
      // Another process may have migrated since the read above: re-read under the write lock.
      const int v = read_version(m);
      if (v > known) refuse_newer(m, v);
      if (v < known) {
        m.exec(std::string(kMigrations[static_cast<std::size_t>(v)]).c_str(),
               "applying migration " + std::to_string(v + 1));
        Stmt rec(m, std::string("INSERT INTO schema_migrations(version, applied_at) VALUES (?, ") + kNow + ")");
        rec.bind(1, static_cast<int64_t>(v + 1));
        rec.step();
      }
      tx.commit();
      m.version = read_version(m);
    }
  } catch (...) {
    m.close();
    throw;
  }
}

RunStore::~RunStore() = default;  // the connection closes itself

const std::filesystem::path& RunStore::path() const { return impl_->path; }

int RunStore::schema_version() const { return impl_->version; }

int RunStore::latest_schema_version() { return static_cast<int>(kMigrations.size()); }

int64_t RunStore::put_run(const RunRecord& r) {
  if (r.manifest_hash.empty()) throw std::runtime_error("run store " + impl_->path.string() + ": empty manifest hash");
  if (r.status.empty()) throw std::runtime_error("run store " + impl_->path.string() + ": empty run status");
  const auto flat = flatten_metrics(r.metrics_json);  // invalid JSON is refused before anything is written

  Impl& m = *impl_;
  std::lock_guard lock(m.mutex);
  Transaction tx(m);
  {  // a failed or stopped run is replaced by its retry; a completed one is final
    Stmt del(m, "DELETE FROM runs WHERE manifest_hash = ? AND status <> 'completed'");
    del.bind(1, r.manifest_hash);
    del.step();
  }
  Stmt ins(m, std::string("INSERT INTO runs(manifest_hash, sweep, variant, scene, fidelity, status, metrics_json, "
                          "manifest_json, created_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ") +
                  kNow + ") ON CONFLICT(manifest_hash) DO NOTHING");
  ins.bind(1, r.manifest_hash).bind(2, r.sweep).bind(3, r.variant).bind(4, r.scene).bind(5, r.fidelity);
  ins.bind(6, r.status).bind(7, r.metrics_json).bind(8, r.manifest_json);
  ins.step();
  if (sqlite3_changes(m.db) == 0) {  // already stored: leave it as it is
    Stmt find(m, "SELECT id FROM runs WHERE manifest_hash = ?");
    find.bind(1, r.manifest_hash);
    if (!find.step()) m.fail("run " + r.manifest_hash + " conflicted but is not there");
    const int64_t id = find.int64(0);
    tx.commit();
    return id;
  }
  const int64_t id = sqlite3_last_insert_rowid(m.db);

  Stmt met(m, "INSERT INTO metrics(run_id, name, value) VALUES (?, ?, ?)");
  for (const auto& [name, value] : flat) {
    met.bind(1, id).bind(2, name).bind(3, value);
    met.step();
    met.reset();
  }
  Stmt ser(m, "INSERT INTO series(run_id, name, csv) VALUES (?, ?, ?)");
  for (const auto& [name, csv] : r.series_csv) {
    ser.bind(1, id).bind(2, name).bind(3, csv);
    ser.step();
    ser.reset();
  }
  tx.commit();
  return id;
}

std::optional<int64_t> RunStore::find_run(const std::string& manifest_hash) const {
  std::lock_guard lock(impl_->mutex);
  Stmt s(*impl_, "SELECT id FROM runs WHERE manifest_hash = ?");
  s.bind(1, manifest_hash);
  if (!s.step()) return std::nullopt;
  return s.int64(0);
}

std::optional<RunStore::RunRow> RunStore::get_run(int64_t run_id) const {
  std::lock_guard lock(impl_->mutex);
  Stmt s(*impl_, "SELECT " + run_columns() + " FROM runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step()) return std::nullopt;
  return read_row(s);
}

std::vector<RunStore::RunRow> RunStore::list_runs(const std::string& sweep) const {
  std::lock_guard lock(impl_->mutex);
  std::vector<RunRow> out;
  if (sweep.empty()) {
    Stmt s(*impl_, "SELECT " + run_columns() + " FROM runs ORDER BY id");
    while (s.step()) out.push_back(read_row(s));
  } else {
    Stmt s(*impl_, "SELECT " + run_columns() + " FROM runs WHERE sweep = ? ORDER BY id");
    s.bind(1, sweep);
    while (s.step()) out.push_back(read_row(s));
  }
  return out;
}

std::map<std::string, double> RunStore::metrics(int64_t run_id) const {
  std::lock_guard lock(impl_->mutex);
  require_run(*impl_, run_id);
  std::map<std::string, double> out;
  Stmt s(*impl_, "SELECT name, value FROM metrics WHERE run_id = ?");
  s.bind(1, run_id);
  while (s.step()) out.emplace(s.text(0), s.real(1));
  return out;
}

std::string RunStore::metrics_json(int64_t run_id) const {
  std::lock_guard lock(impl_->mutex);
  Stmt s(*impl_, "SELECT metrics_json FROM runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step()) require_run(*impl_, run_id);
  return s.text(0);
}

std::string RunStore::manifest_json(int64_t run_id) const {
  std::lock_guard lock(impl_->mutex);
  Stmt s(*impl_, "SELECT manifest_json FROM runs WHERE id = ?");
  s.bind(1, run_id);
  if (!s.step()) require_run(*impl_, run_id);
  return s.text(0);
}

std::vector<std::string> RunStore::series_names(int64_t run_id) const {
  std::lock_guard lock(impl_->mutex);
  require_run(*impl_, run_id);
  std::vector<std::string> out;
  Stmt s(*impl_, "SELECT name FROM series WHERE run_id = ? ORDER BY name");
  s.bind(1, run_id);
  while (s.step()) out.push_back(s.text(0));
  return out;
}

std::optional<std::string> RunStore::series_csv(int64_t run_id, const std::string& name) const {
  std::lock_guard lock(impl_->mutex);
  require_run(*impl_, run_id);
  Stmt s(*impl_, "SELECT csv FROM series WHERE run_id = ? AND name = ?");
  s.bind(1, run_id).bind(2, name);
  if (!s.step()) return std::nullopt;
  return s.text(0);
}

std::string RunStore::integrity_check() const {
  std::lock_guard lock(impl_->mutex);
  Stmt s(*impl_, "PRAGMA integrity_check");
  std::string out;
  while (s.step()) {
    if (!out.empty()) out += '\n';
    out += s.text(0);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------------

Comparison compare_runs(const RunStore& store, const std::vector<int64_t>& run_ids, int64_t baseline_id) {
  auto row_of = [&](int64_t id) {
    auto r = store.get_run(id);
    if (!r) throw std::runtime_error("run store " + store.path().string() + ": no run with id " + std::to_string(id));
    return *r;
  };
  std::map<std::string, int> label_count;
  auto label_of = [](const RunStore::RunRow& r) {
    if (!r.variant.empty()) return r.variant;
    std::string l = "#";
    l += std::to_string(r.id);
    return l;
  };

  const auto base_row = row_of(baseline_id);
  std::vector<RunStore::RunRow> rows;
  for (int64_t id : run_ids) rows.push_back(row_of(id));
  for (const auto& r : rows) ++label_count[label_of(r)];

  Comparison c;
  c.baseline = label_of(base_row);
  c.run_ids = run_ids;
  for (const auto& r : rows) {
    const std::string l = label_of(r);
    c.runs.push_back(label_count[l] > 1 && !r.variant.empty() ? l + "#" + std::to_string(r.id) : l);
  }

  const auto base = store.metrics(baseline_id);
  std::vector<std::map<std::string, double>> values;
  std::set<std::string> names;
  for (const auto& [n, v] : base) names.insert(n);
  for (int64_t id : run_ids) {
    values.push_back(store.metrics(id));
    for (const auto& [n, v] : values.back()) names.insert(n);
  }
  for (const auto& name : names) {
    Comparison::Row row;
    row.metric = name;
    if (auto it = base.find(name); it != base.end()) {
      row.baseline_never = means_never(name, it->second);
      if (!row.baseline_never) row.baseline = it->second;
    }
    for (const auto& vals : values) {
      std::optional<double> v;
      bool never = false;
      if (auto it = vals.find(name); it != vals.end()) {
        never = means_never(name, it->second);
        if (!never) v = it->second;
      }
      std::optional<double> pct;
      if (v && row.baseline && *row.baseline != 0.0) pct = (*v - *row.baseline) / std::abs(*row.baseline) * 100.0;
      row.values.push_back(v);
      row.never.push_back(never);
      row.percent.push_back(pct);
    }
    c.rows.push_back(std::move(row));
  }
  return c;
}

bool means_never(const std::string& metric, double value) {
  static constexpr std::string_view suffix = "arrival_time_s";
  return value < 0 && metric.size() >= suffix.size() &&
         metric.compare(metric.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace runout
