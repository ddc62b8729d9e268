// The front end's policy (http_front.hpp, http_policy.hpp): what a request must look like beyond HTTP's grammar
// (Boost.Beast's parser, http_session.cpp, checks that), the answer to each refusal, the connection limits and
// the handler pools. The problem documents themselves: http_problem.cpp.
#include "http_policy.hpp"

#include <algorithm>
#include <cctype>

namespace runout::service {

namespace front {
namespace {

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// RFC 9110 5.5: a field value is visible characters, obs-text, SP and HTAB; any other control byte or DEL is refused.
bool field_byte(char c) {
  const auto u = static_cast<unsigned char>(c);
  return u == '\t' || (u >= 0x20 && u != 0x7f);
}

// Percent-decoding (and '+' as a space in a query) by httplib, whose Request the handlers take.
std::string decode(const std::string& s, bool plus_as_space) { return httplib::detail::decode_url(s, plus_as_space); }

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

}  // namespace

void read_head(const BeastRequest& head, httplib::Request& req, std::string& instance) {
  req.method = std::string(head.method_string());
  req.target = std::string(head.target());
  if (head.version() != 11 && head.version() != 10)
    throw Refusal{505, "(request)", "unsupported protocol version (accepted: HTTP/1.1 or HTTP/1.0)"};
  req.version = head.version() == 11 ? "HTTP/1.1" : "HTTP/1.0";
  if (req.target.size() > 8192) throw Refusal{414, "(request)", "the request target is over 8192 bytes"};
  // Absolute form (RFC 9112 3.2.2: a server MUST accept it): routed by its path, the authority ignored.
  if (const size_t scheme = req.target.find("://"); scheme != std::string::npos && req.target[0] != '/') {
    const std::string s = lower(req.target.substr(0, scheme));
    if (s != "http" && s != "https")
      throw Refusal{400, "(request)", "malformed request target (accepted: an absolute path, or an http(s) URI)"};
    const size_t path = req.target.find_first_of("/?", scheme + 3);
    req.target = path == std::string::npos ? "/" : req.target[path] == '?' ? "/" + req.target.substr(path)
                                                                             : req.target.substr(path);
  }
  if (req.target.empty() || (req.target[0] != '/' && !(req.target == "*" && req.method == "OPTIONS")))
    throw Refusal{400, "(request)", "malformed request target (accepted: an absolute path starting with '/')"};
  if (std::distance(head.begin(), head.end()) > 100) throw Refusal{431, "(headers)", "more than 100 header lines"};
  for (const auto& f : head) {
    const std::string name(f.name_string()), value(f.value());
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
  instance = req.path;
  if (q != std::string::npos) parse_query(req.target.substr(q + 1), req.params);
}

BodyPlan plan_body(const httplib::Request& req) {
  BodyPlan p;
  if (req.has_header("Transfer-Encoding")) {  // with a Content-Length too, Beast's parser refused it already
    if (lower(req.get_header_value("Transfer-Encoding")) != "chunked" || req.version != "HTTP/1.1")
      throw Refusal{501, "Transfer-Encoding", "not supported (accepted: chunked, in HTTP/1.1, or a Content-Length)"};
    p.chunked = true;
  }
  if (req.has_header("Content-Length")) {  // Beast allows a list of equal numbers; here only one
    const std::string v = req.get_header_value("Content-Length");
    if (v.empty() || v.size() > 18 || !std::all_of(v.begin(), v.end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
      throw Refusal{400, "Content-Length", "must be a decimal number of bytes"};
    p.length = std::stoull(v);
  }
  p.body = p.chunked || p.length > 0;
  return p;
}

void check_body(const httplib::Request& req, BodyPlan& p, const FrontOptions& opt) {
  if (p.length > opt.max_body)
    throw Refusal{413, "(body)", "the body is " + std::to_string(p.length) + " bytes, over the limit (accepted: at most " +
                                     std::to_string(opt.max_body) + " bytes, --max-body)"};
  if (req.has_header("Content-Encoding") && lower(req.get_header_value("Content-Encoding")) != "identity")
    throw Refusal{415, "Content-Encoding", "compressed bodies are not accepted (accepted: identity)"};
  if (req.has_header("Expect")) {
    if (lower(req.get_header_value("Expect")) != "100-continue")
      throw Refusal{417, "Expect", "not supported (accepted: 100-continue)"};
    p.expect_continue = p.body;
  }
}

Refusal refusal_for(const boost::system::error_code& ec, bool head_read, bool late, const FrontOptions& opt) {
  auto secs = [](double s) { return std::to_string(static_cast<int>(s)); };
  if (late && head_read)
    return {408, "(body)", "the body did not arrive within " + secs(opt.body_timeout) +
                               " s (accepted: a whole body within --body-timeout)"};
  if (late)
    return {408, "(request)", "the request head did not arrive within " + secs(opt.header_timeout) +
                                  " s (accepted: a whole head within --header-timeout)"};
  const std::string head_limit = "the request head is over " + std::to_string(opt.max_head) + " bytes";
  if (ec == http::error::header_limit) return {431, "(headers)", head_limit};
  if (ec == http::error::buffer_overflow)  // a chunk's size line or trailer that does not fit the buffer
    return head_read ? Refusal{400, "(body)", "malformed chunk (a size line or trailer over the buffer's limit)"}
                     : Refusal{431, "(headers)", head_limit};
  if (ec == http::error::body_limit)
    return {413, "(body)", "the chunked body is over the limit (accepted: at most " + std::to_string(opt.max_body) +
                               " bytes, --max-body)"};
  if (ec == http::error::bad_content_length)
    return {400, "Content-Length", "malformed, repeated or given with Transfer-Encoding (accepted: one decimal number)"};
  if (ec == http::error::bad_transfer_encoding)
    return {400, "Transfer-Encoding", "repeated or given with Content-Length (accepted: one of the two)"};
  if (ec == http::error::bad_chunk || ec == http::error::bad_chunk_extension)
    return {400, "(body)", "malformed chunk (accepted: hexadecimal size, extensions of at most 1024 bytes)"};
  if (ec == http::error::bad_version)  // Beast's parser refuses any version but 1.0 and 1.1 (HTTP/2.0 included)
    return {505, "(request)", "unsupported or malformed protocol version (accepted: HTTP/1.1 or HTTP/1.0)"};
  if (ec == http::error::bad_method || ec == http::error::bad_target)
    return {400, "(request)", "malformed request line (accepted: METHOD SP target SP HTTP/1.1, tokens and visible characters)"};
  if (ec.category() == http::make_error_code(http::error::bad_field).category() && ec != http::error::end_of_stream &&
      ec != http::error::partial_message && ec != http::error::need_more)
    return {400, head_read ? "(body)" : "(headers)",
            "malformed header line (accepted: Name: value, a token name, no control characters)"};
  return {0, "", ""};  // the client went away, or the connection failed: nobody to answer
}

BeastResponse to_wire(const httplib::Response& res, bool head_only, bool keep_alive) {
  const int status = res.status < 100 || res.status > 599 ? 500 : res.status;
  BeastResponse out;
  out.result(static_cast<unsigned>(status));
  out.version(11);
  for (const auto& [k, v] : res.headers) {
    const std::string key = lower(k);
    if (key == "content-length" || key == "connection" || key == "transfer-encoding" || key == "keep-alive") continue;
    out.insert(k, v);
  }
  out.set(http::field::connection, keep_alive ? "keep-alive" : "close");
  if (status >= 200 && status != 204 && status != 304) {
    out.content_length(res.body.size());  // a HEAD answer announces the body it does not carry
    if (!head_only) out.body() = res.body;
  }
  return out;
}

BeastResponse to_wire(const Refusal& r, const std::string& instance) {
  httplib::Response res;
  res.status = r.status;
  res.set_header("Content-Type", kProblemMediaType);
  for (const auto& [k, v] : r.headers) res.set_header(k, v);
  res.body = problem_body(r.status, instance, {{r.field, r.message}});
  return to_wire(res, false, false);
}

bool Limits::admit(const std::string& peer, Refusal& refusal) {
  std::lock_guard lock(m_);
  if (open_ >= opt_.max_connections) {
    refusal = {503, "(connection)",
               "the server has " + std::to_string(opt_.max_connections) +
                   " open connections (accepted: at most that many, --max-connections); retry shortly",
               {{"Retry-After", "1"}}};
    return false;
  }
  int& mine = per_client_[peer];
  if (mine >= opt_.max_connections_per_client) {
    refusal = {429, "(connection)",
               "this client address has " + std::to_string(mine) + " open connections (accepted: at most " +
                   std::to_string(opt_.max_connections_per_client) + " per client address, --max-connections-per-client)",
               {{"Retry-After", "1"}}};
    return false;
  }
  ++mine;
  ++open_;
  return true;
}

void Limits::release(const std::string& peer) {
  std::lock_guard lock(m_);
  --open_;
  if (auto it = per_client_.find(peer); it != per_client_.end() && --it->second <= 0) per_client_.erase(it);
}

int64_t Limits::open() const {
  std::lock_guard lock(m_);
  return open_;
}

Pool::Pool(int n) {
  for (int k = 0; k < n; ++k) threads_.emplace_back([this] { loop(); });
}

bool Pool::push(std::function<void()> f, size_t max_pending) {
  {
    std::lock_guard lock(m_);
    if (down_ || tasks_.size() >= max_pending) return false;
    tasks_.push_back(std::move(f));
  }
  cv_.notify_one();
  return true;
}

size_t Pool::pending() {
  std::lock_guard lock(m_);
  return tasks_.size();
}

void Pool::shutdown() {
  {
    std::lock_guard lock(m_);
    if (down_) return;
    down_ = true;
    tasks_.clear();
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

void Pool::loop() {
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

}  // namespace front
}  // namespace runout::service
