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

namespace {

// nlohmann's DOM builder behind a count of values and depth: false stops the
// parser at once (a callback parser would read the rest of the input).
class BoundedDom {
 public:
  using Json = nlohmann::json;
  BoundedDom(Json& root, int maxDepth, size_t maxValues)
      : dom_(root, false), maxDepth_(maxDepth), maxValues_(maxValues) {}

  bool null() { return counted() && dom_.null(); }
  bool boolean(bool v) { return counted() && dom_.boolean(v); }
  bool number_integer(Json::number_integer_t v) { return counted() && dom_.number_integer(v); }
  bool number_unsigned(Json::number_unsigned_t v) { return counted() && dom_.number_unsigned(v); }
  bool number_float(Json::number_float_t v, const Json::string_t& s) {
    return counted() && dom_.number_float(v, s);
  }
  bool string(Json::string_t& v) { return counted() && dom_.string(v); }
  bool binary(Json::binary_t& v) { return counted() && dom_.binary(v); }
  bool key(Json::string_t& v) { return dom_.key(v); }
  bool start_object(std::size_t n) { return counted() && deeper() && dom_.start_object(n); }
  bool end_object() { return --depth_, dom_.end_object(); }
  bool start_array(std::size_t n) { return counted() && deeper() && dom_.start_array(n); }
  bool end_array() { return --depth_, dom_.end_array(); }
  bool parse_error(std::size_t position, const std::string& token, const nlohmann::detail::exception& e) {
    malformed_ = true;
    return dom_.parse_error(position, token, e);
  }

  bool tooDeep() const { return tooDeep_; }
  bool tooMany() const { return tooMany_; }
  bool malformed() const { return malformed_ || dom_.is_errored(); }

 private:
  bool counted() {
    tooMany_ = ++values_ > maxValues_;
    return !tooMany_;
  }
  bool deeper() {
    tooDeep_ = ++depth_ > maxDepth_;
    return !tooDeep_;
  }
  nlohmann::detail::json_sax_dom_parser<Json> dom_;
  int maxDepth_;
  size_t maxValues_;
  int depth_ = 0;
  size_t values_ = 0;
  bool tooDeep_ = false, tooMany_ = false, malformed_ = false;
};

}  // namespace

Result<nlohmann::json> parseJsonBody(std::string_view text, int maxDepth, size_t maxValues) {
  nlohmann::json value;
  BoundedDom sax(value, maxDepth, maxValues);
  const bool parsed = nlohmann::json::sax_parse(text.begin(), text.end(), &sax);
  if (sax.tooDeep()) return makeError("body nests deeper than " + std::to_string(maxDepth) + " levels");
  if (sax.tooMany()) {
    return makeError("body holds more than " + std::to_string(maxValues) +
                     " JSON values (a capture spec within its limits holds a few thousand)");
  }
  if (!parsed || sax.malformed()) return makeError("body is not valid JSON");
  if (!value.is_object()) return makeError("body must be a JSON object");
  return value;
}

}  // namespace tally::api
