// The front end's I/O (http_front.hpp): Boost.Beast parses requests and writes responses, one Asio thread runs
// every connection, and the handler pools compute the responses. The policy (limits, checks, problem
// documents) is http_front.cpp's.
//
// Deadlines: waiting for a request, and writing a response, use beast::tcp_stream's expiry (it closes the
// socket: nothing to answer). A request's head (from its first byte) and its body have deadlines of their own
// that cancel the read instead, so that the client still gets its 408. Each deadline is set once for the whole
// read: a client trickling bytes does not extend it.
#include <fcntl.h>
#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <atomic>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>

#include "http_policy.hpp"

namespace runout::service {

namespace net = boost::asio;
namespace beast = boost::beast;
using tcp = net::ip::tcp;
using front::BeastResponse;
using front::Refusal;

namespace {

std::chrono::nanoseconds secs(double s) { return std::chrono::nanoseconds(static_cast<int64_t>(s * 1e9)); }

constexpr size_t kMaxChunkExtension = 1024;  // bytes of one chunk's extensions (they are ignored)
constexpr auto kLinger = std::chrono::seconds(2);

void close_on_exec(int fd) { ::fcntl(fd, F_SETFD, ::fcntl(fd, F_GETFD) | FD_CLOEXEC); }

}  // namespace

// What every connection shares; HttpFront::Impl is this.
struct FrontCore {
  FrontOptions opt;
  HttpFront::Handler handler;
  HttpFront::HeadCheck head_check;
  HttpFront::Lane fast_lane;
  front::Limits limits{opt};
  std::atomic<int64_t> refused{0}, timed_out{0};
  std::atomic<int> draining{0};  // answered connections reading what the client still sends, before the close
  std::atomic<bool> stopping{false};
  std::unique_ptr<front::Pool> main_pool, fast_pool;
  net::io_context ioc{1};  // after what its pending handlers (the sessions) use: destroyed first
  tcp::acceptor acceptor{ioc};
  net::steady_timer accept_pause{ioc};
};

namespace {
using Core = FrontCore;

// Chunk extensions are not counted in --max-body: bounded here instead.
struct ChunkCheck {
  void operator()(std::uint64_t, beast::string_view extensions, beast::error_code& ec) {
    if (extensions.size() > kMaxChunkExtension) ec = front::http::error::bad_chunk_extension;
  }
};

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(Core& core, tcp::socket socket, std::string peer)
      : f_(core), stream_(std::move(socket)), buffer_(core.opt.max_head + 65536), timer_(core.ioc),
        peer_(std::move(peer)) {}
  ~Session() {
    if (draining_) --f_.draining;
    uncount();
  }
  void start() { next(f_.opt.header_timeout); }

 private:
  // Waits up to `wait` s for the first byte of the next request (then closes without an answer).
  void next(double wait) {
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(std::min<size_t>(f_.opt.max_head, UINT32_MAX)));
    // Set once the token is checked (a client without it gets 401, not 413). Not boost::none: Beast 1.74 then
    // refuses every Content-Length (it compares the length with an empty optional).
    parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
    parser_->on_chunk_header(chunk_check_);
    req_ = httplib::Request();
    instance_.clear();
    head_read_ = false;
    stream_.expires_after(secs(wait));
    await_request();
  }

  // Empty lines before a request are skipped (RFC 9112 2.2); the head's own deadline starts at its first byte.
  void await_request() {
    const auto* p = static_cast<const char*>(buffer_.data().data());
    size_t empty = 0;
    while (empty < buffer_.size() && (p[empty] == '\r' || p[empty] == '\n')) ++empty;
    buffer_.consume(empty);
    if (buffer_.size() > 0) {  // pipelined, or just arrived
      stream_.expires_never();
      return read_head();
    }
    stream_.async_read_some(buffer_.prepare(4096), [self = shared_from_this()](beast::error_code ec, size_t n) {
      if (ec) return self->close();
      self->buffer_.commit(n);
      self->await_request();
    });
  }

  void read_head() {
    arm(f_.opt.header_timeout);
    front::http::async_read_header(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, size_t) {
      self->disarm();
      if (ec) return self->fail(ec);
      self->on_head();
    });
  }

  // The head is complete: the policy's checks, the token, then the body or the handler.
  void on_head() {
    try {
      front::read_head(parser_->get(), req_, instance_);
      keep_ = parser_->get().keep_alive();
      plan_ = front::plan_body(req_);
      httplib::Response res;
      if (f_.head_check && f_.head_check(req_, res)) {
        if (res.status < 100) res.status = 400;
        return write(front::to_wire(res, false, false), true);
      }
      front::check_body(req_, plan_, f_.opt);
      if (plan_.body == parser_->is_done()) throw Refusal{400, "(body)", "framing not understood"};  // cannot happen
    } catch (const Refusal& r) {
      return write(front::to_wire(r, instance_), true);
    }
    if (!plan_.body) return dispatch();
    head_read_ = true;
    parser_->body_limit(f_.opt.max_body);
    arm(f_.opt.body_timeout);
    if (plan_.expect_continue && buffer_.size() == 0) {
      static const char kContinue[] = "HTTP/1.1 100 Continue\r\n\r\n";
      net::async_write(stream_, net::buffer(kContinue, sizeof kContinue - 1),
                       [self = shared_from_this()](beast::error_code ec, size_t) {
                         if (ec) return self->fail(ec);
                         self->read_body();
                       });
      return;
    }
    read_body();
  }

  void read_body() {
    front::http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, size_t) {
      self->disarm();
      if (ec) return self->fail(ec);
      self->dispatch();
    });
  }

  // A whole request to a handler thread; its response comes back to this thread to be written.
  void dispatch() {
    req_.body = std::move(parser_->get().body());
    const bool fast = f_.fast_lane(req_);
    auto task = [self = shared_from_this(), req = std::move(req_), keep = keep_]() {
      httplib::Response res;
      try {
        self->f_.handler(req, res);
      } catch (const std::exception& e) {
        res = httplib::Response();
        res.status = 500;
        res.set_content(problem_body(500, req.path, {{"", std::string("internal error: ") + e.what()}}), kProblemMediaType);
      } catch (...) {
        res = httplib::Response();
        res.status = 500;
        res.set_content(problem_body(500, req.path, {{"", "internal error"}}), kProblemMediaType);
      }
      auto wire = std::make_shared<BeastResponse>(front::to_wire(res, req.method == "HEAD", keep));
      net::post(self->f_.ioc, [self, wire, keep] { self->write(std::move(*wire), !keep); });
    };
    const bool queued = fast ? f_.fast_pool->push(std::move(task), 64) : f_.main_pool->push(std::move(task), f_.opt.max_pending);
    if (!queued)
      write(front::to_wire(Refusal{503, "(server)",
                                   "too many requests are waiting for a handler (accepted: at most " +
                                       std::to_string(f_.opt.max_pending) + " waiting); retry shortly",
                                   {{"Retry-After", "1"}}},
                           instance_),
            true);
  }

  void fail(beast::error_code ec) {
    if (late_) ++f_.timed_out;
    const Refusal r = front::refusal_for(ec, head_read_, late_, f_.opt);
    if (r.status == 0) return close();
    write(front::to_wire(r, instance_), true);
  }

  void write(BeastResponse res, bool close_after) {
    res_ = std::move(res);
    close_after_ = close_after || !keep_;
    stream_.expires_after(secs(f_.opt.write_timeout));
    front::http::async_write(stream_, res_, [self = shared_from_this()](beast::error_code ec, size_t) {
      self->stream_.expires_never();
      if (ec) {
        if (ec == beast::error::timeout) ++self->f_.timed_out;
        return self->close();
      }
      if (self->close_after_) return self->linger();
      self->next(self->f_.opt.idle_timeout);
    });
  }

  // Lingering close: the client may still be sending a body that was not read; closing now would reset the
  // connection and could destroy the answer before it is read. Read and drop for a short while, uncounted.
  void linger() {
    uncount();
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    if (ec || f_.draining.load() >= f_.opt.max_connections) return close();  // bounded: past it, closed at once
    ++f_.draining;
    draining_ = true;
    stream_.expires_after(kLinger);
    drain();
  }
  void drain() {
    stream_.async_read_some(net::buffer(scratch_), [self = shared_from_this()](beast::error_code ec, size_t) {
      if (ec) return self->close();
      self->drain();
    });
  }

  void close() {
    if (draining_) --f_.draining;
    draining_ = false;
    uncount();
    disarm();
    beast::error_code ec;
    stream_.socket().close(ec);
  }

  void uncount() {
    if (counted_) f_.limits.release(peer_);
    counted_ = false;
  }

  // The head's or the body's deadline: cancels the read, which then answers 408 (late_).
  void arm(double s) {
    late_ = false;
    const uint64_t gen = ++gen_;
    timer_.expires_after(secs(s));
    timer_.async_wait([w = weak_from_this(), gen](beast::error_code ec) {
      const auto self = w.lock();
      if (ec || !self || self->gen_ != gen) return;
      self->late_ = true;
      beast::error_code ignored;
      self->stream_.socket().cancel(ignored);
    });
  }
  void disarm() {
    ++gen_;
    timer_.cancel();
  }

  Core& f_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;  // its limit bounds a chunk's size line and trailer (Beast has none of its own)
  net::steady_timer timer_;
  std::string peer_;
  ChunkCheck chunk_check_;
  std::optional<front::http::request_parser<front::http::string_body>> parser_;
  httplib::Request req_;
  std::string instance_;  // the request's path once known (problem documents)
  front::BodyPlan plan_;
  BeastResponse res_;
  std::array<char, 16384> scratch_;
  uint64_t gen_ = 0;
  bool head_read_ = false, late_ = false, keep_ = true, close_after_ = false, counted_ = true, draining_ = false;
};

// Over a limit: answered and closed at once, never counted. (A refused connection that lingered and counted let
// one address flooding connections lock every other client out.) The answer fits a new socket's send buffer;
// what the client already sent is read first, so that the close does not reset the connection over unread
// bytes, which could destroy the answer.
void refuse_at_accept(Core& f, tcp::socket& s, const Refusal& r) {
  ++f.refused;
  std::ostringstream out;
  out << front::to_wire(r, "");
  const std::string bytes = out.str();
  const int fd = s.native_handle();
  (void)::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(fd, SHUT_WR);
  char buf[4096];
  while (::recv(fd, buf, sizeof buf, MSG_DONTWAIT) > 0) {
  }
  beast::error_code ec;
  s.close(ec);
}

void accept(Core& f) {
  f.acceptor.async_accept([&f](beast::error_code ec, tcp::socket s) {
    if (f.stopping.load() || !f.acceptor.is_open()) return;
    if (ec == net::error::no_descriptors || ec == net::error::no_buffer_space || ec == net::error::no_memory) {
      // Out of descriptors: the connection stays in the backlog; accepting again at once would spin.
      f.accept_pause.expires_after(std::chrono::milliseconds(100));
      f.accept_pause.async_wait([&f](beast::error_code) { accept(f); });
      return;
    }
    if (!ec) {
      close_on_exec(s.native_handle());
      beast::error_code e;
      s.set_option(tcp::no_delay(true), e);  // small replies: no Nagle + delayed ACK
      const auto ep = s.remote_endpoint(e);
      std::string peer = e ? std::string("?") : ep.address().to_string();
      Refusal r{0, "", ""};
      if (f.limits.admit(peer, r))
        std::make_shared<Session>(f, std::move(s), std::move(peer))->start();
      else
        refuse_at_accept(f, s, r);
    }
    accept(f);
  });
}

}  // namespace

struct HttpFront::Impl : FrontCore {};

HttpFront::HttpFront(FrontOptions options, Handler handler, HeadCheck head_check, Lane fast_lane)
    : impl_(std::make_unique<Impl>()) {
  impl_->opt = std::move(options);
  impl_->handler = std::move(handler);
  impl_->head_check = std::move(head_check);
  impl_->fast_lane = std::move(fast_lane);
}

HttpFront::~HttpFront() {
  stop();
  if (impl_->main_pool) impl_->main_pool->shutdown();
  if (impl_->fast_pool) impl_->fast_pool->shutdown();
}

int HttpFront::bind() {
  Core& m = *impl_;
  const std::string port = std::to_string(m.opt.port);
  beast::error_code ec;
  tcp::resolver resolver(m.ioc);
  const auto found = resolver.resolve(m.opt.host, port, tcp::resolver::passive | tcp::resolver::numeric_service, ec);
  if (ec || found.empty()) throw std::runtime_error("cannot resolve " + m.opt.host);
  for (const auto& entry : found) {
    m.acceptor.open(entry.endpoint().protocol(), ec);
    if (ec) continue;
    close_on_exec(m.acceptor.native_handle());
    m.acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
    m.acceptor.bind(entry.endpoint(), ec);
    if (!ec) m.acceptor.listen(1024, ec);
    if (!ec) break;
    m.acceptor.close();
  }
  if (!m.acceptor.is_open()) throw std::runtime_error("cannot bind to " + m.opt.host + ":" + port);
  return m.acceptor.local_endpoint().port();
}

void HttpFront::run() {
  Core& m = *impl_;
  m.main_pool = std::make_unique<front::Pool>(std::max(1, m.opt.handler_threads));
  m.fast_pool = std::make_unique<front::Pool>(1);
  accept(m);
  m.ioc.run();
  beast::error_code ec;
  m.acceptor.close(ec);  // no new connections while the handlers finish
  m.main_pool->shutdown();
  m.fast_pool->shutdown();
}

void HttpFront::stop() {
  impl_->stopping = true;
  impl_->ioc.stop();
}

FrontStats HttpFront::stats() const {
  FrontStats s;
  s.open_connections = impl_->limits.open();
  s.refused_connections = impl_->refused.load();
  s.timed_out = impl_->timed_out.load();
  if (impl_->main_pool) s.pending = static_cast<int64_t>(impl_->main_pool->pending());
  return s;
}

}  // namespace runout::service
