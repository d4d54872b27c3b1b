// Bytes per draw command (TALLY_LAYER_DRAWS, docs/layer.md "Draws"): each
// draw's region of the counter buffer is its own, so its counted lines are
// its share of the pass's, and the draws of a pass sum to the pass's counted
// lines exactly. The output keeps a pass's heaviest draws and sums the
// others, as the built-in renderers' captures do (capture/sample.cpp).
#include <algorithm>

#include "names.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

// The draws a pass lists; the result's store keeps as many (docs/result-schema.md).
constexpr size_t kMaxDrawsListed = 256;

uint64_t drawBytes(const PassRecord::DrawLine& d) { return d.bytesRead + d.bytesWritten; }

void add(PassRecord::DrawLine& to, const PassRecord::DrawLine& from) {
  to.count += from.count;
  to.bytesRead += from.bytesRead;
  to.bytesWritten += from.bytesWritten;
}

// A draw's name: its innermost debug label and its pipeline's name, the
// pipeline's handle where the application named none.
std::string drawName(const PassRecord::DrawLine& d) {
  return d.label.empty() ? d.pipeline : d.label + " \u00b7 " + d.pipeline;
}

// The pass's draws, most bytes first (ties: recording order).
std::vector<std::pair<uint32_t, const PassRecord::DrawLine*>> byBytes(const PassRecord& pass) {
  std::vector<std::pair<uint32_t, const PassRecord::DrawLine*>> order;
  for (const auto& [index, line] : pass.drawLines) order.emplace_back(index, &line);
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return drawBytes(*a.second) > drawBytes(*b.second); });
  return order;
}

nlohmann::json amounts(nlohmann::json entry, const PassRecord::DrawLine& d) {
  entry["count"] = d.count;
  entry["bytes_read"] = d.bytesRead;
  entry["bytes_written"] = d.bytesWritten;
  entry["bytes"] = drawBytes(d);
  return entry;
}

}  // namespace

namespace {

// The draw a region counts for (created at its first count), the pass's rest
// for the regions beyond the cap; null without Config::draws or for a dispatch.
PassRecord::DrawLine* drawOf(const DeviceState& dev, const Region& region, PassRecord& pass) {
  if (!dev.config.draws || region.draw == kNoDraw) return nullptr;
  if (region.draw == kRestDraws) return &pass.drawsRest;
  auto [at, inserted] = pass.drawLines.try_emplace(region.draw);
  if (inserted) {
    at->second.commands = 1;
    at->second.label = region.label;
    const PipelineInfo& p = *region.pipeline;
    at->second.pipeline = p.name.empty() ? "pipeline " + hexHandle(p.handle) : p.name;
  }
  return &at->second;
}

}  // namespace

void noteDraw(const DeviceState& dev, const Region& region, PassRecord& pass) {
  PassRecord::DrawLine* line = drawOf(dev, region, pass);
  if (line != nullptr && region.draw == kRestDraws) line->commands += region.drawCommands;
}

void addDrawCount(const DeviceState& dev, const Region& region, bool write, uint64_t count, uint64_t bytes,
                  PassRecord& pass) {
  if (PassRecord::DrawLine* line = drawOf(dev, region, pass)) {
    line->count += count;
    (write ? line->bytesWritten : line->bytesRead) += count * bytes;
  }
}

void joinDraws(PassRecord& into, const PassRecord& p, uint32_t before) {
  for (const auto& [index, line] : p.drawLines) into.drawLines[before + index] = line;
  add(into.drawsRest, p.drawsRest);
  into.drawsRest.commands += p.drawsRest.commands;
}

nlohmann::json drawListJson(const PassRecord& pass) {
  nlohmann::json out = nlohmann::json::array();
  const auto order = byBytes(pass);
  for (size_t i = 0; i < order.size() && i < kMaxDrawsListed; ++i) {
    const auto& [index, d] = order[i];
    out.push_back(amounts(
        {{"index", index}, {"name", drawName(*d)}, {"label", d->label}, {"pipeline", d->pipeline}}, *d));
  }
  return out;
}

nlohmann::json drawsRestJson(const PassRecord& pass) {
  PassRecord::DrawLine rest = pass.drawsRest;
  const auto order = byBytes(pass);
  for (size_t i = kMaxDrawsListed; i < order.size(); ++i) {
    add(rest, *order[i].second);
    rest.commands += order[i].second->commands;
  }
  if (rest.commands == 0) return nullptr;
  return amounts({{"draws", rest.commands}}, rest);
}

}  // namespace tally::layer
