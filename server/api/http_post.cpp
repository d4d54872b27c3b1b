#include "api/http_post.hpp"

#include <algorithm>
#include <cctype>

#include <httplib.h>

namespace tally::api {

Result<HttpTarget> parseHttpUrl(const std::string& url) {
  if (url.starts_with("https://")) {
    return makeError("https is not supported by this build; use http:// (a relay on the host can add TLS)");
  }
  const std::string scheme = "http://";
  if (!url.starts_with(scheme)) return makeError("must start with http://");
  std::string rest = url.substr(scheme.size());
  size_t slash = rest.find('/');
  std::string authority = rest.substr(0, slash);
  std::string path = slash == std::string::npos ? "/" : rest.substr(slash);
  if (authority.empty()) return makeError("has no host");
  if (authority.find('@') != std::string::npos) return makeError("must not carry a user or password");
  size_t colon = authority.rfind(':');
  if (colon != std::string::npos && authority.find(']') == std::string::npos) {
    std::string port = authority.substr(colon + 1);
    bool digits = !port.empty() && port.size() <= 5 && std::all_of(port.begin(), port.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c));
    });
    if (!digits || std::stoi(port) < 1 || std::stoi(port) > 65535)
      return makeError("has a bad port '" + port + "'");
    if (colon == 0) return makeError("has no host");
  }
  for (char c : url) {
    if (static_cast<unsigned char>(c) <= 0x20 || c == 0x7f)
      return makeError("must not contain spaces or control characters");
  }
  return HttpTarget{scheme + authority, path};
}

Result<PostReply> postJson(const HttpTarget& target, const std::string& body,
                           const std::vector<std::pair<std::string, std::string>>& headers,
                           int timeoutSeconds) {
  httplib::Client client(target.origin);
  client.set_connection_timeout(timeoutSeconds, 0);
  client.set_read_timeout(timeoutSeconds, 0);
  client.set_write_timeout(timeoutSeconds, 0);
  httplib::Headers h;
  for (const auto& [k, v] : headers) h.emplace(k, v);
  auto res = client.Post(target.path, h, body, "application/json");
  if (!res) return makeError("no reply from " + target.origin + ": " + httplib::to_string(res.error()));
  PostReply reply;
  reply.status = res->status;
  reply.body = res->body.substr(0, 512);
  return reply;
}

}  // namespace tally::api
