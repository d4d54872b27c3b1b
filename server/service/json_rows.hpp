// Stored rows as the routes answer them (docs/api.md names every field).
// Internal to service/.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "service/json_text.hpp"
#include "store/frame_time.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

template <class T>
nlohmann::json opt(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Reuse: requested bytes over the footprint of the same lines; null without a footprint or at 0.
std::optional<double> reuseOf(std::optional<double> requested, std::optional<double> footprint);
nlohmann::json reuseJson(std::optional<double> requested, std::optional<double> footprint);
nlohmann::json jobJson(const store::Job& j);
nlohmann::json hostJson(const store::Host& h);
// Why nobody runs a queued job (null when a free worker can take it).
nlohmann::json waitingReason(const store::Job& job, const std::vector<store::Host>& hosts, int64_t staleAfterMs);
// A run's row; with its frame time, also frame_ms_median (a number or null)
// and frame_ms_median_source. writeRunRow: the same object as JSON text,
// byte for byte its dump() (one list of keys for both, in json_rows.cpp).
nlohmann::json runRowJson(const store::RunRow& r, const store::RunFrameTime* frame = nullptr);
void writeRunRow(JsonText& out, const store::RunRow& r, const store::RunFrameTime* frame);
// GET /api/runs's body, {"next_cursor", "runs"} with each run's frame time
// (none in frameTimes: a default RunFrameTime, source "none"), as the text
// that dump() writes for the same json.
std::string runPageText(const store::RunPage& page, const std::map<int64_t, store::RunFrameTime>& frameTimes);
nlohmann::json deviceJson(const store::Device& d);
nlohmann::json sweepRowJson(const store::SweepRow& s);
nlohmann::json sampleRowJson(const store::SampleRow& s);
nlohmann::json passJson(const store::Pass& p);
// GET /api/runs/{id}'s body: the run's row (with its frame time, as
// runRowJson), device_info, resources, shaders, counter_headroom, ceilings
// and passes (as passJson), written as the text that dump() writes for the
// same object (one list of keys for each part, in json_rows.cpp).
std::string runDetailText(const store::RunDetail& d, const store::RunFrameTime* frame);
nlohmann::json comparisonJson(const store::Comparison& c);

}  // namespace tally::service::detail
