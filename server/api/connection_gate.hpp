// ConnectionGate: the daemon's front door. One thread, epoll, non-blocking
// sockets. It accepts connections and reads each request whole (header, and
// a body up to the payload limit) before any worker thread sees it, so a
// client that sends slowly, or never finishes, holds a few KiB of memory and
// no thread. It also bounds what one peer can hold:
//  - the whole request must arrive within requestTimeout of the accept (408);
//  - a header larger than maxHeaderBytes is refused (431);
//  - at most maxConnectionsPerPeer open connections per peer address, and
//    maxConnections in all; more are answered 503 with Retry-After and closed.
// A request read whole is handed on (onReady) with its bytes; the handler
// answers on the socket, closes it and calls release(). The gate knows HTTP
// only as far as finding the header's end and Content-Length: everything
// else (framing errors, limits, auth) is judged by the handler as before.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace tally::api {

struct GateOptions {
  std::chrono::milliseconds requestTimeout{10000};  // accept -> last byte of the request
  std::size_t maxHeaderBytes = 64 * 1024;           // request line and headers
  std::size_t maxBodyBytes = 1u << 20;  // a larger declared body is not waited for: handed on at the header (413)
  std::size_t maxConnections = 1024;       // open at once, read or being answered
  std::size_t maxConnectionsPerPeer = 64;  // per remote address
};

struct ReadyRequest {
  int fd = -1;         // non-blocking; the handler closes it, then calls release(peerIp)
  std::string bytes;   // what was read: the header, and the body when it was waited for
  std::string peerIp;  // from the socket, never from a header
  int peerPort = 0;
  std::string localIp;
  int localPort = 0;
};

enum class Refusal { kPeerLimit, kTotalLimit, kTimeout, kHeaderTooLarge };
const char* refusalName(Refusal r);  // "peer_limit", "total_limit", "timeout", "header_too_large"

// The request's extent as far as the gate needs it; exposed for tests.
struct RequestExtent {
  bool headerComplete = false;
  std::size_t headerBytes = 0;  // through the blank line
  std::size_t bodyBytes = 0;    // to wait for: a single valid Content-Length within the limit, else 0
  bool expectContinue = false;  // "Expect: 100-continue" and a body to wait for
};
RequestExtent requestExtent(std::string_view bytes, std::size_t maxBodyBytes);

class GateLoop;

class ConnectionGate {
 public:
  using OnReady = std::function<void(ReadyRequest)>;
  using OnRefused = std::function<void(Refusal, const std::string& peerIp)>;

  // listenFd: bound and listening; the gate makes it non-blocking, does not close it.
  ConnectionGate(int listenFd, GateOptions options, OnReady onReady, OnRefused onRefused = {});
  ~ConnectionGate();
  ConnectionGate(const ConnectionGate&) = delete;
  ConnectionGate& operator=(const ConnectionGate&) = delete;

  // Accepts and reads until stop(); blocks. Connections still being read
  // when it returns are closed. Returns false when epoll cannot be set up.
  bool run();
  void stop();  // from any thread, before or during run()
  bool running() const { return running_; }

  // A handed-on connection was closed by its handler.
  void release(const std::string& peerIp);
  std::size_t openConnections() const;

 private:
  friend class GateLoop;  // run()'s loop (connection_gate.cpp)
  bool admit(const std::string& peerIp);  // counts it, or false at a limit

  int listenFd_;
  int wakeFd_ = -1;
  GateOptions options_;
  OnReady onReady_;
  OnRefused onRefused_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> running_{false};
  mutable std::mutex mutex_;
  std::map<std::string, std::size_t> perPeer_;
  std::size_t open_ = 0;
};

}  // namespace tally::api
