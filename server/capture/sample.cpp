#include "capture/sample.hpp"

#include <algorithm>

#include "analysis/stats.hpp"

namespace tally::capture {

using analysis::Spread;
using analysis::spreadOf;
using nlohmann::json;

namespace {

std::string lineKey(const std::string& resource, bool write, const std::string& source) {
  return resource + (write ? "\x1fw\x1f" : "\x1fr\x1f") + source;
}

void addSites(SampleMeasure& m, const renderers::PassResult& pass) {
  auto& list = m.sites[pass.name];
  auto& index = m.siteIndex[pass.name];
  for (const auto& c : pass.sites) {
    std::string key = c.site.shader + "\x1f" + std::to_string(c.site.instruction) + "\x1f" +
                      std::to_string(c.site.line) + "\x1f" + lineKey(c.resource, c.write, "counter");
    auto [it, inserted] = index.try_emplace(key, list.size());
    if (inserted) list.push_back({c, lineKey(c.resource, c.write, "counter"), 0, 0});
    list[it->second].count += double(c.count);
    list[it->second].bytes += double(c.bytes);
  }
}

void addToLine(DrawLine& line, const renderers::DrawCount& d, uint32_t draws) {
  line.draws = draws;
  line.count += double(d.count);
  line.bytesRead += double(d.bytesRead);
  line.bytesWritten += double(d.bytesWritten);
}

void addDraws(SampleMeasure& m, const renderers::PassResult& pass) {
  if (pass.draws.empty() && pass.drawsRest.draws == 0 && pass.materials.empty()) return;
  ++m.drawFrames[pass.name];
  for (const auto& d : pass.draws) {
    auto [it, inserted] = m.draws[pass.name].try_emplace(d.index);
    if (inserted) it->second.draw = d;
    addToLine(it->second, d, d.draws);
  }
  if (pass.drawsRest.draws > 0) addToLine(m.drawsRest[pass.name], pass.drawsRest, pass.drawsRest.draws);
  for (const auto& mc : pass.materials) {
    renderers::DrawCount asDraw;
    asDraw.material = mc.material;
    asDraw.count = mc.count;
    asDraw.bytesRead = mc.bytesRead;
    asDraw.bytesWritten = mc.bytesWritten;
    auto [it, inserted] = m.materials[pass.name].try_emplace(mc.material);
    if (inserted) it->second.draw = asDraw;
    addToLine(it->second, asDraw, mc.draws);
  }
}

double lineBytes(const DrawLine& l) { return l.bytesRead + l.bytesWritten; }

// A pass's draws, most bytes first (ties: scene order).
std::vector<const DrawLine*> drawsByBytes(const SampleMeasure& m, const std::string& pass) {
  std::vector<const DrawLine*> order;
  auto found = m.draws.find(pass);
  if (found == m.draws.end()) return order;
  for (const auto& [index, line] : found->second) order.push_back(&line);
  std::stable_sort(order.begin(), order.end(),
                   [](const DrawLine* a, const DrawLine* b) { return lineBytes(*a) > lineBytes(*b); });
  return order;
}

double drawFrames(const SampleMeasure& m, const std::string& pass) {
  auto it = m.drawFrames.find(pass);
  return it != m.drawFrames.end() && it->second > 0 ? double(it->second) : 1.0;
}

json bytesFields(json entry, const DrawLine& l, double frames) {
  entry["bytes_read"] = l.bytesRead / frames;
  entry["bytes_written"] = l.bytesWritten / frames;
  entry["bytes"] = lineBytes(l) / frames;
  return entry;
}

}  // namespace

json drawsJson(const SampleMeasure& m, const std::string& pass) {
  json out = json::array();
  const double frames = drawFrames(m, pass);
  const auto order = drawsByBytes(m, pass);
  for (size_t i = 0; i < order.size() && i < kMaxDraws; ++i) {
    const renderers::DrawCount& d = order[i]->draw;
    out.push_back(bytesFields({{"index", d.index},
                               {"name", "mesh " + d.mesh + " \u00b7 " + d.material},
                               {"mesh", d.mesh},
                               {"material", d.material},
                               {"count", order[i]->count / frames}},
                              *order[i], frames));
  }
  return out;
}

json drawsRestJson(const SampleMeasure& m, const std::string& pass) {
  DrawLine rest;
  if (auto it = m.drawsRest.find(pass); it != m.drawsRest.end()) rest = it->second;
  const auto order = drawsByBytes(m, pass);
  for (size_t i = kMaxDraws; i < order.size(); ++i) {
    rest.draws += order[i]->draws;
    rest.count += order[i]->count;
    rest.bytesRead += order[i]->bytesRead;
    rest.bytesWritten += order[i]->bytesWritten;
  }
  if (rest.draws == 0) return nullptr;
  const double frames = drawFrames(m, pass);
  return bytesFields({{"draws", rest.draws}, {"count", rest.count / frames}}, rest, frames);
}

json materialsJson(const SampleMeasure& m, const std::string& pass) {
  json out = json::array();
  auto found = m.materials.find(pass);
  if (found == m.materials.end()) return out;
  std::vector<const DrawLine*> order;
  for (const auto& [name, line] : found->second) order.push_back(&line);
  std::stable_sort(order.begin(), order.end(),
                   [](const DrawLine* a, const DrawLine* b) { return lineBytes(*a) > lineBytes(*b); });
  const double frames = drawFrames(m, pass);
  for (const DrawLine* l : order) {
    out.push_back(bytesFields({{"material", l->draw.material}, {"draws", l->draws}}, *l, frames));
  }
  return out;
}

json sitesJson(const SampleMeasure& m, const std::string& pass) {
  json out = json::array();
  auto found = m.sites.find(pass);
  if (found == m.sites.end()) return out;
  std::vector<const SiteLine*> order;
  for (const auto& s : found->second) order.push_back(&s);
  std::stable_sort(order.begin(), order.end(), [](const SiteLine* a, const SiteLine* b) { return a->bytes > b->bytes; });
  for (const SiteLine* s : order) {
    auto line = m.lines.find({pass, s->lineKey});
    const double frames = line != m.lines.end() && !line->second.counts.empty() ? double(line->second.counts.size()) : 1.0;
    const renderers::SiteCount& c = s->site;
    out.push_back(spirv::countedSiteJson(c.site, c.resource, c.write, c.kind, s->count / frames, s->bytes / frames));
  }
  return out;
}

void addCounts(SampleMeasure& m, const renderers::FrameResult& frame) {
  double total = 0;
  for (const auto& pass : frame.passes) {
    if (std::find(m.passOrder.begin(), m.passOrder.end(), pass.name) == m.passOrder.end()) {
      m.passOrder.push_back(pass.name);
    }
    m.fragmentInvocations[pass.name].push_back(double(pass.fragmentInvocations));
    if (pass.fragmentInvocationsStatistic >= 0) m.statistic[pass.name].push_back(double(pass.fragmentInvocationsStatistic));
    if (pass.computeInvocations > 0 || pass.computeInvocationsStatistic > 0) {
      m.computeInvocations[pass.name].push_back(double(pass.computeInvocations));
      if (pass.computeInvocationsStatistic >= 0) {
        m.computeStatistic[pass.name].push_back(double(pass.computeInvocationsStatistic));
      }
    }
    m.instrumentedMs[pass.name].push_back(pass.gpuMs);
    if (pass.arithmeticOps >= 0) m.arithmeticOps[pass.name].push_back(double(pass.arithmeticOps));
    if (pass.arithmeticCounted) m.arithmeticCounted.insert(pass.name);
    total += pass.gpuMs;
    for (const auto& a : pass.accesses) {
      // One line per (pass, resource, access, source): a counted and a
      // derived line on one resource (the visibility pass's index reads)
      // stay apart, not averaged into one.
      auto key = std::make_pair(pass.name, lineKey(a.resource, a.write, a.source));
      auto [it, inserted] = m.lines.try_emplace(key);
      if (inserted) {
        it->second.pass = pass.name;
        it->second.resource = a.resource;
        it->second.write = a.write;
        it->second.source = a.source;
        it->second.kind = a.kind;
        it->second.onChip = a.onChip;
      }
      it->second.counts.push_back(double(a.count));
      it->second.bytes.push_back(double(a.bytes));
      // -1: not measured (footprint off, or a line the model cannot see).
      if (a.footprintBytes >= 0) it->second.footprint.push_back(double(a.footprintBytes));
      if (a.footprintBytes >= 0 && a.footprintBlocks >= 0) it->second.footprintBlocks.push_back(double(a.footprintBlocks));
      if (a.footprintBytes >= 0 && a.footprintClamped) ++it->second.footprintClampedFrames;
    }
    addSites(m, pass);
    addDraws(m, pass);
  }
  m.instrumentedFrameMs.push_back(total);
  m.instrumentedWallMs.push_back(frame.submitSeconds * 1e3);
}

void addTimes(SampleMeasure& m, const renderers::FrameResult& frame) {
  double total = 0;
  size_t index = m.frameMs.size();  // this frame's
  for (const auto& pass : frame.passes) {
    m.plainMs[pass.name].push_back(pass.gpuMs);
    auto& byFrame = m.plainMsByFrame[pass.name];
    byFrame.resize(index + 1, 0.0);  // 0 in earlier frames without the pass
    byFrame[index] += pass.gpuMs;
    total += pass.gpuMs;
  }
  m.frameMs.push_back(total);
  m.wallMs.push_back(frame.submitSeconds * 1e3);
}

void addFrameWall(const SampleMeasure& m, json& extras) {
  if (!m.wallMs.empty()) extras["frame_wall_ms"] = spreadOf(m.wallMs).median;
  if (!m.instrumentedWallMs.empty()) extras["frame_wall_ms_instrumented"] = spreadOf(m.instrumentedWallMs).median;
}

json sampleJson(const SampleMeasure& m, const std::vector<renderers::ResourceInfo>& resources, uint32_t frames,
                uint32_t countedFrames) {
  std::map<std::string, const renderers::ResourceInfo*> byName;
  for (const auto& r : resources) byName[r.name] = &r;
  // A pass's time in each uninstrumented frame, one entry per frame.
  auto passFrames = [&m](const std::string& name) {
    std::vector<double> ms;
    if (auto it = m.plainMsByFrame.find(name); it != m.plainMsByFrame.end()) ms = it->second;
    ms.resize(m.frameMs.size(), 0.0);
    return ms;
  };
  json passes = json::array();
  double sampleBytes = 0, sampleDram = 0;
  double sampleFootprint = 0;
  bool sampleHasFootprint = false;
  for (const auto& name : m.passOrder) {
    Spread plain = spreadOf(m.plainMs.count(name) ? m.plainMs.at(name) : std::vector<double>{});
    Spread instrumented = spreadOf(m.instrumentedMs.at(name));
    json pass = {
        {"name", name},
        {"gpu_ms", plain.median},
        {"gpu_ms_spread", toJson(plain)},
        {"gpu_ms_frames", passFrames(name)},
        {"gpu_ms_instrumented", instrumented.median},
        {"overhead_ratio", plain.median > 0 ? instrumented.median / plain.median : 0.0},
        {"fragment_invocations", spreadOf(m.fragmentInvocations.at(name)).mean},
    };
    if (m.statistic.count(name)) pass["fragment_invocations_statistic"] = spreadOf(m.statistic.at(name)).mean;
    if (m.computeInvocations.count(name)) {
      pass["compute_invocations"] = spreadOf(m.computeInvocations.at(name)).mean;
    }
    if (m.computeStatistic.count(name)) {
      pass["compute_invocations_statistic"] = spreadOf(m.computeStatistic.at(name)).mean;
    }
    json lines = json::array();
    double passBytes = 0, passDram = 0;
    double passFootprint = 0;
    bool passHasFootprint = false;
    for (const auto& [key, line] : m.lines) {
      if (line.pass != name) continue;
      auto info = byName.find(line.resource);
      Spread count = spreadOf(line.counts), bytes = spreadOf(line.bytes);
      json r = {
          {"name", line.resource},
          {"format", info != byName.end() ? json(info->second->formatName) : json(nullptr)},
          // How the pass uses the resource, else (derived lines) what it is.
          {"kind", !line.kind.empty()     ? json(line.kind)
                   : info != byName.end() ? json(std::string(renderers::toString(info->second->kind)))
                                          : json(nullptr)},
          {"access", line.write ? "write" : "read"},
          {"count", count.mean},   // per frame, averaged over the sample's frames
          {"bytes", bytes.mean},
          {"count_spread", toJson(count)},
          {"source", line.source},
          // The tile-memory model (docs/measurement.md, "Byte models"): 0 DRAM bytes.
          {"on_chip", line.onChip},
      };
      if (!line.footprint.empty()) {
        // Distinct bytes touched per frame, averaged like bytes; reuse: how
        // many times each touched byte was requested.
        double footprint = spreadOf(line.footprint).mean;
        r["footprint_bytes"] = footprint;
        r["reuse"] = footprint > 0 ? json(bytes.mean / footprint) : json(nullptr);
        // The blocks behind it: x the block size, the strict bound, which
        // exceeds the requested bytes where accesses are sparser than a block.
        if (!line.footprintBlocks.empty()) r["footprint_blocks"] = spreadOf(line.footprintBlocks).mean;
        // Whether footprint_bytes was clamped to the requested bytes (blocks
        // x block size above them) in any frame: the reuse of 1 is then a floor.
        r["footprint_clamped"] = line.footprintClampedFrames > 0;
        passFootprint += footprint;
        passHasFootprint = true;
      }
      passBytes += bytes.mean;
      if (!line.onChip) passDram += bytes.mean;
      lines.push_back(std::move(r));
    }
    pass["resources"] = std::move(lines);
    if (m.sites.count(name)) pass["sites"] = sitesJson(m, name);
    if (m.drawFrames.count(name)) {
      pass["draws"] = drawsJson(m, name);
      if (json rest = drawsRestJson(m, name); !rest.is_null()) pass["draws_rest"] = std::move(rest);
      pass["materials"] = materialsJson(m, name);
    }
    pass["bytes"] = passBytes;                 // the immediate-mode model: every line
    pass["bytes_tile_model"] = passDram;       // the tile-memory model: lines not on chip
    if (passHasFootprint) {
      pass["footprint_bytes"] = passFootprint;  // the lines that have one
      sampleFootprint += passFootprint;
      sampleHasFootprint = true;
    }
    sampleBytes += passBytes;
    sampleDram += passDram;
    passes.push_back(std::move(pass));
  }
  Spread frame = spreadOf(m.frameMs), instrumentedFrame = spreadOf(m.instrumentedFrameMs);
  // A fixed camera counts the same every frame; a count that varies across
  // the counted frames (non-deterministic work, or a driver fault) is flagged.
  bool countsVary = false;
  for (const auto& [key, line] : m.lines) {
    for (double c : line.counts) countsVary = countsVary || c != line.counts.front();
  }
  json sample = {
      {"frames", frames},
      {"counted_frames", countedFrames},
      {"counts_vary", countsVary},
      {"frame_ms", frame.median},
      {"frame_ms_spread", toJson(frame)},
      {"frame_ms_frames", m.frameMs},
      {"frame_ms_instrumented", instrumentedFrame.median},
      {"overhead_ratio", frame.median > 0 ? instrumentedFrame.median / frame.median : 0.0},
      {"bytes", sampleBytes},
      {"bytes_tile_model", sampleDram},
      {"passes", std::move(passes)},
  };
  if (sampleHasFootprint) sample["footprint_bytes"] = sampleFootprint;
  return sample;
}

}  // namespace tally::capture
