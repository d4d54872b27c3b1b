#include "api/messages.hpp"

#include <stdexcept>

namespace tally::api {

const char* principalName(Principal p) {
  switch (p) {
    case Principal::kRead: return "read";
    case Principal::kCapture: return "capture";
    case Principal::kApplication: return "application";
  }
  return "read";
}

const std::string* Request::queryValue(std::string_view key) const {
  auto it = query.find(std::string(key));
  return it == query.end() ? nullptr : &it->second;
}

const std::string& Request::param(const std::string& name) const {
  auto it = params.find(name);
  if (it == params.end()) throw std::logic_error("route has no parameter '" + name + "'");
  return it->second;
}

Response Response::ok(nlohmann::json body, int status) {
  Response r;
  r.status = status;
  r.json = std::move(body);
  return r;
}

Response Response::raw(std::string bytes, std::string contentType, int status) {
  Response r;
  r.status = status;
  r.bytes = std::move(bytes);
  r.contentType = std::move(contentType);
  return r;
}

nlohmann::json errorBody(std::string_view code, std::string_view message, std::string_view field) {
  nlohmann::json error = {{"code", code}, {"message", message}};
  if (!field.empty()) error["field"] = field;
  return {{"error", std::move(error)}};
}

Response errorResponse(int status, std::string_view code, std::string_view message, std::string_view field) {
  return Response::ok(errorBody(code, message, field), status);
}

Response badRequest(std::string_view message, std::string_view field) {
  return errorResponse(400, code::kInvalidField, message, field);
}
Response notFound(std::string_view message) { return errorResponse(404, code::kNotFound, message); }
Response conflict(std::string_view message, std::string_view field) {
  return errorResponse(409, code::kConflict, message, field);
}

const char* defaultErrorCode(int status) {
  switch (status) {
    case 400: return code::kBadRequest;
    case 401: return code::kUnauthorized;
    case 403: return code::kForbidden;
    case 404: return code::kNotFound;
    case 405: return code::kMethodNotAllowed;
    case 409: return code::kConflict;
    case 411: return code::kLengthRequired;
    case 413: return code::kPayloadTooLarge;
    case 414: return code::kUriTooLong;
    case 415: return code::kUnsupportedMediaType;
    case 416: return code::kRangeNotSatisfiable;
    case 503: return code::kUnavailable;
    default: return status >= 500 ? code::kInternal : code::kBadRequest;
  }
}

const char* defaultErrorMessage(int status) {
  switch (status) {
    case 400: return "malformed request";
    case 401: return "authentication required";
    case 403: return "forbidden";
    case 404: return "no such resource";
    case 405: return "method not allowed";
    case 409: return "conflict";
    case 411: return "Content-Length required";
    case 413: return "request body too large";
    case 414: return "request URI too long";
    case 415: return "unsupported media type";
    case 416: return "range not satisfiable";
    case 503: return "service unavailable";
    default: return status >= 500 ? "internal error" : "bad request";
  }
}

}  // namespace tally::api
