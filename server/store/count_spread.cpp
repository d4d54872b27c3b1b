#include "store/count_spread.hpp"

#include <bit>
#include <string_view>

namespace tally::store {

using nlohmann::json;

namespace {

// The statistics of analysis::toJson(Spread) but n, in its key order (sorted).
constexpr std::string_view kStatistics[] = {"iqr", "max", "mean", "median", "min", "q1", "q3"};

bool sameBits(double a, double b) { return std::bit_cast<uint64_t>(a) == std::bit_cast<uint64_t>(b); }

}  // namespace

std::optional<uint64_t> constantSpreadFrames(const json& spread, double count) {
  if (!spread.is_object() || spread.size() != std::size(kStatistics) + 1) return std::nullopt;
  const auto* fields = spread.get_ptr<const json::object_t*>();
  auto n = fields->find("n");
  // Unsigned as a result's text parses; a signed integer as code may build it.
  bool frames = n != fields->end() && (n->second.is_number_unsigned() ||
                                       (n->second.is_number_integer() && n->second.get<int64_t>() >= 0));
  if (!frames) return std::nullopt;
  for (std::string_view key : kStatistics) {
    auto it = fields->find(key);
    if (it == fields->end() || !it->second.is_number_float()) return std::nullopt;
    if (!sameBits(it->second.get<double>(), key == "iqr" ? 0.0 : count)) return std::nullopt;
  }
  return n->second.get<uint64_t>();
}

json expandCountSpread(json stored, double count) {
  if (!stored.is_number_unsigned()) return stored;
  json spread = json::object();
  for (std::string_view key : kStatistics) spread[std::string(key)] = key == "iqr" ? 0.0 : count;
  spread["n"] = stored.get<uint64_t>();
  return spread;
}

}  // namespace tally::store
