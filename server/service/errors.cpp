// The one error path of the service: handlers throw (RequestError for what
// the request got wrong, StoreError and StoreUnavailable through check()),
// and wrap() turns each into its answer.
#include "service/errors.hpp"

#include <cstdio>

#include "service/store_health.hpp"

namespace tally::service::detail {
using api::Response;

int retryAfterSeconds(store::Fault fault) {
  switch (fault) {
    case store::Fault::kBusy: return 1;
    case store::Fault::kFull:
    case store::Fault::kIoError:
    case store::Fault::kReadOnly:
    case store::Fault::kUnreachable: return 5;
    default: return 60;  // damage: not before it is repaired
  }
}

void requireWritable(const ServiceContext& ctx) {
  if (!ctx.health) return;
  StoreHealth::State state = ctx.health->state();
  if (state.fault == store::Fault::kDamaged) throw StoreUnavailable(state.fault, state.reason);
}

Response wrap(ServiceContext& ctx, const std::function<Response()>& handler) {
  auto log = [&](const std::string& line) {
    if (ctx.log) {
      ctx.log(line);
    } else {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
  };
  try {
    return handler();
  } catch (const RequestError& e) {
    Response r = api::errorResponse(e.status, e.code, e.what(), e.field);
    r.headers = e.headers;
    return r;
  } catch (const StoreUnavailable& e) {
    // The store's own fault, named: 503, never a bare 500.
    std::string reason = store::describe(e.fault);
    if (ctx.health) {
      ctx.health->noteFault(e.fault, e.what());
      StoreHealth::State state = ctx.health->state();
      if (state.fault == e.fault && !state.reason.empty()) reason = state.reason;
    } else {
      log(std::string("service: store ") + store::toString(e.fault) + ": " + e.what());
    }
    Response r = api::errorResponse(503, api::code::kStoreUnavailable, reason, "store");
    r.headers.emplace_back("Retry-After", std::to_string(retryAfterSeconds(e.fault)));
    return r;
  } catch (const std::exception& e) {
    log(std::string("service: ") + e.what());
    return api::errorResponse(500, api::code::kInternal, "internal error");
  }
}

}  // namespace tally::service::detail
