#pragma once
// The service's HTTP/1.1 front end (docs/service.md, "Limits"): Boost.Beast reads each request's head and body
// completely, under byte limits and total deadlines, on one Asio thread, before a handler thread sees it;
// handlers only compute responses, which Beast writes back. The glue is http_session.cpp, the policy (limits,
// checks beyond HTTP's grammar, refusals, handler pools) http_front.cpp.
//
// Why not httplib's own server (0.11.4): it gives every connection a pool thread for as long as the connection
// lives, with a per-recv() timeout (a client sending one byte a second holds a thread forever), and reads
// chunked bodies without any limit. Here a slow or hostile client costs a socket and a buffer, never a thread,
// and is cut at a deadline that trickling does not restart. httplib's Request and Response remain the handlers'
// types (and its client is the tests').
//
// Included by server.cpp and the front end's files (it pulls in httplib.h).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <httplib.h>

namespace runout::service {

struct FrontOptions {
  std::string host = "127.0.0.1";
  int port = 8080;                        // 0: any free port
  size_t max_body = 1 << 20;              // bytes of a body after de-chunking (413 above)
  size_t max_head = 16 * 1024;            // bytes of request line + headers (431 above)
  double header_timeout = 10;             // s for a whole request head, from its first byte (408 after)
  double body_timeout = 30;               // s for a whole body, from the end of the head (408 after)
  double idle_timeout = 5;                // s a kept-alive connection may wait for its next request
  double write_timeout = 30;              // s to write one response (the connection is closed after)
  int max_connections = 512;              // open connections in all (503 above)
  int max_connections_per_client = 32;    // open connections of one client address (429 above)
  int handler_threads = 8;                // threads that run the API's handlers
  size_t max_pending = 1024;              // complete requests waiting for a handler thread (503 above)
};

struct FrontStats {
  int64_t open_connections = 0;
  int64_t refused_connections = 0;  // per-client and total limits
  int64_t timed_out = 0;            // cut at a header, body or write deadline
  int64_t pending = 0;              // requests waiting for a handler thread
};

class HttpFront {
 public:
  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;
  // Called with a request whose head is read and whose body is not: returning true refuses it with `res`
  // (e.g. 401 before a body is read). The body is then never read.
  using HeadCheck = std::function<bool(const httplib::Request&, httplib::Response&)>;
  // True: the request goes to the fast lane, a thread of its own that queued work does not delay (health).
  using Lane = std::function<bool(const httplib::Request&)>;

  HttpFront(FrontOptions options, Handler handler, HeadCheck head_check, Lane fast_lane);
  ~HttpFront();
  HttpFront(const HttpFront&) = delete;
  HttpFront& operator=(const HttpFront&) = delete;

  int bind();   // binds and listens; the port (throws when it cannot)
  void run();   // serves until stop() (blocks)
  void stop();  // from any thread
  FrontStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Every refusal is an RFC 9457 problem document (application/problem+json, docs/service.md "Errors"):
// {type, title, status, detail, instance, errors: [{field, message}]}. `type` is a URI per kind of problem
// (problem_type), `instance` the request's path (left out when the request line was never read), `errors`
// every invalid field (empty when the problem is not a field's). `extra`: further members (the budget's).
inline constexpr const char* kProblemMediaType = "application/problem+json";
struct FieldError {
  std::string field, message;
};
std::string problem_type(int status, const std::string& field);
std::string problem_title(int status, const std::string& field);
std::string problem_body(int status, const std::string& instance, const std::vector<FieldError>& errors,
                         const std::string& extra_json = {});

}  // namespace runout::service
