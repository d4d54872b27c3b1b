// Shared by tallyd and tally: versions and the names used on the wire.
#pragma once

namespace tally::protocol {

inline constexpr const char* kVersion = "0.1.0";
inline constexpr int kApiVersion = 1;

}  // namespace tally::protocol
