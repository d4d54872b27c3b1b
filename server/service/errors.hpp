// The one error path of the service's handlers: they throw, and wrap()
// answers. A RequestError is what the request got wrong (its status, code,
// message and field, as the client sees them); check() turns a store's failed
// Result into StoreUnavailable (a fault of the store: 503 with Retry-After)
// or StoreError (logged, 500 without detail). Internal to service/.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "api/messages.hpp"
#include "common/result.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

// A bad request, thrown by the validators and answered as 400 (or `status`).
struct RequestError : std::runtime_error {
  RequestError(int s, std::string c, std::string m, std::string f = {})
      : std::runtime_error(m), status(s), code(std::move(c)), field(std::move(f)) {}
  int status;
  std::string code, field;
  std::vector<std::pair<std::string, std::string>> headers;  // e.g. Retry-After of a 429
};

[[noreturn]] inline void invalid(const std::string& field, const std::string& message) {
  throw RequestError(400, api::code::kInvalidField, field + ": " + message, field);
}

// 404 for what the path or query names and the store does not hold.
[[noreturn]] inline void missing(const std::string& message) {
  throw RequestError(404, api::code::kNotFound, message);
}

// A store failure: logged, answered 500 without detail.
struct StoreError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A fault of the store itself (store/fault.hpp): answered 503 with
// Retry-After and the fault's reason; the detail is logged.
struct StoreUnavailable : std::runtime_error {
  StoreUnavailable(store::Fault f, const std::string& detail) : std::runtime_error(detail), fault(f) {}
  store::Fault fault;
};

// Seconds a client should wait before it tries again, by fault.
int retryAfterSeconds(store::Fault fault);

template <class T>
T check(Result<T> r) {
  if (!r) {
    if (store::Fault f = store::lastFault(); f != store::Fault::kNone) throw StoreUnavailable(f, r.error());
    throw StoreError(r.error());
  }
  return std::move(r).value();
}

// Before a write: refused while the store is damaged (writing into a
// damaged file may spread the damage).
void requireWritable(const ServiceContext& ctx);

// Runs a handler, answering RequestError with its status and anything else
// with a logged 500.
api::Response wrap(ServiceContext& ctx, const std::function<api::Response()>& handler);

using RouteHandler = api::Response (*)(ServiceContext&, const api::Request&);

// The router's handler for `fn`, wrapped. `ctx` must outlive the router.
inline api::Handler routed(ServiceContext& ctx, RouteHandler fn) {
  return [&ctx, fn](const api::Request& req) { return wrap(ctx, [&] { return fn(ctx, req); }); };
}

}  // namespace tally::service::detail
