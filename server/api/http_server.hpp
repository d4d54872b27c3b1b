// HttpServer: an evented front door (ConnectionGate) that reads each request
// whole, cpp-httplib's request handling underneath, JSON handlers (Router) on top.
// Everything the library gets wrong or leaves open is closed here: framing
// (chunked/gzip bodies, missing or oversized Content-Length), traversal,
// exception text on the wire, spoofable REMOTE_ADDR, auth, DNS rebinding.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "api/router.hpp"
#include "common/metrics.hpp"
#include "common/result.hpp"

namespace tally::api {

struct ServerOptions {
  std::string bindAddress = "127.0.0.1";
  int port = 0;                         // 0: an ephemeral port, see HttpServer::port()
  std::filesystem::path tokenFile;      // empty: none (loopback only); given: always enforced
  std::filesystem::path webRoot;        // empty: no static files (non-/api paths answer 404)
  std::size_t maxBodyBytes = 1u << 20;  // 1 MiB: a capture spec is a few KiB
  std::chrono::milliseconds readTimeout{5000};   // a handler's read past what the front door read
  std::chrono::milliseconds writeTimeout{5000};  // per write; a response may take 6x this in all
  std::size_t threads = 8;  // threads answering requests read whole; one request per connection
  // The front door (api/connection_gate.hpp): requests are read whole by one
  // evented thread before a worker thread sees them.
  std::chrono::milliseconds requestTimeout{10000};  // accept -> whole request, else 408
  std::size_t maxConnections = 1024;                // open at once, else 503
  std::size_t maxConnectionsPerPeer = 64;           // per remote address, else 503
  metrics::Registry* metrics = nullptr;             // request counts and latencies, when given
  // Server-side log (internal errors with their text). Default: stderr.
  std::function<void(std::string_view)> log;
};

class HttpServer {
 public:
  // Checks the bind/token rule and the web root, then binds (nothing is
  // bound when a check fails). Serve with run() or start().
  static Result<std::unique_ptr<HttpServer>> create(ServerOptions options, Router router);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  int port() const;
  bool tokensRequired() const;

  void run();    // serves until stop(); blocks
  void start();  // run() on a background thread
  void stop();   // safe to call more than once and from a handler's thread

 private:
  struct Impl;
  explicit HttpServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace tally::api
