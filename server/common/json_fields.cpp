#include "common/json_fields.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace tally::json_fields {

using nlohmann::json;

std::string show(const json& j) {
  std::string s = j.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

Error fieldError(const std::string& field, const std::string& message) { return Error(field, message); }

std::string member(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string index(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

Error under(const std::string& path, const Error& inner) {
  if (inner.field().empty()) return Error(path, inner.message());
  if (inner.field().starts_with("[")) return Error(path + inner.field(), inner.message());
  return Error(member(path, inner.field()), inner.message());
}

std::optional<Error> unknownKey(const json& object, const std::string& path,
                                const std::vector<std::string>& allowed, const std::string& heading) {
  for (const auto& [key, value] : object.items()) {
    if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
    std::string expected;
    for (const auto& name : allowed) expected += (expected.empty() ? "" : ", ") + name;
    return fieldError(member(path, key), heading + " (expected " + expected + ")");
  }
  return std::nullopt;
}

std::optional<Error> tooMany(const json& list, const std::string& field, size_t most) {
  if (!list.is_array() || list.size() <= most) return std::nullopt;
  return fieldError(field,
                    "at most " + std::to_string(most) + " entries, got " + std::to_string(list.size()));
}

Error duplicate(const std::string& field, const std::string& first) {
  return fieldError(field, "a duplicate of " + first + " (each entry must differ)");
}

namespace {

// The value as int64, or nothing for a non-integer or an unsigned beyond int64.
std::optional<int64_t> asInt64(const json& j) {
  if (!j.is_number_integer()) return std::nullopt;
  if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(INT64_MAX)) return std::nullopt;
  return j.get<int64_t>();
}

}  // namespace

Result<int64_t> integer(const json& j, const std::string& field, int64_t low, int64_t high, RangeWords words) {
  auto v = asInt64(j);
  if (!v || *v < low || *v > high) {
    const bool between = words == RangeWords::kBetween;
    return fieldError(field, std::string("must be an integer ") + (between ? "between " : "from ") +
                                 std::to_string(low) + (between ? " and " : " to ") + std::to_string(high) +
                                 ", got " + show(j));
  }
  return *v;
}

Result<uint32_t> count(const json& j, const std::string& field, uint32_t low, uint32_t high, RangeWords words) {
  auto v = integer(j, field, low, high, words);
  if (!v) return v.failure();
  return static_cast<uint32_t>(*v);
}

Result<int64_t> anyInteger(const json& j, const std::string& field) {
  if (!j.is_number_integer()) return fieldError(field, "must be an integer, got " + j.dump());
  auto v = asInt64(j);
  if (!v) return fieldError(field, "too large");
  return *v;
}

Result<double> finite(const json& j, const std::string& field) {
  if (!j.is_number()) return fieldError(field, "must be a number, got " + j.dump());
  double x = j.get<double>();
  if (!std::isfinite(x)) return fieldError(field, "must be finite");
  return x;
}

Result<double> number(const json& j, const std::string& field, double low, double high, bool openLow) {
  bool ok = j.is_number() && std::isfinite(j.get<double>());
  if (ok) {
    double v = j.get<double>();
    ok = (openLow ? v > low : v >= low) && v <= high;
  }
  if (!ok) {
    return fieldError(field, std::string("must be a number ") + (openLow ? "above " : "from ") + num(low) +
                                 (openLow ? " up to " : " to ") + num(high) + ", got " + show(j));
  }
  return j.get<double>();
}

Result<bool> boolean(const json& j, const std::string& field) {
  if (!j.is_boolean()) return fieldError(field, "must be true or false, got " + show(j));
  return j.get<bool>();
}

Result<std::string> text(const json& j, const std::string& field) {
  if (!j.is_string()) return fieldError(field, "must be a string, got " + show(j));
  return j.get<std::string>();
}

Result<std::string> boundedText(const json& j, const std::string& field, size_t maxLength, bool empty) {
  auto got = text(j, field);
  if (!got) return got;
  const std::string& s = *got;
  if ((!empty && s.empty()) || s.size() > maxLength || s.find('\0') != std::string::npos) {
    return fieldError(field, "must be " + std::string(empty ? "" : "a non-empty string of ") + "at most " +
                                 std::to_string(maxLength) + " characters without NUL");
  }
  return got;
}

Result<std::string> oneOf(const json& j, const std::string& field, const std::vector<std::string>& values,
                          const std::string& why) {
  if (j.is_string() && std::find(values.begin(), values.end(), j.get<std::string>()) != values.end()) {
    return j.get<std::string>();
  }
  std::string list;
  for (size_t i = 0; i < values.size(); ++i) {
    list += (i == 0 ? "" : i + 1 == values.size() ? " or " : ", ") + ("\"" + values[i] + "\"");
  }
  return fieldError(field, "must be " + list + (why.empty() ? "" : " " + why) + ", got " + show(j));
}

Result<Resolution> resolution(const json& r, const std::string& field, Resolution least, RangeWords words) {
  if (!r.is_array() || r.size() != 2) return fieldError(field, "must be [width, height], got " + show(r));
  const uint32_t lowest[2] = {least.width, least.height};
  uint32_t dims[2] = {0, 0};
  for (size_t i = 0; i < 2; ++i) {
    auto v = integer(r[i], index(field, i), lowest[i], kMaxDimension, words);
    if (!v && lowest[i] > 1) {
      // A tiled renderer's least size: say why it is not 1.
      return fieldError(index(field, i), "must be an integer from " + std::to_string(lowest[i]) +
                                             " (one tile) to " + std::to_string(kMaxDimension) + ", got " +
                                             show(r[i]));
    }
    if (!v) return v.failure();
    dims[i] = static_cast<uint32_t>(*v);
  }
  if (uint64_t{dims[0]} * dims[1] > kMaxPixels) {
    return fieldError(field, std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " is more than the " +
                                 std::to_string(kMaxPixels) + "-pixel limit (8K)");
  }
  return Resolution{dims[0], dims[1]};
}

Error missing(const std::string& field, const std::string& hint) {
  return fieldError(field, hint.empty() ? "required" : "required" + hint);
}

const json* find(const json& object, std::string_view key) {
  auto it = object.find(key);
  return it == object.end() || it->is_null() ? nullptr : &*it;
}

void Members::fail(const Error& error) const {
  fail_(error);
  throw std::logic_error("a reader's fail returned: " + error.text());
}

template <class T>
T Members::get(Result<T> r) const {
  if (!r) fail(r.failure());
  return std::move(r).value();
}

const json& Members::present(const json& object, const char* key, const std::string& path) const {
  const json* v = find(object, key);
  if (!v) fail(fieldError(member(path, key), "missing"));
  return *v;
}

// The getters take the value as it is where it is what they want, and build
// the field's path (a string) only for the error: a result file reads
// thousands of members, and building each path was a large part of reading.
double Members::number(const json& object, const char* key, const std::string& path) const {
  const json& v = present(object, key, path);
  if (v.is_number()) {
    double x = v.get<double>();
    if (std::isfinite(x)) return x;
  }
  return get(finite(v, member(path, key)));
}

int64_t Members::integer(const json& object, const char* key, const std::string& path) const {
  const json& v = present(object, key, path);
  if (v.is_number_integer()) {
    if (auto x = asInt64(v)) return *x;
  }
  return get(anyInteger(v, member(path, key)));
}

std::string Members::text(const json& object, const char* key, const std::string& path) const {
  const json& v = present(object, key, path);
  if (v.is_string()) return v.get<std::string>();
  return get(json_fields::text(v, member(path, key)));
}

const json& Members::array(const json& object, const char* key, const std::string& path) const {
  static const json kEmpty = json::array();
  const json* v = find(object, key);
  if (!v) return kEmpty;
  if (!v->is_array()) fail(fieldError(member(path, key), "must be an array"));
  return *v;
}

const json& Members::object(const json& parent, const char* key, const std::string& path) const {
  static const json kEmpty = json::object();
  const json* v = find(parent, key);
  if (!v) return kEmpty;
  if (!v->is_object()) fail(fieldError(member(path, key), "must be an object"));
  return *v;
}

}  // namespace tally::json_fields
