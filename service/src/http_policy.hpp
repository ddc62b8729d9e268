#pragma once
// The front end's policy (http_front.cpp), shared with its Boost.Beast glue (http_session.cpp): what a request
// must look like beyond HTTP's grammar, how a refusal reads, the connection limits and the handler pools.
// Internal to those two files.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <boost/beast/http.hpp>

#include "http_front.hpp"

namespace runout::service::front {

namespace http = boost::beast::http;
using BeastRequest = http::request<http::string_body>;
using BeastResponse = http::response<http::string_body>;

// A request the front refuses itself (before any handler), always closing the connection after the answer:
// its body was not read, so the stream cannot be resynchronised.
struct Refusal {
  int status;
  std::string field, message;
  std::vector<std::pair<std::string, std::string>> headers = {};
};

// The head Beast parsed, as the handlers' request (method, target, headers, decoded path, query). Throws a
// Refusal for what HTTP's grammar allows and the service does not; `instance` is left as the refusal's
// instance (empty until the path is known).
void read_head(const BeastRequest& head, httplib::Request& req, std::string& instance);

// Framing of a read head: whether a body follows, and its announced length (chunked: 0). Throws a Refusal
// (400, 501). Then, once the token is checked, its size, coding and expectation (413, 415, 417);
// `expect_continue`: the client waits for 100 Continue before its body.
struct BodyPlan {
  bool body = false, chunked = false, expect_continue = false;
  uint64_t length = 0;
};
BodyPlan plan_body(const httplib::Request& req);
void check_body(const httplib::Request& req, BodyPlan& plan, const FrontOptions& opt);

// A Beast parser error (or the deadline) as the refusal it earns; status 0: close without an answer.
Refusal refusal_for(const boost::system::error_code& ec, bool head_read, bool late, const FrontOptions& opt);

// Responses on the wire: the handler's, or a refusal's problem document (Connection: close).
BeastResponse to_wire(const httplib::Response& res, bool head_only, bool keep_alive);
BeastResponse to_wire(const Refusal& r, const std::string& instance);

// Open connections per client address and in all. A refused connection is never counted; one that is closing
// (answered, draining what the client still sends) is uncounted at once.
class Limits {
 public:
  explicit Limits(const FrontOptions& opt) : opt_(opt) {}
  // Counts the connection, or returns the refusal (429, 503) without counting it.
  bool admit(const std::string& peer, Refusal& refusal);
  void release(const std::string& peer);
  int64_t open() const;

 private:
  const FrontOptions& opt_;
  mutable std::mutex m_;
  std::map<std::string, int> per_client_;
  int64_t open_ = 0;
};

// A fixed set of threads over a queue of tasks, with the queue's length visible (to refuse past a bound).
class Pool {
 public:
  explicit Pool(int n);
  ~Pool() { shutdown(); }
  bool push(std::function<void()> f, size_t max_pending);
  size_t pending();
  void shutdown();

 private:
  void loop();
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  std::vector<std::thread> threads_;
  bool down_ = false;
};

}  // namespace runout::service::front
