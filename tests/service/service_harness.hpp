#pragma once
// Test harness for the HTTP service: starts the real `runout serve` binary as a child process on a free
// loopback port (--port 0; the port is read from the "listening on" line it prints), with a database and
// output folder in a scratch directory, and talks to it with httplib's client.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace runout_test {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

inline const std::string kRunout = RUNOUT_BINARY_DIR "/runout";

// A tiny 2D dam break: a water column of (w x h) m in a 0.4 x 0.3 m tank. At dp 0.02 and 0.2 x 0.2 m that is
// 100 fluid + 168 boundary particles; 0.05 s of simulated time takes well under a second.
inline json tiny_scene(const std::string& name, double duration = 0.05, double dp = 0.02, double w = 0.2,
                       double h = 0.2) {
  return {{"name", name},
          {"dimensions", 2},
          {"dp", dp},
          {"duration", duration},
          {"materials", json::array({{{"name", "water"}, {"rheology", "newtonian"}, {"density", 1000}, {"viscosity", 0.001}}})},
          {"fluid", json::array({{{"min", {0, 0}}, {"max", {w, h}}, {"material", "water"}}})},
          {"boundaries", json::array({{{"type", "tank"}, {"min", {0, 0}}, {"max", {0.4, 0.3}}}})}};
}

// The first invalid field of an RFC 9457 problem document (docs/service.md, "Errors"): {field, message}.
inline json first_error(const json& problem) {
  if (!problem.is_object() || !problem.contains("errors") || problem.at("errors").empty())
    return {{"field", "(no errors member)"}, {"message", problem.dump().substr(0, 300)}};
  return problem.at("errors").at(0);
}

// The media type of a reply's Content-Type, without parameters.
inline std::string media_type(const httplib::Headers& headers) {
  auto it = headers.find("Content-Type");
  if (it == headers.end()) return "";
  return it->second.substr(0, it->second.find(';'));
}

// A raw TCP connection to the server, optionally from another loopback address (127.0.0.2, ...): the
// server counts connections per client address.
class Raw {
 public:
  Raw(int port, const std::string& from = "127.0.0.1") {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from.c_str(), &local.sin_addr);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) throw std::runtime_error("bind " + from);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Raw() { ::close(fd_); }
  Raw(const Raw&) = delete;
  Raw& operator=(const Raw&) = delete;
  bool connected() const { return ok_; }
  void shutdown_write() { ::shutdown(fd_, SHUT_WR); }
  bool send(const std::string& s) {
    size_t off = 0;
    while (off < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (n <= 0) return false;
      off += static_cast<size_t>(n);
    }
    return true;
  }
  // Reads until one whole response (head and Content-Length body) has arrived, the peer closes, or the timeout.
  // A response to HEAD (`head_only`) has a Content-Length but no body.
  std::string response(std::chrono::milliseconds timeout = 5000ms, bool head_only = false) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      const size_t h = buf_.find("\r\n\r\n");
      if (h != std::string::npos) {
        std::smatch m;
        const std::string head = buf_.substr(0, h);
        const std::regex cl("Content-Length: ([0-9]+)", std::regex::icase);
        const size_t len = !head_only && std::regex_search(head, m, cl) ? std::stoul(m[1].str()) : 0;
        if (buf_.size() >= h + 4 + len) {
          std::string r = buf_.substr(0, h + 4 + len);
          buf_.erase(0, h + 4 + len);
          return r;
        }
      }
      if (!fill(end)) break;
    }
    std::string r = buf_;
    buf_.clear();
    return r;
  }
  // True when the server closes the connection (EOF or reset) before the timeout; what arrived is dropped.
  bool closed_within(std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      char b[4096];
      const ssize_t n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) return true;
    }
    return false;
  }

 private:
  bool fill(std::chrono::steady_clock::time_point end) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(std::max<int64_t>(1, left.count()))) <= 0) return true;
    char b[65536];
    const ssize_t n = ::recv(fd_, b, sizeof b, 0);
    if (n <= 0) return false;
    buf_.append(b, static_cast<size_t>(n));
    return true;
  }
  int fd_ = -1;
  bool ok_ = false;
  std::string buf_;
};

inline int status_of(const std::string& response) {
  std::smatch m;
  static const std::regex re(R"(^HTTP/1\.[01] ([0-9]{3}))");
  return std::regex_search(response, m, re) ? std::stoi(m[1].str()) : 0;
}

inline json body_of(const std::string& response) {
  const size_t h = response.find("\r\n\r\n");
  return h == std::string::npos ? json() : json::parse(response.substr(h + 4), nullptr, false);
}

class ServerProcess {
 public:
  ServerProcess() = default;
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;
  ~ServerProcess() { terminate(); }

  // Starts `runout serve --port 0 --db DB --runs DIR/runs ARGS...`; returns once it listens.
  void start(const fs::path& dir, const fs::path& db, const std::vector<std::string>& extra) {
    dir_ = dir;
    int out[2];
    if (::pipe(out) != 0) throw std::runtime_error("pipe");
    std::vector<std::string> args = {kRunout, "serve", "--port", "0", "--db", db.string(), "--runs", (dir / "runs").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    // The shipped studies' background checks (~50 s of CPU) only where a test asks for them: the others count
    // scenes and time answers.
    if (std::find(extra.begin(), extra.end(), "--shipped-studies") == extra.end())
      args.insert(args.end(), {"--shipped-studies", "off"});
    const std::string log = (dir / ("server-" + std::to_string(starts_++) + ".log")).string();
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork");
    if (pid_ == 0) {
      ::dup2(out[1], 1);
      ::close(out[0]);
      ::close(out[1]);
      std::FILE* err = std::fopen(log.c_str(), "w");
      if (err) ::dup2(fileno(err), 2);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(kRunout.c_str(), argv.data());
      std::_Exit(127);
    }
    ::close(out[1]);
    std::string text;
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    const std::regex re(R"(listening on http://[0-9.]+:([0-9]+))");
    std::smatch m;
    while (!std::regex_search(text, m, re)) {
      if (std::chrono::steady_clock::now() > deadline) break;
      pollfd p{out[0], POLLIN, 0};
      if (::poll(&p, 1, 200) <= 0) continue;
      char buf[512];
      const ssize_t n = ::read(out[0], buf, sizeof buf);
      if (n <= 0) break;
      text.append(buf, static_cast<size_t>(n));
    }
    ::close(out[0]);
    if (!std::regex_search(text, m, re)) {
      terminate();
      throw std::runtime_error("runout serve did not start: " + text + "\n" + log_text());
    }
    port_ = std::stoi(m[1].str());
  }

  int port() const { return port_; }
  pid_t pid() const { return pid_; }

  void kill9() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  // SIGTERM and wait; the exit status.
  int terminate() {
    if (pid_ <= 0) return -1;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return status;
  }
  std::string log_text() const {
    std::string all;
    for (int k = 0; k < starts_; ++k) {
      std::ifstream in(dir_ / ("server-" + std::to_string(k) + ".log"));
      std::stringstream s;
      s << in.rdbuf();
      all += s.str();
    }
    return all;
  }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
  int port_ = 0;
  int starts_ = 0;
};

// A scratch directory per test.
class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("runout_svc_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    db_ = dir_ / "runout.db";
  }
  void TearDown() override {
    server_.terminate();
    if (!HasFailure()) fs::remove_all(dir_);
    else std::cerr << "[service] kept " << dir_ << "; server log:\n" << server_.log_text() << "\n";
  }

  void start(const std::vector<std::string>& extra) { server_.start(dir_, db_, extra); }

  httplib::Client client() const {
    httplib::Client c("127.0.0.1", server_.port());
    c.set_connection_timeout(10);
    c.set_read_timeout(30);
    c.set_write_timeout(30);
    return c;
  }

  // A request; status and parsed JSON body (null when the body is not JSON).
  struct Reply {
    int status = 0;
    json body;
    std::string text;
    httplib::Headers headers;
  };
  Reply request(const std::string& method, const std::string& path, const std::string& body = {},
                httplib::Headers headers = {}, const std::string& content_type = "application/json") const {
    auto c = client();
    auto send = [&]() -> httplib::Result {
      if (method == "GET") return c.Get(path.c_str(), headers);
      if (method == "POST") return c.Post(path.c_str(), headers, body, content_type.c_str());
      if (method == "PUT") return c.Put(path.c_str(), headers, body, content_type.c_str());
      if (method == "PATCH") return c.Patch(path.c_str(), headers, body, content_type.c_str());
      if (method == "DELETE") return c.Delete(path.c_str(), headers);
      throw std::runtime_error("method " + method);
    };
    const httplib::Result r = send();
    Reply out;
    if (!r) return out;  // status 0: no answer
    out.status = r->status;
    out.text = r->body;
    out.headers = r->headers;
    out.body = json::parse(r->body, nullptr, false);
    return out;
  }
  Reply get(const std::string& path) const { return request("GET", "/api/v1" + path); }
  Reply post(const std::string& path, const json& body, httplib::Headers headers = {}) const {
    return request("POST", "/api/v1" + path, body.dump(), std::move(headers));
  }

  // Polls a job until `pred` holds for it or the deadline passes; returns the last state.
  json wait_job(int64_t id, const std::function<bool(const json&)>& pred, std::chrono::seconds deadline = 60s) const {
    const auto end = std::chrono::steady_clock::now() + deadline;
    json last;
    while (std::chrono::steady_clock::now() < end) {
      const Reply r = get("/jobs/" + std::to_string(id));
      if (r.status == 200) {
        last = r.body;
        if (pred(last)) return last;
      }
      std::this_thread::sleep_for(50ms);
    }
    return last;
  }
  json wait_status(int64_t id, const std::string& status, std::chrono::seconds deadline = 60s) const {
    return wait_job(id, [&](const json& j) { return j.value("status", "") == status; }, deadline);
  }

  // Reads the database behind the server's back (WAL: a reader never blocks the server).
  int64_t query_int(const std::string& sql) const {
    sqlite3* db = nullptr;
    if (sqlite3_open_v2(db_.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      sqlite3_close(db);
      throw std::runtime_error("cannot open " + db_.string());
    }
    sqlite3_busy_timeout(db, 10000);
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
      const std::string err = sqlite3_errmsg(db);
      sqlite3_close(db);
      throw std::runtime_error(sql + ": " + err);
    }
    int64_t v = -1;
    if (sqlite3_step(s) == SQLITE_ROW) v = sqlite3_column_int64(s, 0);
    sqlite3_finalize(s);
    sqlite3_close(db);
    return v;
  }

  fs::path dir_, db_;
  ServerProcess server_;
};

}  // namespace runout_test
