// HttpServer: cpp-httplib underneath, JSON handlers (Router) on top.
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
#include "common/result.hpp"

namespace tally::api {

struct ServerOptions {
  std::string bindAddress = "127.0.0.1";
  int port = 0;                         // 0: an ephemeral port, see HttpServer::port()
  std::filesystem::path tokenFile;      // empty: none (loopback only); given: always enforced
  std::filesystem::path webRoot;        // empty: no static files (non-/api paths answer 404)
  std::size_t maxBodyBytes = 1u << 20;  // 1 MiB: a capture spec is a few KiB
  std::chrono::milliseconds readTimeout{5000};
  std::chrono::milliseconds writeTimeout{5000};
  std::size_t threads = 8;  // worker threads; one request per connection (no keep-alive)
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
