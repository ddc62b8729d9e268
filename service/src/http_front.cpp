// The HTTP/1.1 front end (http_front.hpp): an event loop that owns the sockets, two handler pools.
#include "http_front.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

namespace runout::service {

using Clock = std::chrono::steady_clock;

namespace {
// The kinds of problem (docs/service.md, "Errors"): the URI's last segment and its title, by status and, where
// one status has several causes, by the field the refusal names.
struct ProblemKind {
  const char* slug;
  const char* title;
};
ProblemKind problem_kind(int status, const std::string& field) {
  switch (status) {
    case 400: return {"malformed-request", "The request cannot be read"};
    case 401: return {"unauthorized", "A write needs the service's bearer token"};
    case 404: return {"not-found", "No such resource"};
    case 405: return {"method-not-allowed", "Method not allowed on this path"};
    case 408: return {"request-timeout", "The request did not arrive in time"};
    case 409: return {"not-ready", "The resource is not in a state that allows this"};
    case 413: return {"body-too-large", "The request body is over the size limit"};
    case 414: return {"target-too-long", "The request target is too long"};
    case 415: return {"unsupported-media-type", "Unsupported media type or content coding"};
    case 417: return {"expectation-failed", "Unsupported expectation"};
    case 422:
      return field == "(budget)" ? ProblemKind{"over-work-budget", "Over the work budget"}
                                 : ProblemKind{"invalid-field", "A field of the request is invalid"};
    case 429:
      return field == "(budget)" ? ProblemKind{"over-work-budget", "Over the work budget"}
                                 : ProblemKind{"too-many-connections", "Too many connections from this client"};
    case 431: return {"head-too-large", "The request head is over the size limit"};
    case 501: return {"not-implemented", "Not implemented"};
    case 503: return {"overloaded", "The service is at its limit of connections or waiting requests"};
    case 505: return {"http-version-not-supported", "HTTP version not supported"};
    default: return {nullptr, nullptr};
  }
}
}  // namespace

std::string problem_type(int status, const std::string& field) {
  const ProblemKind k = problem_kind(status, field);
  return k.slug ? std::string("https://runout.invalid/problems/") + k.slug : "about:blank";
}

std::string problem_title(int status, const std::string& field) {
  const ProblemKind k = problem_kind(status, field);
  return k.title ? k.title : status >= 500 ? "Internal server error" : "Request refused";
}

std::string problem_body(int status, const std::string& instance, const std::vector<FieldError>& errors,
                         const std::string& extra_json) {
  using json = nlohmann::ordered_json;  // the RFC's members first, in its order
  const std::string first_field = errors.empty() ? std::string() : errors.front().field;
  json list = json::array();
  for (const auto& e : errors)
    if (!e.field.empty()) list.push_back({{"field", e.field}, {"message", e.message}});
  std::string detail = errors.empty() ? problem_title(status, first_field) : errors.front().message;
  if (!errors.empty() && !first_field.empty()) detail = first_field + ": " + detail;
  if (errors.size() > 1) {  // a last "(errors)" entry counts those not listed (FieldErrors, requests.hpp)
    const bool capped = errors.back().field == "(errors)";
    detail = (capped ? "more than " + std::to_string(errors.size() - 1) : std::to_string(errors.size())) +
             " fields are invalid (each in errors); the first, " + detail;
  }
  json j = {{"type", problem_type(status, first_field)},
            {"title", problem_title(status, first_field)},
            {"status", status},
            {"detail", detail}};
  if (!instance.empty()) j["instance"] = instance;
  j["errors"] = list;
  if (!extra_json.empty()) j.update(json::parse(extra_json));
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

namespace {

const char* reason(int s) {
  switch (s) {
    case 100: return "Continue";
    case 200: return "OK";
    case 201: return "Created";
    case 202: return "Accepted";
    case 204: return "No Content";
    case 206: return "Partial Content";
    case 304: return "Not Modified";
    case 400: return "Bad Request";
    case 401: return "Unauthorized";
    case 403: return "Forbidden";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 408: return "Request Timeout";
    case 409: return "Conflict";
    case 411: return "Length Required";
    case 413: return "Payload Too Large";
    case 414: return "URI Too Long";
    case 415: return "Unsupported Media Type";
    case 417: return "Expectation Failed";
    case 422: return "Unprocessable Entity";
    case 429: return "Too Many Requests";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 501: return "Not Implemented";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Unknown";
  }
}

// A request the front refuses itself (before any handler), always closing the connection after the answer:
// its body was not read, so the stream cannot be resynchronised.
struct Refusal {
  int status;
  std::string field, message;
  std::vector<std::pair<std::string, std::string>> headers = {};
};

bool ieq(const std::string& a, const char* b) {
  const size_t n = std::strlen(b);
  if (a.size() != n) return false;
  for (size_t i = 0; i < n; ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

bool tchar(char c) {  // strchr finds a NUL too (the terminator): excluded first
  return c != '\0' && (std::isalnum(static_cast<unsigned char>(c)) || std::strchr("!#$%&'*+-.^_`|~", c) != nullptr);
}

// RFC 9110 5.5: a field value is visible characters, obs-text, SP and HTAB; any other control byte or DEL is refused.
bool field_byte(char c) {
  const auto u = static_cast<unsigned char>(c);
  return u == '\t' || (u >= 0x20 && u != 0x7f);
}

int hexval(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Percent-decoding as httplib's decode_url: %XX becomes the byte, anything else is kept as it is.
std::string decode(const std::string& s, bool plus_as_space) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && hexval(s[i + 1]) >= 0 && hexval(s[i + 2]) >= 0) {
      out.push_back(static_cast<char>(hexval(s[i + 1]) * 16 + hexval(s[i + 2])));
      i += 2;
    } else if (plus_as_space && s[i] == '+') {
      out.push_back(' ');
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

// The query string, strictly: name=value pairs separated by '&', each name once, exactly one '=' in each.
void parse_query(const std::string& q, httplib::Params& params) {
  size_t start = 0;
  while (start <= q.size()) {
    size_t amp = q.find('&', start);
    if (amp == std::string::npos) amp = q.size();
    const std::string piece = q.substr(start, amp - start);
    start = amp + 1;
    if (piece.empty()) continue;
    const size_t eq = piece.find('=');
    const std::string name = decode(piece.substr(0, eq), true);
    const std::string shown = name.empty() ? std::string("(query)") : name.substr(0, 64);
    if (eq == std::string::npos || eq == 0 || piece.find('=', eq + 1) != std::string::npos)
      throw Refusal{400, shown, "malformed query parameter '" + piece.substr(0, 80) +
                                    "' (accepted: name=value pairs separated by '&', one '=' in each)"};
    if (params.count(name)) throw Refusal{400, shown, "query parameter given twice (accepted: each at most once)"};
    params.emplace(name, decode(piece.substr(eq + 1), true));
  }
}

// Request line and headers (`head` without its final empty line).
void parse_head(const std::string& head, httplib::Request& req) {
  std::vector<std::string> lines;
  for (size_t pos = 0;;) {
    const size_t e = head.find("\r\n", pos);
    lines.push_back(head.substr(pos, e == std::string::npos ? std::string::npos : e - pos));
    if (e == std::string::npos) break;
    pos = e + 2;
  }
  const std::string& line = lines[0];
  const size_t s1 = line.find(' '), s2 = s1 == std::string::npos ? s1 : line.find(' ', s1 + 1);
  if (s1 == std::string::npos || s2 == std::string::npos || line.find(' ', s2 + 1) != std::string::npos)
    throw Refusal{400, "(request)", "malformed request line (accepted: METHOD SP target SP HTTP/1.1)"};
  req.method = line.substr(0, s1);
  req.target = line.substr(s1 + 1, s2 - s1 - 1);
  req.version = line.substr(s2 + 1);
  if (req.method.empty() || !std::all_of(req.method.begin(), req.method.end(), tchar))
    throw Refusal{400, "(request)", "malformed method (accepted: an HTTP token such as GET or POST)"};
  if (req.version != "HTTP/1.1" && req.version != "HTTP/1.0")
    throw Refusal{505, "(request)", "unsupported protocol version (accepted: HTTP/1.1 or HTTP/1.0)"};
  if (req.target.size() > 8192) throw Refusal{414, "(request)", "the request target is over 8192 bytes"};
  // Absolute form (RFC 9112 3.2.2: a server MUST accept it): routed by its path, the authority ignored.
  if (const size_t scheme = req.target.find("://"); scheme != std::string::npos && scheme > 0 && req.target[0] != '/') {
    const std::string s = lower(req.target.substr(0, scheme));
    if (s != "http" && s != "https")
      throw Refusal{400, "(request)", "malformed request target (accepted: an absolute path, or an http(s) URI)"};
    const size_t path = req.target.find_first_of("/?", scheme + 3);
    req.target = path == std::string::npos ? "/" : req.target[path] == '?' ? "/" + req.target.substr(path)
                                                                             : req.target.substr(path);
  }
  if (req.target.empty() || (req.target[0] != '/' && !(req.target == "*" && req.method == "OPTIONS")) ||
      std::any_of(req.target.begin(), req.target.end(), [](char c) { return static_cast<unsigned char>(c) <= 0x20 || c == 0x7f; }))
    throw Refusal{400, "(request)", "malformed request target (accepted: an absolute path starting with '/')"};
  if (lines.size() > 101) throw Refusal{431, "(headers)", "more than 100 header lines"};
  for (size_t k = 1; k < lines.size(); ++k) {
    const std::string& h = lines[k];
    if (h.empty() || h[0] == ' ' || h[0] == '\t')
      throw Refusal{400, "(headers)", "malformed header line (folded lines are not accepted)"};
    const size_t colon = h.find(':');
    const std::string name = h.substr(0, colon);
    if (colon == std::string::npos || name.empty() || !std::all_of(name.begin(), name.end(), tchar))
      throw Refusal{400, "(headers)", "malformed header line (accepted: Name: value, no space before the colon)"};
    const std::string value = trim(h.substr(colon + 1));
    if (!std::all_of(value.begin(), value.end(), field_byte))
      throw Refusal{400, name, "control character in the header's value (accepted: visible characters, SP and HTAB)"};
    req.headers.emplace(name, value);
  }
  // Headers whose repetition is ambiguous (smuggling, two keys, two tokens) are refused, equal or not.
  for (const char* once : {"Content-Length", "Transfer-Encoding", "Content-Type", "Content-Encoding", "Authorization",
                           "Idempotency-Key", "Host", "Expect"})
    if (req.get_header_value_count(once) > 1)
      throw Refusal{400, once, "given " + std::to_string(req.get_header_value_count(once)) + " times (accepted: once)"};
  if (req.version == "HTTP/1.1" && !req.has_header("Host"))
    throw Refusal{400, "Host", "missing (accepted: an HTTP/1.1 request names its Host, RFC 9112)"};
  const size_t q = req.target.find('?');
  req.path = decode(req.target.substr(0, q), false);
  if (q != std::string::npos) parse_query(req.target.substr(q + 1), req.params);
}

std::string serialize(int status, const httplib::Headers& headers, const std::string& body, bool head_only,
                      bool keep_alive) {
  if (status < 100 || status > 599) status = 500;
  const bool no_body = status < 200 || status == 204 || status == 304;
  std::string s = "HTTP/1.1 " + std::to_string(status) + " " + reason(status) + "\r\n";
  for (const auto& [k, v] : headers) {
    if (ieq(k, "Content-Length") || ieq(k, "Connection") || ieq(k, "Transfer-Encoding") || ieq(k, "Keep-Alive")) continue;
    s += k + ": " + v + "\r\n";
  }
  if (!no_body) s += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  s += keep_alive ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n";
  if (!no_body && !head_only) s += body;
  return s;
}

std::string serialize_refusal(const Refusal& r, const std::string& instance) {
  httplib::Headers h{{"Content-Type", kProblemMediaType}};
  for (const auto& [k, v] : r.headers) h.emplace(k, v);
  return serialize(r.status, h, problem_body(r.status, instance, {{r.field, r.message}}), false, false);
}

struct Conn {
  enum class St { head, body, busy, write, drain };
  uint64_t id = 0;
  int fd = -1;
  std::string peer;
  St st = St::head;
  Clock::time_point deadline;
  bool head_seen = false;  // a byte of the current request's head has arrived
  bool counted = true;     // in its client's connection count (not once it drains)
  std::string in;          // read, not yet consumed
  httplib::Request req;
  bool keep_alive = true;
  bool chunked = false;
  enum class Ch { size, data, data_crlf, trailer } ch = Ch::size;
  size_t remaining = 0;    // Content-Length bytes, or the current chunk's, still to come
  size_t trailer_bytes = 0;
  std::string out;
  size_t out_off = 0;
  bool close_after = false;
  bool peer_eof = false;   // the client half-closed: answer what it sent, then close
};

// A fixed set of threads over a queue of tasks, with the queue's length visible (to refuse past a bound).
class Pool {
 public:
  explicit Pool(int n) {
    for (int k = 0; k < n; ++k) threads_.emplace_back([this] { loop(); });
  }
  ~Pool() { shutdown(); }
  bool push(std::function<void()> f, size_t max_pending) {
    {
      std::lock_guard lock(m_);
      if (tasks_.size() >= max_pending) return false;
      tasks_.push_back(std::move(f));
    }
    cv_.notify_one();
    return true;
  }
  size_t pending() {
    std::lock_guard lock(m_);
    return tasks_.size();
  }
  void shutdown() {
    {
      std::lock_guard lock(m_);
      if (down_) return;
      down_ = true;
      tasks_.clear();
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }

 private:
  void loop() {
    for (;;) {
      std::function<void()> f;
      {
        std::unique_lock lock(m_);
        cv_.wait(lock, [&] { return down_ || !tasks_.empty(); });
        if (down_) return;
        f = std::move(tasks_.front());
        tasks_.pop_front();
      }
      f();
    }
  }
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  std::vector<std::thread> threads_;
  bool down_ = false;
};

std::chrono::nanoseconds secs(double s) { return std::chrono::nanoseconds(static_cast<int64_t>(s * 1e9)); }

}  // namespace

struct HttpFront::Impl {
  FrontOptions opt;
  Handler handler;
  HeadCheck head_check;
  Lane fast_lane;
  int listen_fd = -1;
  int wake_fd = -1;
  std::atomic<bool> stopping{false};
  std::unordered_map<uint64_t, std::unique_ptr<Conn>> conns;
  std::map<std::string, int> per_client;
  uint64_t next_id = 1;
  std::unique_ptr<Pool> main_pool, fast_pool;
  struct Done {
    uint64_t id;
    std::string bytes;
    bool close;
  };
  std::mutex done_mutex;
  std::vector<Done> done;
  std::atomic<int64_t> open{0}, refused{0}, timed_out{0};
  int draining = 0;  // answered connections closing (not counted in `open`)
  Clock::time_point accept_paused_until{};

  void wake() {
    const uint64_t one = 1;
    (void)!::write(wake_fd, &one, sizeof one);
  }

  // Out of both limits' counts: a connection that is closing (draining) holds neither a client's nor the
  // server's share.
  void uncount(Conn& c) {
    if (!c.counted) return;
    c.counted = false;
    --open;
    if (--per_client[c.peer] <= 0) per_client.erase(c.peer);
  }

  void close_conn(uint64_t id) {
    auto it = conns.find(id);
    if (it == conns.end()) return;
    if (it->second->st == Conn::St::drain) --draining;
    uncount(*it->second);
    ::close(it->second->fd);
    conns.erase(it);
  }

  // Writes what it can now; the rest when the socket is writable again. False: the connection is gone.
  bool flush(Conn& c) {
    while (c.out_off < c.out.size()) {
      const ssize_t n = ::send(c.fd, c.out.data() + c.out_off, c.out.size() - c.out_off, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        c.out_off += static_cast<size_t>(n);
        continue;
      }
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
      if (n < 0 && errno == EINTR) continue;
      close_conn(c.id);
      return false;
    }
    c.out.clear();
    c.out_off = 0;
    if (c.close_after) {
      // Lingering close: the client may still be sending a body we did not read; closing now would reset the
      // connection and could destroy our answer before it is read. Read and drop for a short while.
      ::shutdown(c.fd, SHUT_WR);
      if (draining >= opt.max_connections) {  // bounded: past it, closed at once
        close_conn(c.id);
        return false;
      }
      uncount(c);
      ++draining;
      c.st = Conn::St::drain;
      c.deadline = Clock::now() + std::chrono::seconds(2);
      return true;
    }
    c.st = Conn::St::head;
    c.head_seen = false;
    c.req = httplib::Request();
    c.deadline = Clock::now() + secs(opt.idle_timeout);
    const uint64_t id = c.id;
    if (!advance(c) || !conns.count(id)) return false;  // a pipelined request may be waiting in `in`
    if (c.peer_eof && (c.st == Conn::St::head || c.st == Conn::St::body)) {  // nothing more will come
      close_conn(id);
      return false;
    }
    return true;
  }

  bool respond(Conn& c, std::string bytes, bool close_after) {
    c.out = std::move(bytes);
    c.out_off = 0;
    c.close_after = close_after || !c.keep_alive;
    c.st = Conn::St::write;
    c.deadline = Clock::now() + secs(opt.write_timeout);
    return flush(c);
  }

  bool refuse(Conn& c, const Refusal& r) { return refuse(c, r, c.req.path); }
  bool refuse(Conn& c, const Refusal& r, const std::string& instance) {
    return respond(c, serialize_refusal(r, instance), true);
  }

  void dispatch(Conn& c) {
    c.st = Conn::St::busy;
    const bool fast = fast_lane(c.req);
    const std::string path = c.req.path;  // for a refusal below, once the request has moved into the task
    auto task = [this, id = c.id, req = std::move(c.req), keep = c.keep_alive]() {
      httplib::Response res;
      try {
        handler(req, res);
      } catch (const std::exception& e) {
        res = httplib::Response();
        res.status = 500;
        res.set_content(problem_body(500, req.path, {{"", std::string("internal error: ") + e.what()}}), kProblemMediaType);
      } catch (...) {
        res = httplib::Response();
        res.status = 500;
        res.set_content(problem_body(500, req.path, {{"", "internal error"}}), kProblemMediaType);
      }
      Done d{id, serialize(res.status, res.headers, res.body, req.method == "HEAD", keep), !keep};
      {
        std::lock_guard lock(done_mutex);
        done.push_back(std::move(d));
      }
      wake();
    };
    c.req = httplib::Request();
    const bool queued = fast ? fast_pool->push(std::move(task), 64) : main_pool->push(std::move(task), opt.max_pending);
    if (!queued) {
      c.st = Conn::St::head;  // refuse() takes it from here
      refuse(c, {503, "(server)",
                 "too many requests are waiting for a handler (accepted: at most " + std::to_string(opt.max_pending) +
                     " waiting); retry shortly",
                 {{"Retry-After", "1"}}},
             path);
    }
  }

  // The head is complete: its checks, then the body or the handler. False: the connection is gone.
  bool start_request(Conn& c, const std::string& head) {
    httplib::Request& req = c.req;
    parse_head(head, req);
    const std::string conn_hdr = lower(req.get_header_value("Connection"));
    c.keep_alive = req.version == "HTTP/1.1" ? conn_hdr.find("close") == std::string::npos
                                              : conn_hdr.find("keep-alive") != std::string::npos;
    const bool has_te = req.has_header("Transfer-Encoding"), has_cl = req.has_header("Content-Length");
    if (has_te && has_cl)
      throw Refusal{400, "Content-Length", "given with Transfer-Encoding (accepted: one of the two)"};
    c.chunked = false;
    c.remaining = 0;
    if (has_te) {
      if (lower(req.get_header_value("Transfer-Encoding")) != "chunked" || req.version != "HTTP/1.1")
        throw Refusal{501, "Transfer-Encoding", "not supported (accepted: chunked, in HTTP/1.1, or a Content-Length)"};
      c.chunked = true;
    }
    uint64_t length = 0;
    if (has_cl) {
      const std::string v = req.get_header_value("Content-Length");
      if (v.empty() || v.size() > 18 || !std::all_of(v.begin(), v.end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
        throw Refusal{400, "Content-Length", "must be a decimal number of bytes"};
      length = std::stoull(v);
    }
    // Before any byte of the body: the token (writes), then the body's size and coding.
    {
      httplib::Response res;
      if (head_check && head_check(req, res)) {
        if (res.status < 100) res.status = 400;
        return respond(c, serialize(res.status, res.headers, res.body, false, false), true);
      }
    }
    if (length > opt.max_body)
      throw Refusal{413, "(body)", "the body is " + std::to_string(length) + " bytes, over the limit (accepted: at most " +
                                       std::to_string(opt.max_body) + " bytes, --max-body)"};
    if (req.has_header("Content-Encoding") && lower(req.get_header_value("Content-Encoding")) != "identity")
      throw Refusal{415, "Content-Encoding", "compressed bodies are not accepted (accepted: identity)"};
    const bool body = c.chunked || length > 0;
    if (req.has_header("Expect")) {
      if (lower(req.get_header_value("Expect")) != "100-continue")
        throw Refusal{417, "Expect", "not supported (accepted: 100-continue)"};
      if (body && c.in.empty()) {
        static const char kContinue[] = "HTTP/1.1 100 Continue\r\n\r\n";
        (void)::send(c.fd, kContinue, sizeof kContinue - 1, MSG_NOSIGNAL | MSG_DONTWAIT);
      }
    }
    if (!body) {
      dispatch(c);
      return true;
    }
    c.st = Conn::St::body;
    c.remaining = c.chunked ? 0 : static_cast<size_t>(length);
    c.ch = Conn::Ch::size;
    c.trailer_bytes = 0;
    c.deadline = Clock::now() + secs(opt.body_timeout);
    return true;
  }

  // Consumes body bytes from `in`; true when the body is complete.
  bool read_body(Conn& c) {
    std::string& body = c.req.body;
    if (!c.chunked) {
      const size_t take = std::min(c.remaining, c.in.size());
      body.append(c.in, 0, take);
      c.in.erase(0, take);
      c.remaining -= take;
      return c.remaining == 0;
    }
    for (;;) {
      switch (c.ch) {
        case Conn::Ch::size: {
          const size_t e = c.in.find("\r\n");
          if (e == std::string::npos) {
            if (c.in.size() > 1024) throw Refusal{400, "(body)", "malformed chunk size line (over 1024 bytes)"};
            return false;
          }
          if (e > 1024) throw Refusal{400, "(body)", "malformed chunk size line (over 1024 bytes)"};
          std::string line = c.in.substr(0, e);
          c.in.erase(0, e + 2);
          line = trim(line.substr(0, line.find(';')));  // chunk extensions are ignored
          if (line.empty() || line.size() > 15 || !std::all_of(line.begin(), line.end(), [](char ch) { return hexval(ch) >= 0; }))
            throw Refusal{400, "(body)", "malformed chunk size (accepted: hexadecimal digits)"};
          const uint64_t size = std::stoull(line, nullptr, 16);
          if (size == 0) {
            c.ch = Conn::Ch::trailer;
          } else if (size > opt.max_body || body.size() + size > opt.max_body) {
            throw Refusal{413, "(body)", "the chunked body is over the limit (accepted: at most " +
                                             std::to_string(opt.max_body) + " bytes, --max-body)"};
          } else {
            c.remaining = static_cast<size_t>(size);
            c.ch = Conn::Ch::data;
          }
          break;
        }
        case Conn::Ch::data: {
          const size_t take = std::min(c.remaining, c.in.size());
          body.append(c.in, 0, take);
          c.in.erase(0, take);
          c.remaining -= take;
          if (c.remaining > 0) return false;
          c.ch = Conn::Ch::data_crlf;
          break;
        }
        case Conn::Ch::data_crlf:
          if (c.in.size() < 2) return false;
          if (c.in.compare(0, 2, "\r\n") != 0) throw Refusal{400, "(body)", "malformed chunk (no CRLF after its data)"};
          c.in.erase(0, 2);
          c.ch = Conn::Ch::size;
          break;
        case Conn::Ch::trailer: {
          const size_t e = c.in.find("\r\n");
          if (e == std::string::npos) {
            if (c.trailer_bytes + c.in.size() > opt.max_head) throw Refusal{431, "(headers)", "trailer over the head limit"};
            return false;
          }
          c.trailer_bytes += e + 2;
          c.in.erase(0, e + 2);
          if (e == 0) return true;  // the empty line ends the trailer; its fields are dropped
          if (c.trailer_bytes > opt.max_head) throw Refusal{431, "(headers)", "trailer over the head limit"};
          break;
        }
      }
    }
  }

  // Moves a connection on with what it has read. False: the connection is gone.
  bool advance(Conn& c) {
    const uint64_t id = c.id;  // `c` is gone once its connection is closed
    try {
      for (;;) {
        if (c.st == Conn::St::head) {
          if (!c.head_seen) {
            const size_t skip = c.in.find_first_not_of("\r\n");  // empty lines before a request are allowed
            c.in.erase(0, skip == std::string::npos ? c.in.size() : skip);
            if (c.in.empty()) return true;
            c.head_seen = true;
            c.deadline = Clock::now() + secs(opt.header_timeout);  // the whole head, however it trickles
          }
          const size_t end = c.in.find("\r\n\r\n");
          if (end == std::string::npos) {
            if (c.in.size() > opt.max_head)
              throw Refusal{431, "(headers)", "the request head is over " + std::to_string(opt.max_head) + " bytes"};
            return true;
          }
          if (end > opt.max_head)
            throw Refusal{431, "(headers)", "the request head is over " + std::to_string(opt.max_head) + " bytes"};
          const std::string head = c.in.substr(0, end);
          c.in.erase(0, end + 4);
          if (!start_request(c, head) || !conns.count(id)) return false;
          if (c.st != Conn::St::body) return true;
        }
        if (c.st == Conn::St::body) {
          if (!read_body(c)) return true;
          dispatch(c);
          return conns.count(id) > 0;
        }
        return true;
      }
    } catch (const Refusal& r) {
      return refuse(c, r);
    }
  }

  void accept_all() {
    for (;;) {
      sockaddr_storage addr{};
      socklen_t len = sizeof addr;
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&addr), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        // Out of descriptors: the pending connection stays in the backlog, and polling the listener again at
        // once would spin; wait a little for connections to close.
        if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM)
          accept_paused_until = Clock::now() + std::chrono::milliseconds(100);
        return;  // EAGAIN, or a transient error: poll again
      }
      char host[INET6_ADDRSTRLEN] = "?";
      if (addr.ss_family == AF_INET)
        ::inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(&addr)->sin_addr, host, sizeof host);
      else if (addr.ss_family == AF_INET6)
        ::inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(&addr)->sin6_addr, host, sizeof host);
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);  // small replies: no Nagle + delayed ACK
      // Over a limit: answered and closed at once, never counted. A refused connection that lingered (and
      // counted) let one address flooding connections lock every other client out.
      if (open >= opt.max_connections) {
        refuse_at_accept(fd, {503, "(connection)",
                              "the server has " + std::to_string(opt.max_connections) +
                                  " open connections (accepted: at most that many, --max-connections); retry shortly",
                              {{"Retry-After", "1"}}});
        continue;
      }
      auto pc = per_client.find(host);
      if (pc != per_client.end() && pc->second >= opt.max_connections_per_client) {
        refuse_at_accept(fd, {429, "(connection)",
                              "this client address has " + std::to_string(pc->second) +
                                  " open connections (accepted: at most " + std::to_string(opt.max_connections_per_client) +
                                  " per client address, --max-connections-per-client)",
                              {{"Retry-After", "1"}}});
        continue;
      }
      auto c = std::make_unique<Conn>();
      c->id = next_id++;
      c->fd = fd;
      c->peer = host;
      c->deadline = Clock::now() + secs(opt.header_timeout);
      ++per_client[c->peer];
      conns.emplace(c->id, std::move(c));
      ++open;
    }
  }

  // The answer fits the socket's send buffer of a new connection; what the client already sent is read first,
  // so that the close does not reset the connection over unread bytes (which could destroy the answer).
  void refuse_at_accept(int fd, const Refusal& r) {
    ++refused;
    const std::string bytes = serialize_refusal(r, "");
    (void)::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    ::shutdown(fd, SHUT_WR);
    char buf[4096];
    while (::recv(fd, buf, sizeof buf, MSG_DONTWAIT) > 0) {
    }
    ::close(fd);
  }

  void read_from(Conn& c) {
    char buf[65536];
    size_t total = 0;
    bool eof = false;
    for (;;) {
      const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) {
        total += static_cast<size_t>(n);
        if (c.st != Conn::St::drain) c.in.append(buf, static_cast<size_t>(n));
        if (total >= (1u << 20)) break;  // fairness: others get their turn
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      if (n < 0) {  // reset: nobody to answer
        close_conn(c.id);
        return;
      }
      eof = true;
      break;
    }
    const uint64_t id = c.id;
    if ((c.st == Conn::St::head || c.st == Conn::St::body) && !advance(c)) return;
    if (!eof || !conns.count(id)) return;
    // The client has finished sending (a half-close): a request it completed is still answered, then closed.
    if (c.st == Conn::St::busy || c.st == Conn::St::write) c.peer_eof = true;
    else close_conn(id);
  }

  void expire(Conn& c) {
    switch (c.st) {
      case Conn::St::head:
        if (!c.head_seen) {
          close_conn(c.id);  // idle: nothing to answer
          return;
        }
        ++timed_out;
        refuse(c, {408, "(request)",
                   "the request head did not arrive within " + std::to_string(static_cast<int>(opt.header_timeout)) +
                       " s (accepted: a whole head within --header-timeout)"});
        return;
      case Conn::St::body:
        ++timed_out;
        refuse(c, {408, "(body)",
                   "the body did not arrive within " + std::to_string(static_cast<int>(opt.body_timeout)) +
                       " s (accepted: a whole body within --body-timeout)"});
        return;
      case Conn::St::write:
        ++timed_out;
        close_conn(c.id);
        return;
      case Conn::St::drain:
        close_conn(c.id);
        return;
      case Conn::St::busy:
        return;
    }
  }

  void take_done() {
    std::vector<Done> ready;
    {
      std::lock_guard lock(done_mutex);
      ready.swap(done);
    }
    for (auto& d : ready) {
      auto it = conns.find(d.id);
      if (it == conns.end()) continue;
      respond(*it->second, std::move(d.bytes), d.close);
    }
  }

  void loop() {
    std::vector<pollfd> fds;
    std::vector<uint64_t> ids;
    while (!stopping.load()) {
      fds.clear();
      ids.clear();
      fds.push_back({listen_fd, static_cast<short>(Clock::now() < accept_paused_until ? 0 : POLLIN), 0});
      fds.push_back({wake_fd, POLLIN, 0});
      auto now = Clock::now();
      auto next = now + std::chrono::seconds(1);
      if (now < accept_paused_until) next = accept_paused_until;
      for (auto& [id, c] : conns) {
        if (c->st == Conn::St::busy) continue;
        fds.push_back({c->fd, static_cast<short>(c->st == Conn::St::write ? POLLOUT : POLLIN), 0});
        ids.push_back(id);
        next = std::min(next, c->deadline);
      }
      const int wait_ms = static_cast<int>(std::max<int64_t>(
          0, std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count() + 1));
      const int n = ::poll(fds.data(), fds.size(), wait_ms);
      if (n < 0 && errno != EINTR) throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
      if (fds[1].revents & POLLIN) {
        uint64_t v;
        (void)!::read(wake_fd, &v, sizeof v);
      }
      take_done();
      for (size_t k = 2; k < fds.size(); ++k) {
        if (!fds[k].revents) continue;
        auto it = conns.find(ids[k - 2]);
        if (it == conns.end()) continue;
        Conn& c = *it->second;
        if (c.st == Conn::St::write) {
          if (fds[k].revents & (POLLERR | POLLHUP | POLLNVAL)) close_conn(c.id);
          else flush(c);
        } else if (c.st != Conn::St::busy) {
          read_from(c);
        }
      }
      if (fds[0].revents & POLLIN) accept_all();
      now = Clock::now();
      std::vector<uint64_t> late;
      for (auto& [id, c] : conns)
        if (c->st != Conn::St::busy && c->deadline <= now) late.push_back(id);
      for (uint64_t id : late)
        if (auto it = conns.find(id); it != conns.end()) expire(*it->second);
    }
  }
};

HttpFront::HttpFront(FrontOptions options, Handler handler, HeadCheck head_check, Lane fast_lane)
    : impl_(std::make_unique<Impl>()) {
  impl_->opt = std::move(options);
  impl_->handler = std::move(handler);
  impl_->head_check = std::move(head_check);
  impl_->fast_lane = std::move(fast_lane);
  impl_->wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (impl_->wake_fd < 0) throw std::runtime_error("eventfd failed");
}

HttpFront::~HttpFront() {
  stop();
  if (impl_->main_pool) impl_->main_pool->shutdown();
  if (impl_->fast_pool) impl_->fast_pool->shutdown();
  for (auto& [id, c] : impl_->conns) ::close(c->fd);
  if (impl_->listen_fd >= 0) ::close(impl_->listen_fd);
  ::close(impl_->wake_fd);
}

int HttpFront::bind() {
  Impl& m = *impl_;
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* res = nullptr;
  const std::string port = std::to_string(m.opt.port);
  if (::getaddrinfo(m.opt.host.c_str(), port.c_str(), &hints, &res) != 0 || !res)
    throw std::runtime_error("cannot resolve " + m.opt.host);
  int fd = -1;
  for (addrinfo* a = res; a; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, 1024) == 0) break;
    ::close(fd);
    fd = -1;
  }
  ::freeaddrinfo(res);
  if (fd < 0) throw std::runtime_error("cannot bind to " + m.opt.host + ":" + port);
  m.listen_fd = fd;
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  return addr.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port)
                                    : ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
}

void HttpFront::run() {
  Impl& m = *impl_;
  m.main_pool = std::make_unique<Pool>(std::max(1, m.opt.handler_threads));
  m.fast_pool = std::make_unique<Pool>(1);
  m.loop();
  ::close(m.listen_fd);  // no new connections while the handlers finish
  m.listen_fd = -1;
  m.main_pool->shutdown();
  m.fast_pool->shutdown();
}

void HttpFront::stop() {
  impl_->stopping = true;
  impl_->wake();
}

FrontStats HttpFront::stats() const {
  FrontStats s;
  s.open_connections = impl_->open.load();
  s.refused_connections = impl_->refused.load();
  s.timed_out = impl_->timed_out.load();
  if (impl_->main_pool) s.pending = static_cast<int64_t>(impl_->main_pool->pending());
  return s;
}

}  // namespace runout::service
