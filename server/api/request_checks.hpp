// Checks on the parts of a request that the HTTP library hands over raw:
// the target, Content-Length, media types, Host, header values. Pure
// functions, so the tests can reach them without a socket.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "common/result.hpp"

namespace tally::api {

// Refuses traversal and ambiguity before any routing: the raw target must be
// origin-form ("/..."), ASCII, without "//", backslashes, control bytes,
// percent-encoded '.', '/', '\', '%' or NUL; no decoded segment may be "." or
// "..". Returns the reason, or nullopt when the target is fine.
std::optional<std::string> checkTarget(std::string_view rawTarget, std::string_view decodedPath);

// Content-Length: digits only, at most 18 of them.
std::optional<uint64_t> parseContentLength(std::string_view value);

// "application/json; charset=utf-8" -> true.
bool isJsonMediaType(std::string_view contentType);

// Host header names a loopback address (localhost, 127.x.x.x, [::1]), with or
// without a port. Guards an open (token-less) loopback server against DNS rebinding.
bool isLoopbackHost(std::string_view host);

// Idempotency-Key: 1..200 visible ASCII characters.
bool isValidIdempotencyKey(std::string_view key);

// A request body: a JSON object nested at most maxDepth deep (the depth bound
// keeps hostile input away from recursive code further on) and holding at
// most maxValues values (objects, arrays, strings, numbers, ...; keys are
// not counted). Parsing stops at the first value over either bound, so a
// hostile body costs what its first maxValues values cost, not what 1 MiB of
// small values would (about 60 ms of CPU). The largest capture spec within
// the spec's own caps holds under 4,000 values.
inline constexpr int kMaxJsonDepth = 64;
inline constexpr size_t kMaxJsonValues = 16384;
Result<nlohmann::json> parseJsonBody(std::string_view text, int maxDepth = kMaxJsonDepth,
                                     size_t maxValues = kMaxJsonValues);

}  // namespace tally::api
