#include "api/connection_gate.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <memory>
#include <unordered_map>
#include <vector>

namespace tally::api {
namespace {

using Clock = std::chrono::steady_clock;

char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }

bool equalsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

void addressOf(const sockaddr_storage& addr, std::string& ip, int& port) {
  char text[INET6_ADDRSTRLEN] = {};
  if (addr.ss_family == AF_INET) {
    const auto* in = reinterpret_cast<const sockaddr_in*>(&addr);
    inet_ntop(AF_INET, &in->sin_addr, text, sizeof text);
    port = ntohs(in->sin_port);
  } else if (addr.ss_family == AF_INET6) {
    const auto* in6 = reinterpret_cast<const sockaddr_in6*>(&addr);
    inet_ntop(AF_INET6, &in6->sin6_addr, text, sizeof text);
    port = ntohs(in6->sin6_port);
  }
  ip = text;
}

// A short answer to a connection the gate closes itself, written once,
// without waiting: the peer may not be reading.
void refuseOnSocket(int fd, int status, const char* reason, const char* code, const char* message) {
  std::string body = std::string("{\"error\":{\"code\":\"") + code + "\",\"message\":\"" + message + "\"}}";
  std::string text = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                     "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
                     "\r\nConnection: close\r\nX-Content-Type-Options: nosniff\r\n" +
                     (status == 503 ? "Retry-After: 1\r\n" : "") + "\r\n" + body;
  (void)::send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

struct Pending {
  int fd = -1;
  std::string peerIp, localIp;
  int peerPort = 0, localPort = 0;
  std::string bytes;
  Clock::time_point deadline;
  bool continueSent = false;
};

}  // namespace

const char* refusalName(Refusal r) {
  switch (r) {
    case Refusal::kPeerLimit: return "peer_limit";
    case Refusal::kTotalLimit: return "total_limit";
    case Refusal::kTimeout: return "timeout";
    case Refusal::kHeaderTooLarge: return "header_too_large";
  }
  return "unknown";
}

RequestExtent requestExtent(std::string_view bytes, std::size_t maxBodyBytes) {
  RequestExtent extent;
  size_t end = bytes.find("\r\n\r\n");
  if (end == std::string_view::npos) return extent;
  extent.headerComplete = true;
  extent.headerBytes = end + 4;
  // Header lines after the request line. Anything odd (two lengths, a
  // length that is not a number, chunked framing) waits for no body: the
  // handler refuses the request from its header alone.
  std::string_view header = bytes.substr(0, end);
  size_t lengths = 0;
  bool valid = true, chunked = false, expect = false;
  uint64_t length = 0;
  size_t at = header.find("\r\n");
  while (at != std::string_view::npos) {
    size_t next = header.find("\r\n", at + 2);
    std::string_view line = header.substr(at + 2, next == std::string_view::npos ? std::string_view::npos : next - at - 2);
    at = next;
    size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    std::string_view name = line.substr(0, colon), value = trim(line.substr(colon + 1));
    if (equalsIgnoreCase(name, "Content-Length")) {
      ++lengths;
      if (value.empty() || value.size() > 18) valid = false;
      for (char c : value) valid = valid && c >= '0' && c <= '9';
      if (valid) length = std::stoull(std::string(value));
    } else if (equalsIgnoreCase(name, "Transfer-Encoding") || equalsIgnoreCase(name, "Content-Encoding")) {
      chunked = true;  // refused from the header (411, 415): no body to wait for
    } else if (equalsIgnoreCase(name, "Expect")) {
      expect = equalsIgnoreCase(value, "100-continue");
    }
  }
  if (lengths == 1 && valid && !chunked && length <= maxBodyBytes) {
    extent.bodyBytes = static_cast<size_t>(length);
    extent.expectContinue = expect && length > 0;
  }
  return extent;
}

ConnectionGate::ConnectionGate(int listenFd, GateOptions options, OnReady onReady, OnRefused onRefused)
    : listenFd_(listenFd),
      options_(options),
      onReady_(std::move(onReady)),
      onRefused_(std::move(onRefused)) {
  wakeFd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
}

ConnectionGate::~ConnectionGate() {
  if (wakeFd_ >= 0) ::close(wakeFd_);
}

void ConnectionGate::stop() {
  stopping_ = true;
  uint64_t one = 1;
  if (wakeFd_ >= 0) (void)!::write(wakeFd_, &one, sizeof one);
}

bool ConnectionGate::admit(const std::string& peerIp) {
  std::lock_guard lock(mutex_);
  if (open_ >= options_.maxConnections) {
    if (onRefused_) onRefused_(Refusal::kTotalLimit, peerIp);
    return false;
  }
  size_t& mine = perPeer_[peerIp];
  if (mine >= options_.maxConnectionsPerPeer) {
    if (onRefused_) onRefused_(Refusal::kPeerLimit, peerIp);
    return false;
  }
  ++mine;
  ++open_;
  return true;
}

void ConnectionGate::release(const std::string& peerIp) {
  std::lock_guard lock(mutex_);
  auto it = perPeer_.find(peerIp);
  if (it != perPeer_.end() && --it->second == 0) perPeer_.erase(it);
  if (open_ > 0) --open_;
}

std::size_t ConnectionGate::openConnections() const {
  std::lock_guard lock(mutex_);
  return open_;
}

// One run of the gate's loop: the epoll set, the connections still being
// read, and what happens to each (ConnectionGate::run).
class GateLoop {
 public:
  GateLoop(ConnectionGate& gate, int ep) : gate_(gate), ep_(ep) {}

  void drop(Pending& p) {
    ::epoll_ctl(ep_, EPOLL_CTL_DEL, p.fd, nullptr);
    ::close(p.fd);
    gate_.release(p.peerIp);
    pending_.erase(p.fd);
  }
  void refuse(Pending& p, Refusal why, int status, const char* reason, const char* code,
              const char* message) {
    if (gate_.onRefused_) gate_.onRefused_(why, p.peerIp);
    refuseOnSocket(p.fd, status, reason, code, message);
    drop(p);
  }

  // Every connection waiting on the listening socket.
  void acceptAll() {
    for (;;) {
      sockaddr_storage peer{};
      socklen_t len = sizeof peer;
      int c = ::accept4(gate_.listenFd_, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (c < 0) break;  // EAGAIN: none left; EMFILE and the like: try at the next wake-up
      auto p = std::make_unique<Pending>();
      p->fd = c;
      addressOf(peer, p->peerIp, p->peerPort);
      sockaddr_storage local{};
      len = sizeof local;
      if (::getsockname(c, reinterpret_cast<sockaddr*>(&local), &len) == 0) addressOf(local, p->localIp, p->localPort);
      if (!gate_.admit(p->peerIp)) {
        refuseOnSocket(c, 503, "Service Unavailable", "unavailable", "too many open connections; try again shortly");
        ::close(c);
        continue;
      }
      p->deadline = Clock::now() + gate_.options_.requestTimeout;
      epoll_event cev{};
      cev.events = EPOLLIN | EPOLLRDHUP;
      cev.data.fd = c;
      if (::epoll_ctl(ep_, EPOLL_CTL_ADD, c, &cev) != 0) {
        ::close(c);
        gate_.release(p->peerIp);
        continue;
      }
      pending_.emplace(c, std::move(p));
    }
  }

  // What arrived on a connection: read on, refused, dropped, or handed on whole.
  void readFrom(int fd) {
    auto it = pending_.find(fd);
    if (it == pending_.end()) return;
    Pending& p = *it->second;
    const auto& options = gate_.options_;
    bool closed = false;
    for (;;) {
      ssize_t got = ::recv(fd, buffer_, sizeof buffer_, 0);
      if (got > 0) {
        p.bytes.append(buffer_, size_t(got));
        if (p.bytes.size() > options.maxHeaderBytes + options.maxBodyBytes) break;
        continue;
      }
      if (got == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) closed = true;
      if (got < 0 && errno == EINTR) continue;
      break;
    }
    RequestExtent extent = requestExtent(p.bytes, options.maxBodyBytes);
    // The header limit holds however the bytes came: a whole oversized
    // header in one read is as refused as one that is still arriving.
    if (extent.headerComplete && extent.headerBytes > options.maxHeaderBytes) {
      refuse(p, Refusal::kHeaderTooLarge, 431, "Request Header Fields Too Large", "bad_header",
             "the request header is too large");
      return;
    }
    if (!extent.headerComplete) {
      if (p.bytes.size() > options.maxHeaderBytes) {
        refuse(p, Refusal::kHeaderTooLarge, 431, "Request Header Fields Too Large", "bad_header",
               "the request header is too large");
      } else if (closed) {
        drop(p);  // gone before finishing its header: nothing to answer
      }
      return;
    }
    bool whole = p.bytes.size() >= extent.headerBytes + extent.bodyBytes;
    if (!whole && closed) {
      drop(p);
      return;
    }
    if (!whole) {
      if (extent.expectContinue && !p.continueSent) {
        static constexpr char kContinue[] = "HTTP/1.1 100 Continue\r\n\r\n";
        (void)::send(fd, kContinue, sizeof kContinue - 1, MSG_NOSIGNAL | MSG_DONTWAIT);
        p.continueSent = true;
      }
      return;
    }
    // Whole: hand it on. From here its handler owns the socket.
    ::epoll_ctl(ep_, EPOLL_CTL_DEL, fd, nullptr);
    ReadyRequest ready{fd, std::move(p.bytes), p.peerIp, p.peerPort, p.localIp, p.localPort};
    pending_.erase(it);
    gate_.onReady_(std::move(ready));
  }

  // Requests not read whole in time.
  void refuseLate() {
    auto now = Clock::now();
    std::vector<int> late;
    for (const auto& [fd, p] : pending_) {
      if (now >= p->deadline) late.push_back(fd);
    }
    for (int fd : late) {
      refuse(*pending_.at(fd), Refusal::kTimeout, 408, "Request Timeout", "request_timeout",
             "the request was not received in time");
    }
  }

  void dropAll() {
    std::vector<int> left;
    for (const auto& [fd, p] : pending_) left.push_back(fd);
    for (int fd : left) drop(*pending_.at(fd));
  }

 private:
  ConnectionGate& gate_;
  int ep_;
  std::unordered_map<int, std::unique_ptr<Pending>> pending_;
  char buffer_[16384];
};

bool ConnectionGate::run() {
  if (wakeFd_ < 0) return false;
  int ep = ::epoll_create1(EPOLL_CLOEXEC);
  if (ep < 0) return false;
  struct EpollCloser {
    int fd;
    ~EpollCloser() { ::close(fd); }
  } closer{ep};
  ::fcntl(listenFd_, F_SETFL, ::fcntl(listenFd_, F_GETFL) | O_NONBLOCK);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.fd = listenFd_;
  if (::epoll_ctl(ep, EPOLL_CTL_ADD, listenFd_, &ev) != 0) return false;
  ev.data.fd = wakeFd_;
  if (::epoll_ctl(ep, EPOLL_CTL_ADD, wakeFd_, &ev) != 0) return false;

  GateLoop loop(*this, ep);
  running_ = true;
  std::array<epoll_event, 64> events{};
  while (!stopping_) {
    // Deadlines are checked at least every 100 ms.
    int n = ::epoll_wait(ep, events.data(), int(events.size()), 100);
    if (n < 0 && errno != EINTR) break;
    for (int i = 0; i < n && !stopping_; ++i) {
      int fd = events[i].data.fd;
      if (fd == wakeFd_) continue;
      if (fd == listenFd_) {
        loop.acceptAll();
      } else {
        loop.readFrom(fd);
      }
    }
    loop.refuseLate();
  }
  running_ = false;
  loop.dropAll();
  return true;
}

}  // namespace tally::api
