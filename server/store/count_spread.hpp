// A counter's count_spread (its count's median, quartiles, IQR, min, max and
// mean over the sample's frames, and the frames n) as the store keeps it.
// Counts repeat exactly from frame to frame wherever the scene and camera
// hold still, so most spreads say only "n frames, each counting `count`":
// 165 bytes of JSON text, two thirds of a counter's bytes and most of the
// ingest's on PostgreSQL (docs/benchmarks.md, "Constant count spreads").
// Such a spread is stored as the JSON number n alone and expanded on
// reading; any other spread is stored as its JSON text. The ingest refuses a
// count_spread that is not an object, so a stored number is always this form.
#pragma once

#include <cstdint>
#include <optional>

#include <nlohmann/json.hpp>

namespace tally::store {

// n when `spread` is exactly the spread of n frames that each counted
// `count`: the eight keys and nothing else, the seven statistics floats with
// count's bits (iqr +0.0), n a non-negative integer; otherwise nothing.
std::optional<uint64_t> constantSpreadFrames(const nlohmann::json& spread, double count);

// The spread as stored (a number n: n frames of `count`; anything else as
// it is) back to the object the result carried.
nlohmann::json expandCountSpread(nlohmann::json stored, double count);

}  // namespace tally::store
