// Shared by tallyd and tally: versions and the names used on the wire.
#pragma once

namespace tally::protocol {

// The build's version is tally::version() (common/version.hpp, from CMake).
inline constexpr int kApiVersion = 1;

// The port `tally` connects to by default (http://127.0.0.1:kDefaultPort).
inline constexpr int kDefaultPort = 8377;

// Capture job states, the "status" of GET /api/captures/{id}. done, failed and
// cancelled are final.
inline constexpr const char* kJobQueued = "queued";
inline constexpr const char* kJobRunning = "running";
inline constexpr const char* kJobDone = "done";
inline constexpr const char* kJobFailed = "failed";
inline constexpr const char* kJobCancelled = "cancelled";

}  // namespace tally::protocol
