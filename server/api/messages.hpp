// The seam between HTTP and the service layer: plain requests and responses
// carrying JSON. Handlers see these types only, never the HTTP library's.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::api {

// Who is asking. A route needs kRead (GET, HEAD) or kCapture (POST, DELETE);
// a capture token may also read. kApplication (the token file's optional
// application= line) may do what kCapture may, and also post specs that run
// a program on the daemon's host (the service checks that per spec). Without
// tokens (loopback only) every request is kCapture.
enum class Principal { kRead, kCapture, kApplication };

inline bool allows(Principal have, Principal need) {
  return static_cast<int>(have) >= static_cast<int>(need);
}
const char* principalName(Principal p);

struct Request {
  std::string method;                         // "GET", "POST", "DELETE", ... (HEAD arrives as "GET")
  std::string path;                           // percent-decoded, e.g. "/api/runs/12"
  std::map<std::string, std::string> params;  // from the route pattern: {"id": "12"}
  std::map<std::string, std::string> query;   // percent-decoded; a repeated key was refused before here
  nlohmann::json body;                        // null without a body, else a JSON object (checked before here)
  std::string idempotencyKey;                 // the Idempotency-Key header; empty when absent
  Principal principal = Principal::kRead;
  std::string remoteAddr;  // the socket's peer address, never a header
  // Who is asking, for per-client limits: "token:capture" (the token the
  // request carried, by its role) when the server has tokens, else
  // "peer:<remoteAddr>". Empty outside the HTTP server (tests).
  std::string client;

  // The query value for key, or nullptr.
  const std::string* queryValue(std::string_view key) const;
  // The route parameter (always present when the pattern names it).
  const std::string& param(const std::string& name) const;
};

struct Response {
  int status = 200;
  nlohmann::json json;      // the body when contentType is empty
  std::string bytes;        // the body when contentType is set (PNG, CSV, ...)
  std::string contentType;  // empty: JSON
  std::vector<std::pair<std::string, std::string>> headers;  // extra, e.g. Location, Retry-After

  bool isRaw() const { return !contentType.empty(); }

  static Response ok(nlohmann::json body, int status = 200);
  static Response raw(std::string bytes, std::string contentType, int status = 200);
};

using Handler = std::function<Response(const Request&)>;

// Error codes used by the transport layer; services may add their own
// (lower_snake_case). The body is {"error":{"code","message","field"?}}.
namespace code {
inline constexpr const char* kBadRequest = "bad_request";      // 400, generic
inline constexpr const char* kInvalidField = "invalid_field";  // 400, a field of the body or query
inline constexpr const char* kBadJson = "bad_json";            // 400, body is not a JSON object
inline constexpr const char* kBadQuery = "bad_query";          // 400, repeated or malformed query parameter
inline constexpr const char* kBadPath = "bad_path";      // 400, traversal, encoded separators, control bytes
inline constexpr const char* kBadHeader = "bad_header";  // 400, malformed/duplicate/reserved header
inline constexpr const char* kUnexpectedBody = "unexpected_body";  // 400, a body on GET/HEAD/DELETE/OPTIONS
inline constexpr const char* kUnauthorized = "unauthorized";       // 401
inline constexpr const char* kForbidden = "forbidden";             // 403, read token on a capture route
inline constexpr const char* kForbiddenHost =
    "forbidden_host";                                  // 403, Host not loopback while tokens are off
inline constexpr const char* kNotFound = "not_found";  // 404
inline constexpr const char* kMethodNotAllowed = "method_not_allowed";  // 405
inline constexpr const char* kConflict = "conflict";                    // 409
inline constexpr const char* kLengthRequired = "length_required";       // 411, chunked or no Content-Length
inline constexpr const char* kPayloadTooLarge = "payload_too_large";    // 413
inline constexpr const char* kUriTooLong = "uri_too_long";              // 414
inline constexpr const char* kUnsupportedMediaType = "unsupported_media_type";  // 415, Content-Type
inline constexpr const char* kUnsupportedEncoding = "unsupported_encoding";     // 415, Content-Encoding
inline constexpr const char* kRangeNotSatisfiable = "range_not_satisfiable";    // 416
inline constexpr const char* kTooManyRequests = "too_many_requests";            // 429, with Retry-After
inline constexpr const char* kInternal = "internal";                            // 500, no detail on the wire
inline constexpr const char* kUnavailable = "unavailable";                      // 503
inline constexpr const char* kStoreUnavailable = "store_unavailable";  // 503, the store's fault, named
}  // namespace code

// {"error":{"code":..,"message":..,"field":..}}; "field" is left out when empty.
nlohmann::json errorBody(std::string_view code, std::string_view message, std::string_view field = {});
Response errorResponse(int status, std::string_view code, std::string_view message,
                       std::string_view field = {});

// Shorthands for the common cases.
Response badRequest(std::string_view message, std::string_view field = {});  // 400 invalid_field
Response notFound(std::string_view message);                                 // 404 not_found
Response conflict(std::string_view message, std::string_view field = {});    // 409 conflict

// The code used when only a status is known (errors raised by the HTTP library itself).
const char* defaultErrorCode(int status);
const char* defaultErrorMessage(int status);

}  // namespace tally::api
