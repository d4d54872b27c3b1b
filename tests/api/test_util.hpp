// An in-process server on 127.0.0.1 and a raw-socket client for requests
// that no well-behaved HTTP client would send.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "api/builtin_routes.hpp"
#include "api/http_server.hpp"

namespace tally::api::test {

struct RawResponse {
  int status = 0;
  std::multimap<std::string, std::string> headers;  // names lower-cased
  std::string body;
  std::string raw;

  std::string header(const std::string& lowerName) const {
    auto it = headers.find(lowerName);
    return it == headers.end() ? "" : it->second;
  }
  nlohmann::json json() const { return nlohmann::json::parse(body, nullptr, false); }
};

// Sends bytes as they are and reads until the server closes (every response
// closes the connection) or 5 s pass.
inline RawResponse rawRequest(int port, const std::string& bytes) {
  RawResponse out;
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    ::close(fd);
    return out;
  }
  size_t sent = 0;
  while (sent < bytes.size()) {
    ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may refuse before reading everything
    sent += static_cast<size_t>(n);
  }
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  char buf[8192];
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) break;
    out.raw.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);

  size_t headEnd = out.raw.find("\r\n\r\n");
  if (out.raw.rfind("HTTP/1.", 0) != 0 || headEnd == std::string::npos) return out;
  out.status = std::atoi(out.raw.c_str() + 9);
  size_t pos = out.raw.find("\r\n") + 2;
  while (pos < headEnd) {
    size_t end = out.raw.find("\r\n", pos);
    std::string line = out.raw.substr(pos, end - pos);
    size_t colon = line.find(':');
    if (colon != std::string::npos) {
      std::string name = line.substr(0, colon);
      for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      size_t v = colon + 1;
      while (v < line.size() && line[v] == ' ') ++v;
      out.headers.emplace(name, line.substr(v));
    }
    pos = end + 2;
  }
  out.body = out.raw.substr(headEnd + 4);
  return out;
}

// A GET with the usual headers.
inline RawResponse get(int port, const std::string& target, const std::string& extraHeaders = "") {
  return rawRequest(port, "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + extraHeaders + "\r\n");
}

inline std::string jsonPost(const std::string& target, const std::string& body,
                            const std::string& extraHeaders = "") {
  return "POST " + target +
         " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\nContent-Length: " +
         std::to_string(body.size()) + "\r\n" + extraHeaders + "\r\n" + body;
}

// A scratch directory, removed at the end.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "tally-api-XXXXXX").string();
    path_ = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path write(const std::string& rel, const std::string& content) const {
    auto p = path_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }

 private:
  std::filesystem::path path_;
};

// Routes for the tests: echo what the service layer sees, throw, and a
// capture-level route with a parameter.
inline Router testRouter() {
  Router r;
  addBuiltinRoutes(r, {"forward", "deferred"}, nlohmann::json::array(), {"volume-fog"});
  auto echo = [](const Request& req) {
    return Response::ok({{"method", req.method},
                         {"path", req.path},
                         {"params", req.params},
                         {"query", req.query},
                         {"body", req.body},
                         {"idempotency_key", req.idempotencyKey},
                         {"principal", principalName(req.principal)},
                         {"remote_addr", req.remoteAddr}});
  };
  r.post("/api/test/echo", echo);
  r.get("/api/test/echo", echo);
  r.get("/api/test/items/{id}", echo);
  r.del("/api/test/items/{id}", echo);
  r.get("/api/test/items/special", [](const Request&) { return Response::ok({{"special", true}}); });
  r.get("/api/test/throw",
        [](const Request&) -> Response { throw std::runtime_error("secret-detail-7f3a /etc/shadow"); });
  r.get("/api/test/throw-int", [](const Request&) -> Response { throw 42; });
  r.get("/api/test/png",
        [](const Request&) { return Response::raw(std::string("\x89PNG\r\n", 6), "image/png"); });
  return r;
}

struct LogSink {
  std::mutex mutex;
  std::vector<std::string> lines;
  std::function<void(std::string_view)> fn() {
    return [this](std::string_view line) {
      std::lock_guard lock(mutex);
      lines.emplace_back(line);
    };
  }
  std::string all() {
    std::lock_guard lock(mutex);
    std::string s;
    for (auto& l : lines) s += l + "\n";
    return s;
  }
};

}  // namespace tally::api::test
