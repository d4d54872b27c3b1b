// What the route files of the service share: the error path (errors.hpp),
// parameter checks (params.hpp), the JSON of stored rows (json_rows.hpp) and
// the calling thread's read-only store. Internal to service/.
#pragma once

#include "service/errors.hpp"
#include "service/json_rows.hpp"
#include "service/params.hpp"
#include "service/read_stores.hpp"
#include "service/service.hpp"

namespace tally::service::detail {

// This thread's read-only store (ServiceContext::readers).
inline store::Store& reader(const ServiceContext& ctx) { return ctx.readers->forThisThread(); }

}  // namespace tally::service::detail
