// Stored rows as the routes answer them (docs/api.md names every field).
// Internal to service/.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/store.hpp"

namespace tally::service::detail {

template <class T>
nlohmann::json opt(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Reuse: requested bytes over the footprint of the same lines; null without a footprint or at 0.
nlohmann::json reuseJson(std::optional<double> requested, std::optional<double> footprint);
nlohmann::json jobJson(const store::Job& j);
nlohmann::json hostJson(const store::Host& h);
// Why nobody runs a queued job (null when a free worker can take it).
nlohmann::json waitingReason(const store::Job& job, const std::vector<store::Host>& hosts, int64_t staleAfterMs);
nlohmann::json runRowJson(const store::RunRow& r);
nlohmann::json deviceJson(const store::Device& d);
nlohmann::json sweepRowJson(const store::SweepRow& s);
nlohmann::json sampleRowJson(const store::SampleRow& s);
nlohmann::json passJson(const store::Pass& p);
nlohmann::json comparisonJson(const store::Comparison& c);

}  // namespace tally::service::detail
