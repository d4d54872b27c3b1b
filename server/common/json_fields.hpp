// Checks of JSON input fields, shared by every parser of the server. Each
// error is an Error whose field is the path of the value at fault
// ("resolutions[2]", "passes.shading.width") and whose text reads
// "resolutions[2]: must be [width, height], got 3".
#pragma once

#include <array>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/resolution.hpp"
#include "common/result.hpp"

namespace tally::json_fields {

// The value as compact JSON, cut to 60 characters, for error messages.
std::string show(const nlohmann::json& j);
// A number as %g prints it.
std::string num(double v);

Error fieldError(const std::string& field, const std::string& message);

// Paths: member("passes", "width") is "passes.width" (a bare "width" under
// an empty path); index("resolutions", 2) is "resolutions[2]".
std::string member(const std::string& path, const std::string& key);
std::string index(const std::string& path, size_t i);

// A nested parser's error moved under `path`: "scenes[0]" and "layers: ..."
// give "scenes[0].layers: ...", "cameras" and "[1].eye: ..." give "cameras[1].eye: ...".
Error under(const std::string& path, const Error& inner);

// "key: unknown field (expected a, b, c)" for the first key of `object` not
// in `allowed` (the list in the order given), with the key under `path`;
// `heading` replaces "unknown field" where a parser names its object
// ("unknown field for the floor layout").
std::optional<Error> unknownKey(const nlohmann::json& object, const std::string& path,
                                const std::vector<std::string>& allowed,
                                const std::string& heading = "unknown field");
// "field: at most 32 entries, got 40", before any entry is looked at.
std::optional<Error> tooMany(const nlohmann::json& list, const std::string& field, size_t most);
// "scenes[3]: a duplicate of scenes[0] (each entry must differ)".
Error duplicate(const std::string& field, const std::string& first);

// An integer from `low` to `high`; the unsigned values JSON allows beyond
// int64 are out of range, not wrapped.
// The range reads "between 1 and 10" (capture and scene specs) or "from 1
// to 10" (sweep specs), as each parser's messages always did.
enum class RangeWords { kBetween, kFromTo };
Result<int64_t> integer(const nlohmann::json& j, const std::string& field, int64_t low, int64_t high,
                        RangeWords words = RangeWords::kBetween);
Result<uint32_t> count(const nlohmann::json& j, const std::string& field, uint32_t low, uint32_t high,
                       RangeWords words = RangeWords::kBetween);
// Any integer that fits int64 ("must be an integer", "too large").
Result<int64_t> anyInteger(const nlohmann::json& j, const std::string& field);
// A finite number ("must be a number", "must be finite").
Result<double> finite(const nlohmann::json& j, const std::string& field);
// A number from `low` (above it when `openLow`) to `high`.
Result<double> number(const nlohmann::json& j, const std::string& field, double low, double high,
                      bool openLow = false);
Result<bool> boolean(const nlohmann::json& j, const std::string& field);
Result<std::string> text(const nlohmann::json& j, const std::string& field);
// A string without NUL of 1..maxLength characters (0.. when `empty` is allowed).
Result<std::string> boundedText(const nlohmann::json& j, const std::string& field, size_t maxLength,
                                bool empty = false);
// One of `values` (a string): "must be \"none\" or \"xvfb\", got 3"; `why`
// follows the list when given ("(the layer's modes)").
Result<std::string> oneOf(const nlohmann::json& j, const std::string& field,
                          const std::vector<std::string>& values, const std::string& why = "");

// [width, height]: integers from `least` (per axis; above 1 is one tile of
// a tiled renderer) to kMaxDimension, at most kMaxPixels in all.
Result<Resolution> resolution(const nlohmann::json& r, const std::string& field, Resolution least = {1, 1},
                              RangeWords words = RangeWords::kBetween);

// A field the caller must have: "field: required" with `hint` after it.
Error missing(const std::string& field, const std::string& hint = "");

// The member `key` of `object`, or nullptr where it is absent or null.
const nlohmann::json* find(const nlohmann::json& object, std::string_view key);

// Whether `keys` are in the order an object keeps its members (ascending,
// as std::string compares): what findAll needs, checked where they are declared.
template <size_t N>
constexpr bool inMemberOrder(const std::array<std::string_view, N>& keys) {
  for (size_t k = 1; k < N; ++k) {
    if (!(keys[k - 1] < keys[k])) return false;
  }
  return true;
}

// The members `keys` of `object`, each as find() reads it (nullptr where
// absent or null; all nullptr when `object` is not an object), found in one
// walk of the object's members beside `keys` instead of a search per key:
// for the many small objects of a result. `keys` must be inMemberOrder.
template <size_t N>
std::array<const nlohmann::json*, N> findAll(const nlohmann::json& object,
                                             const std::array<std::string_view, N>& keys) {
  std::array<const nlohmann::json*, N> out{};
  if (!object.is_object()) return out;
  const auto& members = object.get_ref<const nlohmann::json::object_t&>();
  auto it = members.begin();
  for (size_t k = 0; k < N && it != members.end();) {
    int order = std::string_view(it->first).compare(keys[k]);
    if (order < 0) {
      ++it;
    } else if (order > 0) {
      ++k;
    } else {
      if (!it->second.is_null()) out[k] = &it->second;
      ++it;
      ++k;
    }
  }
  return out;
}

// Members of a document that must be whole (a result file, the layer's
// output), read where any fault ends the reading: each getter calls `fail`,
// which throws the reader's exception with "path.key: message". Null reads as
// absent; absent lists and objects read as empty.
class Members {
 public:
  using Fail = void (*)(const Error& error);  // throws
  explicit constexpr Members(Fail thrower) : fail_(thrower) {}

  double number(const nlohmann::json& object, const char* key, const std::string& path) const;
  std::optional<double> optNumber(const nlohmann::json& object, const char* key,
                                  const std::string& path) const {
    if (!find(object, key)) return std::nullopt;
    return number(object, key, path);
  }
  int64_t integer(const nlohmann::json& object, const char* key, const std::string& path) const;
  std::optional<int64_t> optInteger(const nlohmann::json& object, const char* key,
                                    const std::string& path) const {
    if (!find(object, key)) return std::nullopt;
    return integer(object, key, path);
  }
  std::string text(const nlohmann::json& object, const char* key, const std::string& path) const;
  std::optional<std::string> optText(const nlohmann::json& object, const char* key,
                                     const std::string& path) const {
    if (!find(object, key)) return std::nullopt;
    return text(object, key, path);
  }
  const nlohmann::json& array(const nlohmann::json& object, const char* key, const std::string& path) const;
  const nlohmann::json& object(const nlohmann::json& parent, const char* key, const std::string& path) const;

 private:
  [[noreturn]] void fail(const Error& error) const;
  template <class T>
  T get(Result<T> r) const;
  const nlohmann::json& present(const nlohmann::json& object, const char* key, const std::string& path) const;

  Fail fail_;
};

}  // namespace tally::json_fields
