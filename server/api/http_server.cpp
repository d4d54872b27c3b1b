#include "api/http_server.hpp"

#include <httplib.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>
#include <variant>

#include "api/auth.hpp"
#include "api/connection_gate.hpp"
#include "api/request_checks.hpp"
#include "api/static_files.hpp"
#include "common/log.hpp"

namespace tally::api {
namespace {

using HandlerResponse = httplib::Server::HandlerResponse;

constexpr int kListenBacklog = 128;

bool isBodyMethod(const std::string& m) { return m == "POST" || m == "PUT" || m == "PATCH"; }
// Routed paths: the API and the metrics; everything else is a static file.
bool isApiPath(std::string_view p) { return p == "/api" || p.rfind("/api/", 0) == 0 || p == "/metrics"; }

// Sent with every response, errors included.
void addSecurityHeaders(httplib::Response& res) {
  res.set_header("X-Content-Type-Options", "nosniff");
  res.set_header("X-Frame-Options", "DENY");
  res.set_header("Referrer-Policy", "no-referrer");
}

std::string dumpJson(const nlohmann::json& j) {
  // Invalid UTF-8 from stored data must not throw here.
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// Sets a body that is sent as it is. cpp-httplib 0.11.4 compresses a text
// body set with set_content with brotli at its slowest quality whenever the
// client accepts "br", as browsers do: 0.35 s for the dashboard's 200 KiB
// chart library and 0.5 s for a list of 1,000 runs, for nothing on loopback.
// A body given as a content provider of known length is never compressed.
// Error bodies keep set_content: the error handler fills in empty ones.
void setUncompressed(httplib::Response& res, std::string body, const std::string& type) {
  if (body.empty() || res.status >= 400) {
    res.set_content(std::move(body), type.c_str());
    return;
  }
  auto shared = std::make_shared<const std::string>(std::move(body));
  res.set_content_provider(shared->size(), type.c_str(),
                           [shared](size_t offset, size_t length, httplib::DataSink& sink) {
                             return sink.write(shared->data() + offset, length);
                           });
}

void write(httplib::Response& res, Response r, bool api) {
  res.status = r.status;
  for (const auto& [k, v] : r.headers) res.set_header(k, v);
  if (api) res.set_header("Cache-Control", "no-store");
  if (r.status == 204 || r.status == 304) return;
  if (r.isRaw()) {
    setUncompressed(res, std::move(r.bytes), r.contentType);
  } else {
    setUncompressed(res, dumpJson(r.json), "application/json");
  }
}

// The verdict on a request before its body is read: refused, or let through
// with what the handler needs.
struct Admitted {
  bool api = false;
  Principal principal = Principal::kCapture;
};
using Verdict = std::variant<Response, Admitted>;

Response refuse(int status, const char* code, std::string message, std::string_view field = {}) {
  return errorResponse(status, code, message, field);
}

// A request the gate read whole, answered on its socket: reads come from the
// bytes read so far (then the socket, which a whole request never needs),
// writes go to the socket with a per-write timeout and an overall deadline,
// so that a client that stops reading cannot hold the thread for long.
class GatedStream final : public httplib::Stream {
 public:
  GatedStream(const ReadyRequest& ready, std::chrono::milliseconds readTimeout,
              std::chrono::milliseconds writeTimeout)
      : r_(ready),
        readTimeout_(readTimeout),
        writeTimeout_(writeTimeout),
        writeDeadline_(std::chrono::steady_clock::now() + 6 * writeTimeout) {}

  bool is_readable() const override { return at_ < r_.bytes.size() || wait(POLLIN, readTimeout_); }
  bool is_writable() const override {
    return std::chrono::steady_clock::now() < writeDeadline_ && wait(POLLOUT, writeTimeout_);
  }
  ssize_t read(char* ptr, size_t size) override {
    if (at_ < r_.bytes.size()) {
      size_t n = std::min(size, r_.bytes.size() - at_);
      std::memcpy(ptr, r_.bytes.data() + at_, n);
      at_ += n;
      return ssize_t(n);
    }
    if (!wait(POLLIN, readTimeout_)) return -1;
    return ::recv(r_.fd, ptr, size, 0);
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n = ::send(r_.fd, ptr, size, MSG_NOSIGNAL);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return 0;
    return n;
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = r_.peerIp;
    port = r_.peerPort;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = r_.localIp;
    port = r_.localPort;
  }
  socket_t socket() const override { return r_.fd; }

 private:
  bool wait(short events, std::chrono::milliseconds timeout) const {
    pollfd p{r_.fd, events, 0};
    int n;
    do {
      n = ::poll(&p, 1, int(timeout.count()));
    } while (n < 0 && errno == EINTR);
    return n > 0 && (p.revents & events) != 0;
  }

  const ReadyRequest& r_;
  size_t at_ = 0;
  std::chrono::milliseconds readTimeout_, writeTimeout_;
  std::chrono::steady_clock::time_point writeDeadline_;
};

// The library's request handling (parsing, routing, responses) over a
// request the gate has read; its accept loop is not used.
class GatedServer : public httplib::Server {
 public:
  void serve(httplib::Stream& stream) {
    bool closed = false;
    process_request(stream, /*close_connection=*/true, closed, nullptr);
  }
};

}  // namespace

struct HttpServer::Impl {
  ServerOptions options;
  Router router;
  Auth auth;
  std::optional<StaticFiles> web;
  GatedServer server;
  int port = 0;
  socket_t listenSocket = -1;
  std::atomic<bool> ran{false};
  std::thread thread;
  std::unique_ptr<ConnectionGate> gate;
  std::unique_ptr<httplib::ThreadPool> pool;
  metrics::Registry* metrics = nullptr;

  // The route a request counts under in the metrics: its pattern
  // ("/api/runs/{id}"), "static" for dashboard files, "unmatched" otherwise.
  std::string routeLabel(const std::string& method, const std::string& path) const {
    if (!isApiPath(path)) return "static";
    auto m = router.match(method == "HEAD" ? "GET" : method, path);
    return m.outcome == Router::Outcome::kFound ? m.route->pattern : "unmatched";
  }
  void serveReady(const ReadyRequest& ready);

  void log(std::string_view line) const {
    if (options.log) {
      options.log(line);
    } else {
      log::error(line);
    }
  }

  Verdict admit(const httplib::Request& req) const;
  void handle(const httplib::Request& req, httplib::Response& res) const;
  void install();
};

Verdict HttpServer::Impl::admit(const httplib::Request& req) const {
  // 1. Framing. The library would read chunked and compressed bodies past the
  //    payload limit, and a body without Content-Length until the peer closes.
  if (req.has_header("Transfer-Encoding"))
    return refuse(411, code::kLengthRequired,
                  "Transfer-Encoding is not accepted; send the body with Content-Length",
                  "Transfer-Encoding");
  if (req.has_header("Content-Encoding"))
    return refuse(415, code::kUnsupportedEncoding,
                  "Content-Encoding is not accepted; send the body uncompressed", "Content-Encoding");
  // The library adds REMOTE_ADDR/PORT and LOCAL_ADDR/PORT headers after the
  // client's, and header lookups return the client's first. Refuse any that
  // the client sent; only req.remote_addr (from the socket) is used.
  for (const char* reserved : {"REMOTE_ADDR", "REMOTE_PORT", "LOCAL_ADDR", "LOCAL_PORT"}) {
    if (req.get_header_value_count(reserved) > 1)
      return refuse(400, code::kBadHeader, std::string(reserved) + " is a reserved header", reserved);
  }
  if (req.get_header_value_count("REMOTE_ADDR") == 1 &&
      req.get_header_value("REMOTE_ADDR") != req.remote_addr)
    return refuse(400, code::kBadHeader, "REMOTE_ADDR is a reserved header", "REMOTE_ADDR");

  const size_t lengths = req.get_header_value_count("Content-Length");
  uint64_t length = 0;
  if (lengths > 1) return refuse(400, code::kBadHeader, "more than one Content-Length", "Content-Length");
  if (lengths == 1) {
    auto parsed = parseContentLength(req.get_header_value("Content-Length"));
    if (!parsed)
      return refuse(400, code::kBadHeader, "Content-Length is not a decimal number", "Content-Length");
    length = *parsed;
  }
  if (isBodyMethod(req.method) && lengths == 0)
    return refuse(411, code::kLengthRequired, req.method + " needs a Content-Length", "Content-Length");
  if (length > options.maxBodyBytes)
    return refuse(413, code::kPayloadTooLarge,
                  "body of " + std::to_string(length) + " bytes exceeds the limit of " +
                      std::to_string(options.maxBodyBytes),
                  "Content-Length");
  if (!isBodyMethod(req.method) && length > 0)
    return refuse(400, code::kUnexpectedBody, req.method + " takes no body", "Content-Length");

  // 2. The target.
  if (auto why = checkTarget(req.target, req.path)) return refuse(400, code::kBadPath, *why);
  for (auto it = req.params.begin(); it != req.params.end(); it = req.params.upper_bound(it->first)) {
    if (req.params.count(it->first) > 1)
      return refuse(400, code::kBadQuery, "query parameter '" + it->first + "' given more than once",
                    it->first);
  }

  // 3. Who is asking. One Host only: which of two a proxy, a cache or the
  //    checks below would use is anybody's guess (RFC 9112 3.2: answer 400).
  if (req.get_header_value_count("Host") > 1)
    return refuse(400, code::kBadHeader, "more than one Host header", "Host");
  //    Without tokens (loopback only) the Host must be a
  //    loopback name too, so a web page cannot reach us through DNS rebinding.
  if (!auth.required()) {
    if (req.has_header("Host") && !isLoopbackHost(req.get_header_value("Host")))
      return refuse(403, code::kForbiddenHost,
                    "Host must be a loopback address (localhost, 127.0.0.1, [::1])", "Host");
  }
  Admitted admitted;
  admitted.api = isApiPath(req.path);
  if (!admitted.api) {
    if (req.method != "GET" && req.method != "HEAD") {
      auto r = refuse(405, code::kMethodNotAllowed, req.method + " is not allowed on static files");
      r.headers.emplace_back("Allow", "GET, HEAD");
      return r;
    }
    return admitted;  // static files are public: they hold no data
  }
  if (auth.required()) {
    const size_t n = req.get_header_value_count("Authorization");
    if (n > 1) return refuse(400, code::kBadHeader, "more than one Authorization header", "Authorization");
    std::optional<Principal> who;
    if (n == 1) who = auth.authenticate(req.get_header_value("Authorization"));
    if (!who) {
      auto r = refuse(401, code::kUnauthorized,
                      n == 0 ? "missing Authorization: Bearer <token>" : "unknown token", "Authorization");
      r.headers.emplace_back("WWW-Authenticate", "Bearer");
      return r;
    }
    admitted.principal = *who;
  }

  // 4. The route, before the body is read.
  auto m = router.match(req.method, req.path);
  if (m.outcome == Router::Outcome::kNotFound)
    return refuse(404, code::kNotFound, "no route for " + req.path);
  if (m.outcome == Router::Outcome::kMethodNotAllowed) {
    auto r = refuse(405, code::kMethodNotAllowed, req.method + " is not allowed on " + req.path);
    r.headers.emplace_back("Allow", joinAllowed(m.allowed));
    return r;
  }
  if (!allows(admitted.principal, m.route->need))
    return refuse(403, code::kForbidden, "this token may read but not capture or delete", "Authorization");

  // 5. Body type and the headers handed to services.
  if (length > 0 && !isJsonMediaType(req.get_header_value("Content-Type")))
    return refuse(415, code::kUnsupportedMediaType, "the body must be application/json", "Content-Type");
  if (req.get_header_value_count("Idempotency-Key") > 1)
    return refuse(400, code::kBadHeader, "more than one Idempotency-Key", "Idempotency-Key");
  if (req.has_header("Idempotency-Key") && !isValidIdempotencyKey(req.get_header_value("Idempotency-Key")))
    return refuse(400, code::kBadHeader, "Idempotency-Key must be 1-200 visible ASCII characters",
                  "Idempotency-Key");
  return admitted;
}

void HttpServer::Impl::handle(const httplib::Request& req, httplib::Response& res) const {
  // Same verdict as before the body was read (it depends on headers only).
  Verdict verdict = admit(req);
  if (auto* refused = std::get_if<Response>(&verdict)) return write(res, *refused, true);
  const auto& admitted = std::get<Admitted>(verdict);

  if (!admitted.api) {
    std::optional<StaticFile> file;
    if (web) file = web->lookup(req.path);
    if (!file) return write(res, errorResponse(404, code::kNotFound, "no such file: " + req.path), false);
    res.status = 200;
    res.set_header("Cache-Control", "no-cache");
    setUncompressed(res, std::move(file->bytes), file->contentType);
    return;
  }

  Request request;
  request.method = req.method == "HEAD" ? "GET" : req.method;
  request.path = req.path;
  for (const auto& [k, v] : req.params) request.query.emplace(k, v);
  request.principal = admitted.principal;
  request.remoteAddr = req.remote_addr;
  request.client =
      auth.required() ? std::string("token:") + principalName(admitted.principal) : "peer:" + req.remote_addr;
  request.idempotencyKey = req.get_header_value("Idempotency-Key");
  if (!req.body.empty()) {
    auto body = parseJsonBody(req.body);
    if (!body) return write(res, errorResponse(400, code::kBadJson, body.error(), "body"), true);
    request.body = std::move(*body);
  }
  write(res, router.dispatch(std::move(request)), true);
}

thread_local std::chrono::steady_clock::time_point tRequestStart;

void HttpServer::Impl::serveReady(const ReadyRequest& ready) {
  tRequestStart = std::chrono::steady_clock::now();
  {
    GatedStream stream(ready, options.readTimeout, options.writeTimeout);
    server.serve(stream);
  }
  ::shutdown(ready.fd, SHUT_WR);
  ::close(ready.fd);
  gate->release(ready.peerIp);
}

void HttpServer::Impl::install() {
  server.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                              {"X-Frame-Options", "DENY"},
                              {"Referrer-Policy", "no-referrer"}});
  // One request per connection: a request refused before its body was read
  // leaves that body unread, and it must not be parsed as the next request.
  server.set_keep_alive_max_count(1);
  server.set_payload_max_length(options.maxBodyBytes);  // backstop; admit() refuses first
  // Time and count every answered request by route and status (the
  // library calls its logger once the response is written).
  if (metrics != nullptr) {
    server.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
      double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - tRequestStart).count();
      std::string route = routeLabel(req.method, req.path);
      metrics->observe("tally_http_request_duration_seconds", {{"route", route}}, seconds);
      metrics->add("tally_http_requests_total", {{"route", route}, {"code", std::to_string(res.status)}});
    });
  }
  // The library's default adds SO_REUSEPORT, which would let a second process
  // bind our port and take a share of the connections. Keep SO_REUSEADDR only
  // (restarts while old connections sit in TIME_WAIT).
  server.set_socket_options([this](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    listenSocket = sock;
  });

  server.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    Verdict verdict = admit(req);
    if (auto* refused = std::get_if<Response>(&verdict)) {
      write(res, *refused, true);
      return HandlerResponse::Handled;
    }
    return HandlerResponse::Unhandled;
  });

  auto handler = [this](const httplib::Request& req, httplib::Response& res) { handle(req, res); };
  server.Get(".*", handler);
  server.Post(".*", handler);
  server.Put(".*", handler);
  server.Patch(".*", handler);
  server.Delete(".*", handler);
  server.Options(".*", handler);

  // Errors the library raises itself (malformed request line, 414, 416, ...)
  // get the JSON error body too; our own errors already have one.
  server.set_error_handler(
      httplib::Server::HandlerWithResponse([](const httplib::Request&, httplib::Response& res) {
        if (res.body.empty()) {
          res.set_content(dumpJson(errorBody(defaultErrorCode(res.status), defaultErrorMessage(res.status))),
                          "application/json");
        }
        return HandlerResponse::Handled;
      }));

  // Without this the library sends e.what() in an EXCEPTION_WHAT header.
  server.set_exception_handler(
      [this](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
        std::string what = "unknown exception";
        try {
          if (ep) std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          what = e.what();
        } catch (...) {
        }
        log("internal error on " + req.method + " " + req.path + ": " + what);
        res = httplib::Response();
        res.version = "HTTP/1.1";
        addSecurityHeaders(res);
        res.status = 500;
        res.set_header("Cache-Control", "no-store");
        res.set_content(dumpJson(errorBody(code::kInternal, "internal error; see the server log")),
                        "application/json");
      });
}

Result<std::unique_ptr<HttpServer>> HttpServer::create(ServerOptions options, Router router) {
  // The token rule is checked before anything binds.
  auto auth = Auth::forBind(options.bindAddress, options.tokenFile);
  if (!auth) return makeError(auth.error());
  if (options.port < 0 || options.port > 65535)
    return makeError("port " + std::to_string(options.port) + " out of range");

  auto impl = std::make_unique<Impl>();
  if (!options.webRoot.empty()) {
    auto web = StaticFiles::open(options.webRoot);
    if (!web) return makeError(web.error());
    impl->web = std::move(*web);
  }
  impl->options = std::move(options);
  impl->router = std::move(router);
  impl->auth = std::move(*auth);
  impl->metrics = impl->options.metrics;
  if (impl->metrics != nullptr) {
    impl->metrics->declare("tally_http_request_duration_seconds", metrics::Type::kHistogram,
                           "Time from a request read whole to its response written, by route", metrics::kRequestSeconds);
    impl->metrics->declare("tally_http_requests_total", metrics::Type::kCounter,
                           "Requests answered, by route and status code");
    impl->metrics->declare("tally_http_connections_refused_total", metrics::Type::kCounter,
                           "Connections closed by the front door: peer_limit, total_limit, timeout "
                           "(request not read whole in time), header_too_large");
    impl->metrics->declare("tally_http_connections_open", metrics::Type::kGauge,
                           "Connections open: being read, or being answered");
  }
  impl->install();

  const std::string host = impl->options.bindAddress == "localhost" ? "127.0.0.1" : impl->options.bindAddress;
  if (impl->options.port == 0) {
    impl->port = impl->server.bind_to_any_port(host);
    if (impl->port <= 0) return makeError("cannot bind " + host + " on any port");
  } else {
    if (!impl->server.bind_to_port(host, impl->options.port))
      return makeError("cannot bind " + host + ":" + std::to_string(impl->options.port) +
                       " (in use, or not an address here)");
    impl->port = impl->options.port;
  }
  if (impl->listenSocket < 0) return makeError("cannot bind " + host + ": no socket");
  // The library listens with a backlog of 5; a dashboard opening a dozen
  // connections at once would see SYNs dropped and retried a second later.
  ::listen(impl->listenSocket, kListenBacklog);

  GateOptions gate;
  gate.requestTimeout = impl->options.requestTimeout;
  gate.maxBodyBytes = impl->options.maxBodyBytes;
  gate.maxConnections = impl->options.maxConnections;
  gate.maxConnectionsPerPeer = impl->options.maxConnectionsPerPeer;
  Impl* raw = impl.get();
  impl->gate = std::make_unique<ConnectionGate>(
      impl->listenSocket, gate,
      [raw](ReadyRequest ready) {
        auto shared = std::make_shared<ReadyRequest>(std::move(ready));
        raw->pool->enqueue([raw, shared] { raw->serveReady(*shared); });
      },
      [raw](Refusal why, const std::string& peer) {
        if (raw->metrics != nullptr)
          raw->metrics->add("tally_http_connections_refused_total", {{"reason", refusalName(why)}});
        (void)peer;  // counted, not logged: a flood of refusals must not flood the journal
      });
  if (impl->metrics != nullptr) {
    impl->metrics->onScrape([raw](metrics::Registry& r) {
      r.set("tally_http_connections_open", {}, double(raw->gate->openConnections()));
    });
  }
  return std::unique_ptr<HttpServer>(new HttpServer(std::move(impl)));
}

HttpServer::HttpServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpServer::~HttpServer() {
  stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  if (impl_->listenSocket >= 0) ::close(impl_->listenSocket);
}

int HttpServer::port() const { return impl_->port; }
bool HttpServer::tokensRequired() const { return impl_->auth.required(); }

void HttpServer::run() {
  if (impl_->ran.exchange(true)) return;
  const size_t threads = impl_->options.threads == 0 ? 1 : impl_->options.threads;
  impl_->pool = std::make_unique<httplib::ThreadPool>(threads);
  if (!impl_->gate->run()) impl_->log("cannot start serving: epoll failed");
  // Requests already handed on are answered before run() returns.
  impl_->pool->shutdown();
}

void HttpServer::start() {
  if (impl_->thread.joinable()) return;
  impl_->thread = std::thread([this] { run(); });
  // Wait until the gate serves (the socket is already listening, so clients
  // can connect meanwhile), or was stopped first.
  for (int i = 0; i < 2000 && !impl_->gate->running() && impl_->thread.joinable(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void HttpServer::stop() { impl_->gate->stop(); }

}  // namespace tally::api
