#include "api/router.hpp"

#include <algorithm>
#include <stdexcept>

namespace tally::api {
namespace {

std::vector<std::string> splitPath(std::string_view path) {
  std::vector<std::string> out;
  if (path.empty() || path.front() != '/') return out;
  size_t start = 1;
  while (start <= path.size()) {
    size_t end = path.find('/', start);
    if (end == std::string_view::npos) end = path.size();
    out.emplace_back(path.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

bool isParam(const std::string& segment) {
  return segment.size() > 2 && segment.front() == '{' && segment.back() == '}';
}

// Number of literal segments when path matches, or -1.
int matchSegments(const Route& route, const std::vector<std::string>& parts,
                  std::map<std::string, std::string>* params) {
  if (route.segments.size() != parts.size()) return -1;
  int literals = 0;
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& seg = route.segments[i];
    if (isParam(seg)) {
      if (parts[i].empty()) return -1;
      if (params) (*params)[seg.substr(1, seg.size() - 2)] = parts[i];
    } else if (seg == parts[i]) {
      ++literals;
    } else {
      return -1;
    }
  }
  return literals;
}

}  // namespace

Router& Router::add(std::string method, std::string pattern, Handler handler, std::optional<Principal> need) {
  if (method.empty() || !handler) throw std::invalid_argument("route: empty method or handler");
  if (method == "HEAD") throw std::invalid_argument("route: HEAD is served by the GET route");
  auto segments = splitPath(pattern);
  if (segments.empty()) throw std::invalid_argument("route: pattern must start with '/': " + pattern);
  for (const auto& s : segments) {
    if (s.empty()) throw std::invalid_argument("route: empty segment in " + pattern);
    if ((s.front() == '{') != (s.back() == '}') || (s.front() == '{' && s.size() <= 2))
      throw std::invalid_argument("route: malformed parameter in " + pattern);
  }
  for (const auto& r : routes_) {
    if (r.method == method && r.segments == segments)
      throw std::invalid_argument("route: duplicate " + method + " " + pattern);
  }
  Route route;
  route.method = std::move(method);
  route.pattern = std::move(pattern);
  route.segments = std::move(segments);
  route.need = need.value_or(route.method == "GET" ? Principal::kRead : Principal::kCapture);
  route.handler = std::move(handler);
  routes_.push_back(std::move(route));
  return *this;
}

Router::Match Router::match(std::string_view method, std::string_view path) const {
  const std::string want = method == "HEAD" ? "GET" : std::string(method);
  const auto parts = splitPath(path);
  Match best;
  int bestLiterals = -1;
  std::vector<std::string> allowed;
  for (const auto& route : routes_) {
    std::map<std::string, std::string> params;
    int literals = matchSegments(route, parts, &params);
    if (literals < 0) continue;
    if (route.method != want) {
      allowed.push_back(route.method);
      if (route.method == "GET") allowed.push_back("HEAD");
      continue;
    }
    if (literals > bestLiterals) {
      bestLiterals = literals;
      best.outcome = Outcome::kFound;
      best.route = &route;
      best.params = std::move(params);
    }
  }
  if (best.outcome == Outcome::kFound) return best;
  if (!allowed.empty()) {
    std::sort(allowed.begin(), allowed.end());
    allowed.erase(std::unique(allowed.begin(), allowed.end()), allowed.end());
    best.outcome = Outcome::kMethodNotAllowed;
    best.allowed = std::move(allowed);
  }
  return best;
}

Response Router::dispatch(Request req) const {
  auto m = match(req.method, req.path);
  if (m.outcome == Outcome::kNotFound) return errorResponse(404, code::kNotFound, "no route for " + req.path);
  if (m.outcome == Outcome::kMethodNotAllowed) {
    auto r = errorResponse(405, code::kMethodNotAllowed, req.method + " is not allowed on " + req.path);
    r.headers.emplace_back("Allow", joinAllowed(m.allowed));
    return r;
  }
  req.params = std::move(m.params);
  return m.route->handler(req);
}

std::string joinAllowed(const std::vector<std::string>& methods) {
  std::string out;
  for (const auto& m : methods) out += (out.empty() ? "" : ", ") + m;
  return out;
}

}  // namespace tally::api
