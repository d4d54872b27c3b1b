// Router: (method, pattern) -> handler. Patterns are literal segments and
// {name} parameters, e.g. "/api/runs/{id}/samples"; a literal segment wins
// over a parameter. HEAD is answered by the GET route.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "api/messages.hpp"

namespace tally::api {

struct Route {
  std::string method;
  std::string pattern;
  std::vector<std::string> segments;  // "{id}" marks a parameter
  Principal need = Principal::kRead;  // kRead for GET, kCapture otherwise, unless given
  Handler handler;
};

class Router {
 public:
  // Throws std::invalid_argument on a malformed pattern or a duplicate route
  // (programming errors, found at startup).
  Router& add(std::string method, std::string pattern, Handler handler, std::optional<Principal> need = {});
  Router& get(std::string pattern, Handler handler) {
    return add("GET", std::move(pattern), std::move(handler));
  }
  Router& post(std::string pattern, Handler handler) {
    return add("POST", std::move(pattern), std::move(handler));
  }
  Router& del(std::string pattern, Handler handler) {
    return add("DELETE", std::move(pattern), std::move(handler));
  }

  enum class Outcome { kFound, kNotFound, kMethodNotAllowed };
  struct Match {
    Outcome outcome = Outcome::kNotFound;
    const Route* route = nullptr;               // kFound
    std::map<std::string, std::string> params;  // kFound
    std::vector<std::string> allowed;           // kMethodNotAllowed: for the Allow header
  };
  Match match(std::string_view method, std::string_view path) const;

  // Matches and calls the handler; 404/405 as JSON errors otherwise. The
  // transport fills everything else in req.
  Response dispatch(Request req) const;

  const std::vector<Route>& routes() const { return routes_; }

 private:
  std::vector<Route> routes_;
};

// "GET, HEAD, POST" for an Allow header.
std::string joinAllowed(const std::vector<std::string>& methods);

}  // namespace tally::api
