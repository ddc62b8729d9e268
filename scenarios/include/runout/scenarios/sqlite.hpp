#pragma once
// The project's one SQLite wrapper (issue 19), shared by the run store (scenarios/src/store.cpp) and the
// service's job queue (service/src/jobs.cpp), which open the same file: a connection with the store's settings
// (WAL, synchronous FULL, busy_timeout 10 s, foreign keys), prepared statements and BEGIN IMMEDIATE
// transactions. Errors are std::runtime_error naming the connection's role and path. Header-only: include it
// from .cpp files only (it pulls in <sqlite3.h>; link SQLite::SQLite3).
#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

namespace runout::sqlite {

struct Connection {
  std::string role;  // "run store", "job queue": the start of every error message
  std::filesystem::path path;
  sqlite3* db = nullptr;
  std::mutex mutex;  // one connection; callers serialise their use of it with this

  explicit Connection(std::string what) : role(std::move(what)) {}
  ~Connection() { close(); }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // Opens (or, with `create`, creates) the file with the project's settings. WAL is required: a reader must
  // never wait for a writer's fsync.
  void open(const std::filesystem::path& p, bool create) {
    path = p;
    const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0) | SQLITE_OPEN_FULLMUTEX;
    if (sqlite3_open_v2(p.c_str(), &db, flags, nullptr) != SQLITE_OK) {
      const std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
      close();
      throw std::runtime_error(role + " " + p.string() + ": opening: " + msg);
    }
    try {
      sqlite3_extended_result_codes(db, 1);
      if (sqlite3_busy_timeout(db, 10000) != SQLITE_OK) fail("setting busy_timeout");
      {
        sqlite3_stmt* s = nullptr;
        if (sqlite3_prepare_v2(db, "PRAGMA journal_mode = WAL", -1, &s, nullptr) != SQLITE_OK) fail("setting WAL");
        const bool row = sqlite3_step(s) == SQLITE_ROW;
        const char* mode = row ? reinterpret_cast<const char*>(sqlite3_column_text(s, 0)) : nullptr;
        const std::string got = mode ? mode : "";
        sqlite3_finalize(s);
        if (got != "wal")
          throw std::runtime_error(role + " " + path.string() + ": cannot use WAL journal mode (got \"" + got + "\")");
      }
      exec("PRAGMA synchronous = FULL", "setting synchronous");
      exec("PRAGMA foreign_keys = ON", "enabling foreign keys");
    } catch (...) {
      close();
      throw;
    }
  }
  void close() {
    if (db) sqlite3_close_v2(db);
    db = nullptr;
  }

  [[noreturn]] void fail(const std::string& what) const {
    std::string msg = role + " " + path.string() + ": " + what;
    if (db) msg += ": " + std::string(sqlite3_errmsg(db));
    throw std::runtime_error(msg);
  }
  // One or more statements without results; `what` names them in an error (default: the SQL itself).
  void exec(const std::string& sql, const std::string& what = {}) {
    char* err = nullptr;
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string msg = err ? err : sqlite3_errmsg(db);
      sqlite3_free(err);
      throw std::runtime_error(role + " " + path.string() + ": " + (what.empty() ? sql : what) + ": " + msg);
    }
  }
  int64_t last_insert_rowid() const { return sqlite3_last_insert_rowid(db); }
  int changes() const { return sqlite3_changes(db); }
};

// A prepared statement. Text is bound as a copy, so a temporary may be bound.
class Stmt {
 public:
  Stmt(const Connection& c, const std::string& sql) : c_(c) {
    if (sqlite3_prepare_v2(c.db, sql.c_str(), static_cast<int>(sql.size()), &s_, nullptr) != SQLITE_OK)
      c_.fail("preparing \"" + sql + "\"");
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, const std::string& v) {
    check(sqlite3_bind_text64(s_, i, v.data(), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8), "binding text");
    return *this;
  }
  Stmt& bind(int i, int64_t v) {
    check(sqlite3_bind_int64(s_, i, v), "binding integer");
    return *this;
  }
  Stmt& bind(int i, double v) {
    check(sqlite3_bind_double(s_, i, v), "binding real");
    return *this;
  }
  template <class T>
  Stmt& bind(int i, const std::optional<T>& v) {  // NULL when empty
    if (v) return bind(i, *v);
    check(sqlite3_bind_null(s_, i), "binding null");
    return *this;
  }
  // True for a row, false when done.
  bool step() {
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    c_.fail("executing \"" + std::string(sqlite3_sql(s_)) + "\"");
  }
  void reset() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }
  bool null(int col) const { return sqlite3_column_type(s_, col) == SQLITE_NULL; }
  std::string text(int col) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s_, col));
    return p ? std::string(p, static_cast<size_t>(sqlite3_column_bytes(s_, col))) : std::string();
  }
  int64_t int64(int col) const { return sqlite3_column_int64(s_, col); }
  double real(int col) const { return sqlite3_column_double(s_, col); }
  std::optional<int64_t> opt_int(int col) const { return null(col) ? std::nullopt : std::optional<int64_t>(int64(col)); }
  std::optional<double> opt_real(int col) const { return null(col) ? std::nullopt : std::optional<double>(real(col)); }
  std::optional<std::string> opt_text(int col) const {
    return null(col) ? std::nullopt : std::optional<std::string>(text(col));
  }

 private:
  void check(int rc, const char* what) {
    if (rc != SQLITE_OK) c_.fail(what);
  }
  const Connection& c_;
  sqlite3_stmt* s_ = nullptr;
};

// BEGIN IMMEDIATE: the write lock up front, so busy_timeout applies at the start rather than as a deadlock at
// the first write. Rolls back unless committed.
class Transaction {
 public:
  explicit Transaction(Connection& c) : c_(c) { c_.exec("BEGIN IMMEDIATE", "beginning a transaction"); }
  ~Transaction() {
    if (!done_) sqlite3_exec(c_.db, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() {
    c_.exec("COMMIT", "committing");
    done_ = true;
  }

 private:
  Connection& c_;
  bool done_ = false;
};

}  // namespace runout::sqlite
