#include "api/request_checks.hpp"

#include "api/auth.hpp"

namespace tally::api {
namespace {

char lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

std::string toLower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = lower(c);
  return out;
}

}  // namespace

std::optional<std::string> checkTarget(std::string_view rawTarget, std::string_view decodedPath) {
  std::string_view rawPath = rawTarget.substr(0, rawTarget.find('?'));
  if (rawPath.empty() || rawPath.front() != '/') return "the target must be a path starting with '/'";
  if (rawPath.find("//") != std::string_view::npos) return "empty path segment";
  for (unsigned char c : rawTarget) {
    if (c < 0x20 || c >= 0x7f) return "control or non-ASCII byte in the target (percent-encode it)";
  }
  if (rawPath.find('\\') != std::string_view::npos) return "backslash in the path";
  const std::string low = toLower(rawPath);
  for (const char* enc : {"%2e", "%2f", "%5c", "%25", "%00"}) {
    if (low.find(enc) != std::string::npos) return std::string("percent-encoded '") + enc + "' in the path";
  }
  for (unsigned char c : decodedPath) {
    if (c < 0x20 || c == 0x7f || c == '\\') return "control byte or backslash in the decoded path";
  }
  // Segments "." and "..", also as the last segment.
  size_t start = 0;
  while (start <= decodedPath.size()) {
    size_t end = decodedPath.find('/', start);
    if (end == std::string_view::npos) end = decodedPath.size();
    std::string_view seg = decodedPath.substr(start, end - start);
    if (seg == "." || seg == "..") return "'.' or '..' segment in the path";
    start = end + 1;
  }
  return std::nullopt;
}

std::optional<uint64_t> parseContentLength(std::string_view value) {
  if (value.empty() || value.size() > 18) return std::nullopt;
  uint64_t n = 0;
  for (char c : value) {
    if (c < '0' || c > '9') return std::nullopt;
    n = n * 10 + static_cast<uint64_t>(c - '0');
  }
  return n;
}

bool isJsonMediaType(std::string_view contentType) {
  std::string_view type = contentType.substr(0, contentType.find(';'));
  while (!type.empty() && (type.back() == ' ' || type.back() == '\t')) type.remove_suffix(1);
  while (!type.empty() && (type.front() == ' ' || type.front() == '\t')) type.remove_prefix(1);
  return toLower(type) == "application/json";
}

bool isLoopbackHost(std::string_view host) {
  std::string_view name = host;
  if (!name.empty() && name.front() == '[') {
    size_t close = name.find(']');
    if (close == std::string_view::npos) return false;
    std::string_view rest = name.substr(close + 1);
    if (!rest.empty() && rest.front() != ':') return false;
    name = name.substr(1, close - 1);
  } else {
    size_t colon = name.find(':');
    if (colon != std::string_view::npos) name = name.substr(0, colon);
  }
  const std::string low = toLower(name);
  if (low == "localhost") return true;
  // Only numeric forms; a DNS name that resolves to 127.0.0.1 is what rebinding uses.
  return isLoopbackAddress(low);
}

bool isValidIdempotencyKey(std::string_view key) {
  if (key.empty() || key.size() > 200) return false;
  for (unsigned char c : key)
    if (c < 0x21 || c > 0x7e) return false;
  return true;
}

Result<nlohmann::json> parseJsonBody(std::string_view text, int maxDepth) {
  bool tooDeep = false;
  auto callback = [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
    if (depth > maxDepth) tooDeep = true;
    return !tooDeep;
  };
  nlohmann::json value =
      nlohmann::json::parse(text.begin(), text.end(), callback, /*allow_exceptions=*/false);
  if (tooDeep) return makeError("body nests deeper than " + std::to_string(maxDepth) + " levels");
  if (value.is_discarded()) return makeError("body is not valid JSON");
  if (!value.is_object()) return makeError("body must be a JSON object");
  return value;
}

}  // namespace tally::api
