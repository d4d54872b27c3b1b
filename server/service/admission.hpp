// What a capture must be to be queued: the spec checked by its parser and
// against the server's limits (ServiceOptions), glTF paths resolved inside
// the scene folders, applications only where allowed; and the answer when
// a queue limit refuses it. Internal to service/.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

#include "api/messages.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

// The spec as stored (canonical glTF paths), or a RequestError naming the field.
nlohmann::json validateSpec(const ServiceContext& ctx, const nlohmann::json& body, api::Principal principal);

// Whether `file` lies inside `folder` (both canonical).
bool under(const std::filesystem::path& file, const std::filesystem::path& folder);

// The queue limits that apply to this request's client.
store::QueueLimits queueLimits(const ServiceContext& ctx, const api::Request& req);

// Throws the 429 (with Retry-After) of a job a queue limit refused.
[[noreturn]] void refuseQueued(const ServiceContext& ctx, const store::CreatedJob& created);

}  // namespace tally::service::detail
