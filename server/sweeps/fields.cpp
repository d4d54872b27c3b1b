#include "sweeps/fields.hpp"

#include <cstdio>

namespace tally::sweeps::fields {

using nlohmann::json;

std::string show(const json& j) {
  std::string s = j.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

Error fieldError(const std::string& field, const std::string& message) { return makeError(field + ": " + message); }

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

Result<Resolution> resolution(const json& r, Resolution least) {
  if (!r.is_array() || r.size() != 2) return fieldError("resolution", "must be [width, height], got " + show(r));
  const uint32_t lowest[2] = {least.width, least.height};
  uint32_t dims[2] = {0, 0};
  for (size_t i = 0; i < 2; ++i) {
    std::string f = "resolution[" + std::to_string(i) + "]";
    if (!r[i].is_number_integer() || r[i].get<int64_t>() < lowest[i] || r[i].get<int64_t>() > kMaxDimension) {
      return fieldError(f, "must be an integer from " + std::to_string(lowest[i]) +
                               (lowest[i] > 1 ? " (one tile)" : "") + " to " + std::to_string(kMaxDimension) +
                               ", got " + show(r[i]));
    }
    dims[i] = uint32_t(r[i].get<int64_t>());
  }
  if (uint64_t{dims[0]} * dims[1] > kMaxPixels) {
    return fieldError("resolution", "more than the " + std::to_string(kMaxPixels) + "-pixel limit (8K)");
  }
  return Resolution{dims[0], dims[1]};
}

}  // namespace tally::sweeps::fields
