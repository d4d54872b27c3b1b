// What the route files of the service share: request errors, query parameter
// checks, the per-thread reader and the JSON of a run row. Internal to
// service/ (service.cpp defines these; alerts.cpp uses them too).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "api/router.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

// A bad request, thrown by the validators and answered as 400 (or `status`).
struct RequestError : std::runtime_error {
  RequestError(int s, std::string c, std::string m, std::string f = {})
      : std::runtime_error(m), status(s), code(std::move(c)), field(std::move(f)) {}
  int status;
  std::string code, field;
};

[[noreturn]] inline void invalid(const std::string& field, const std::string& message) {
  throw RequestError(400, api::code::kInvalidField, field + ": " + message, field);
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

template <class T>
nlohmann::json opt(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Query parameters; each throws a RequestError naming the parameter.
std::optional<int64_t> queryInt(const api::Request& req, const std::string& key, int64_t low, int64_t high);
std::optional<std::string> queryString(const api::Request& req, const std::string& key,
                                       size_t maxLength = 256);
int64_t pathId(const api::Request& req);
store::Page queryPage(const api::Request& req);
void allowOnly(const api::Request& req, const std::set<std::string>& keys);
store::RunFilter queryFilter(const api::Request& req);

nlohmann::json runRowJson(const store::RunRow& r);

// This thread's read-only store.
store::Store& reader(const ServiceContext& ctx);

// Runs a handler, answering RequestError with its status and anything else
// with a logged 500.
api::Response wrap(ServiceContext& ctx, const std::function<api::Response()>& handler);

}  // namespace tally::service::detail
