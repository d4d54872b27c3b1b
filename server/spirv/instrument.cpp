#include "spirv/instrument.hpp"

#include <charconv>
#include <cstdlib>
#include <map>
#include <tuple>

#include "spirv/address_table.hpp"
#include "spirv/early_tests.hpp"
#include "spirv/find_sites.hpp"
#include "spirv/inject.hpp"
#include "spirv/module.hpp"
#include "spirv/site_text.hpp"
#include "spirv/types.hpp"
#include "spirv/footprint.hpp"
#include "spirv/validate.hpp"

namespace tally::spirv {

std::string_view toString(Stage stage) {
  switch (stage) {
    case Stage::Vertex: return "vertex";
    case Stage::TessControl: return "tess_control";
    case Stage::TessEval: return "tess_eval";
    case Stage::Geometry: return "geometry";
    case Stage::Fragment: return "fragment";
    case Stage::Compute: return "compute";
    case Stage::Task: return "task";
    case Stage::Mesh: return "mesh";
    case Stage::Other: break;
  }
  return "other";
}

std::string_view toString(SiteKind kind) {
  switch (kind) {
    case SiteKind::TextureRead: return "texture_read";
    case SiteKind::AttachmentRead: return "attachment_read";
    case SiteKind::ImageWrite: return "image_write";
    case SiteKind::ImageAtomic: return "image_atomic";
    case SiteKind::BufferRead: return "buffer_read";
    case SiteKind::BufferWrite: return "buffer_write";
    case SiteKind::OutputWrite: return "output_write";
    case SiteKind::Invocation: return "invocation";
  }
  return "invocation";
}

std::string_view useKind(const Site& site) {
  switch (site.kind) {
    case SiteKind::TextureRead:
      return site.opcode == "OpImageRead" || site.opcode == "OpImageSparseRead" ? "storage image" : "texture";
    case SiteKind::ImageWrite:
    case SiteKind::ImageAtomic: return "storage image";
    case SiteKind::AttachmentRead:
    case SiteKind::OutputWrite: return "attachment";
    case SiteKind::BufferRead:
    case SiteKind::BufferWrite:
    case SiteKind::Invocation: return "buffer";
  }
  return "buffer";
}

std::optional<SiteKind> siteKindFromString(std::string_view name) {
  for (auto k : {SiteKind::TextureRead, SiteKind::AttachmentRead, SiteKind::ImageWrite, SiteKind::ImageAtomic,
                 SiteKind::BufferRead, SiteKind::BufferWrite, SiteKind::OutputWrite, SiteKind::Invocation}) {
    if (toString(k) == name) return k;
  }
  return std::nullopt;
}

std::optional<Stage> stageFromString(std::string_view name) {
  for (auto s : {Stage::Vertex, Stage::TessControl, Stage::TessEval, Stage::Geometry, Stage::Fragment,
                 Stage::Compute, Stage::Task, Stage::Mesh, Stage::Other}) {
    if (toString(s) == name) return s;
  }
  return std::nullopt;
}

Result<Mode> parseMode(std::string_view text) {
  if (text == "exact") return Mode{CountMode::Exact, 1};
  if (text == "subgroup") return Mode{CountMode::Subgroup, 1};
  if (text == "accumulate") return Mode{CountMode::Accumulate, 1, Flush::Auto};
  if (text == "accumulate:subgroup") return Mode{CountMode::Accumulate, 1, Flush::Subgroup};
  if (text == "accumulate:lane") return Mode{CountMode::Accumulate, 1, Flush::Lane};
  constexpr std::string_view kSampled = "sampled:";
  if (text.starts_with(kSampled)) {
    std::string_view digits = text.substr(kSampled.size());
    uint32_t n = 0;
    auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
    if (ec != std::errc() || end != digits.data() + digits.size() || digits.empty()) {
      return makeError("mode '" + std::string(text) + "': N in sampled:N must be a whole number");
    }
    // 65536: one counted invocation per 256x256 tile; beyond that a 4K frame has under 200 samples.
    if (n < 2 || n > 65536) return makeError("mode '" + std::string(text) + "': N must be between 2 and 65536");
    return Mode{CountMode::Sampled, n};
  }
  return makeError("unknown mode '" + std::string(text) + "' (expected exact, subgroup, sampled:N, accumulate, accumulate:subgroup or accumulate:lane)");
}

std::string toString(const Mode& mode) {
  switch (mode.kind) {
    case CountMode::Exact: return "exact";
    case CountMode::Subgroup: return "subgroup";
    case CountMode::Sampled: return "sampled:" + std::to_string(mode.sampleRate);
    case CountMode::Accumulate:
      return mode.flush == Flush::Lane ? "accumulate:lane" : mode.flush == Flush::Subgroup ? "accumulate:subgroup" : "accumulate";
  }
  return "exact";
}

namespace {
const std::map<std::string_view, uint32_t> kFootprintStudy = {
    {"fp-no-marks", kStudyFpNoMarks},         {"fp-no-bitmap", kStudyFpNoBitmap},
    {"fp-no-outputs", kStudyFpNoOutputs},     {"fp-no-samples", kStudyFpNoSamples},
    {"fp-aliased", kStudyFpAliased},          {"fp-quad", kStudyFpQuad},
    {"fp-first", kStudyFpFirst},              {"fp-own-outputs", kStudyFpOwnOutputs},
    {"fp-match-samples", kStudyFpMatchSamples}, {"fp-match-bytes", kStudyFpMatchBytes},
    {"fp-red", kStudyFpRed},                  {"fp-load-samples", kStudyFpLoadSamples}};
}  // namespace

Result<uint32_t> parseStudy(std::string_view text) {
  uint32_t bits = 0;
  while (!text.empty()) {
    size_t comma = text.find(',');
    std::string_view word = text.substr(0, comma);
    if (word == "no-adds") {
      bits |= kStudyNoAdds;
    } else if (word == "no-flush") {
      bits |= kStudyNoFlush;
    } else if (word == "inline-flush") {
      bits |= kStudyInlineFlush;
    } else if (word == "elected-adds") {
      bits |= kStudyElectedAdds;
    } else if (word == "split-reductions") {
      bits |= kStudySplitReductions;
    } else if (word == "waterfall-each") {
      bits |= kStudyWaterfallEach;
    } else if (word == "partitioned") {
      bits |= kStudyPartitioned;
    } else if (word == "evict-always") {
      bits |= kStudyEvictAlways;
    } else if (auto fp = kFootprintStudy.find(word); fp != kFootprintStudy.end()) {
      bits |= fp->second;
    } else {
      return makeError("unknown variant '" + std::string(word) + "' (expected no-adds, no-flush, inline-flush, elected-adds, split-reductions, waterfall-each, partitioned, evict-always, fp-no-marks, fp-no-bitmap, fp-no-outputs, fp-no-samples, fp-aliased, fp-quad, fp-first, fp-own-outputs, fp-match-samples, fp-match-bytes, fp-red or fp-load-samples, comma-separated)");
    }
    text = comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1);
  }
  return bits;
}

Result<FootprintDedup> parseFootprintDedup(std::string_view text) {
  if (text == "none") return FootprintDedup{false, false, false, false};
  if (text == "all") return FootprintDedup{true, true, true, true};
  FootprintDedup d{false, false, false, false};
  for (std::string_view rest = text;;) {
    size_t comma = rest.find(',');
    std::string_view word = rest.substr(0, comma);
    bool* flag = word == "subgroup" ? &d.subgroup
                 : word == "cache"  ? &d.cache
                 : word == "loops"  ? &d.loops
                 : word == "lanes"  ? &d.lanes
                                    : nullptr;
    if (flag == nullptr || *flag) break;
    *flag = true;
    if (comma == std::string_view::npos) return d;
    rest = rest.substr(comma + 1);
  }
  return makeError("unknown footprint dedup '" + std::string(text) +
                   "' (expected none, all, or a list of subgroup, cache, loops and lanes, each once, joined by commas)");
}

std::string toString(const FootprintDedup& dedup) {
  if (dedup.subgroup && dedup.cache && dedup.loops && dedup.lanes) return "all";
  std::string out;
  for (auto [on, word] : {std::pair{dedup.subgroup, "subgroup"}, {dedup.cache, "cache"}, {dedup.loops, "loops"},
                          {dedup.lanes, "lanes"}}) {
    if (on) out += (out.empty() ? "" : ",") + std::string(word);
  }
  return out.empty() ? "none" : out;
}

Result<std::vector<uint32_t>> wordsFromBytes(std::span<const uint8_t> bytes) {
  if (bytes.empty()) return makeError("empty file: not SPIR-V");
  if (bytes.size() % 4 != 0) {
    return makeError("truncated SPIR-V: " + std::to_string(bytes.size()) + " bytes is not a whole number of 32-bit words");
  }
  std::vector<uint32_t> words(bytes.size() / 4);
  for (size_t i = 0; i < words.size(); ++i) {
    words[i] = uint32_t{bytes[4 * i]} | uint32_t{bytes[4 * i + 1]} << 8 | uint32_t{bytes[4 * i + 2]} << 16 |
               uint32_t{bytes[4 * i + 3]} << 24;
  }
  return words;
}

namespace {

// Slots are per (stage, kind, resource); buffers also split by access width
// so that bytes = count x element size holds for every slot.
// With perSite, each access site is a key of its own (its position in the scan).
using SlotKey = std::tuple<int, int, int64_t, int64_t, int64_t, std::string, int64_t, uint32_t, std::string, int64_t>;

SlotKey slotKey(const Site& s, int64_t site) {
  bool buffer = s.kind == SiteKind::BufferRead || s.kind == SiteKind::BufferWrite;
  bool perEntry = s.kind == SiteKind::Invocation || s.kind == SiteKind::OutputWrite;
  int64_t index = s.dynamicIndex ? -2 : (s.index ? static_cast<int64_t>(*s.index) : -1);
  return {static_cast<int>(s.stage), static_cast<int>(s.kind), s.set, s.binding, index,
          s.set < 0 ? s.resource : std::string(), s.location ? static_cast<int64_t>(*s.location) : -1,
          buffer ? s.elementBytes : 0u, perEntry ? s.entryPoint : std::string(),
          s.kind == SiteKind::Invocation ? -1 : site};
}

Result<Instrumented> run(std::span<const uint32_t> input, const InstrumentOptions& options, bool rewrite) {
  // Framing and header first, for a precise message; then full validation.
  auto parsed = Module::parse(input);
  if (!parsed) return makeError(parsed.error());
  if (options.validate) {
    if (auto error = validate(input, options.target)) {
      // A device's target is named, so a reason says what the module was held to.
      return makeError(options.target == ValidationTarget{}
                           ? "invalid SPIR-V: " + *error
                           : "invalid SPIR-V (validated for " + describe(options.target) + "): " + *error);
    }
  }
  for (const auto& cap : parsed->capabilities) {
    if (static_cast<spv::Capability>(cap.word(1)) == spv::Capability::Kernel) {
      return makeError("unsupported SPIR-V: OpenCL kernel modules are not shaders");
    }
  }

  Instrumented result;
  result.versionIn = parsed->version;
  Module module = std::move(parsed).value();
  result.arithmetic = countArithmetic(module);  // before inlining and counters

  // Refuse a module that already uses the counter binding.
  {
    DefIndex defs(module);
    for (const auto& inst : module.globals) {
      if (inst.opcode() != spv::Op::OpVariable) continue;
      auto set = defs.decorationValue(inst.resultId(), spv::Decoration::DescriptorSet);
      auto binding = defs.decorationValue(inst.resultId(), spv::Decoration::Binding);
      std::vector<std::pair<uint32_t, const char*>> needed = {{options.binding, "the counters"}};
      if (options.footprintBlockBytes != 0) {
        needed.push_back({options.footprintTableBinding, "the footprint table"});
        needed.push_back({options.footprintBitmapBinding, "the footprint bitmaps"});
      }
      if (options.addressTable) needed.push_back({options.addressTableBinding, "the address table lookups"});
      for (const auto& [b, what] : needed) {
        if (set != options.set || binding != b) continue;
        std::string name = defs.name(inst.resultId());
        return makeError("module already uses descriptor set " + std::to_string(options.set) + " binding " +
                         std::to_string(b) + (name.empty() ? "" : " ('" + name + "')") + ", which " + what +
                         " need; choose another set/binding");
      }
    }
  }

  auto scanOnce = [&](const Module& m, const DefIndex& defs, const Types& types) { return findSites(m, defs, types); };
  std::unique_ptr<DefIndex> defs = std::make_unique<DefIndex>(module);
  std::unique_ptr<Types> types = std::make_unique<Types>(*defs);
  auto scan = scanOnce(module, *defs, *types);
  if (!scan) return makeError(scan.error());
  if (!scan->needsInline.empty()) {
    std::string reason = scan->needsInline;
    auto inlined = inlineAll(module.serialize());
    if (!inlined) return makeError(inlined.error());
    auto reparsed = Module::parse(*inlined);
    if (!reparsed) return makeError("after inlining: " + reparsed.error());
    module = std::move(reparsed).value();
    defs = std::make_unique<DefIndex>(module);
    types = std::make_unique<Types>(*defs);
    scan = scanOnce(module, *defs, *types);
    if (!scan) return makeError(scan.error());
    if (!scan->needsInline.empty()) {
      return makeError("unsupported SPIR-V: cannot resolve resources even after inlining: " + scan->needsInline);
    }
    result.inlined = true;
    result.notes.push_back("functions inlined: " + reason);
  }
  result.notes.insert(result.notes.end(), scan->notes.begin(), scan->notes.end());
  // Before the counters: whether early tests are safe is a question about the application's own code.
  result.earlyTestsAdded = preserveEarlyTests(module, *defs, *types, scan->entryPoints,
                                              rewrite && options.earlyFragmentTests, result.notes);

  // Slots.
  std::map<SlotKey, std::pair<uint32_t, uint32_t>> slotOf;
  std::vector<uint32_t> slots;
  uint32_t next = options.firstSlot;
  for (const auto& found : scan->sites) {
    uint32_t count = 1;
    if (found.site.dynamicIndex) count = found.arrayLength != 0 ? found.arrayLength : kRuntimeArraySlots;
    const bool byAddress = options.addressTable && found.address != 0;
    if (byAddress) count = kAddressSlots;
    auto key = slotKey(found.site, options.perSite ? int64_t(result.sites.size()) : -1);
    auto it = slotOf.find(key);
    if (it == slotOf.end()) {
      it = slotOf.emplace(key, std::make_pair(next, count)).first;
      next += count;
    }
    slots.push_back(it->second.first);
    Site site = found.site;
    site.slot = it->second.first;
    site.slotCount = it->second.second;
    site.byAddress = byAddress;
    result.sites.push_back(std::move(site));
  }
  if (options.perSite) describeSites(module, *defs, scan->sites, result.sites);
  if (rewrite && options.countArithmetic && options.mode.kind == CountMode::Accumulate) result.arithmeticSlot = next++;
  result.slotCount = next - options.firstSlot;
  result.firstSlot = options.firstSlot;

  if (!rewrite) {
    result.words.assign(input.begin(), input.end());
    result.versionOut = result.versionIn;
    return result;
  }
  if (auto injected = injectCounters(module, *defs, *types, *scan, slots, options, result); !injected.ok()) {
    return makeError(injected.error());
  }
  result.versionOut = module.version;
  result.words = module.serialize();
  if (options.validate) {
    if (auto error = validate(result.words, options.target)) {
      return makeError("internal error: the instrumented module does not validate: " + *error);
    }
  }
  return result;
}

}  // namespace

Result<Instrumented> instrument(std::span<const uint32_t> words, const InstrumentOptions& options) {
  if (options.mode.kind == CountMode::Sampled && options.mode.sampleRate < 2) {
    return makeError("sampled mode needs N >= 2");
  }
  if (options.footprintBlockBytes != 0 && !footprint::validBlockBytes(options.footprintBlockBytes)) {
    return makeError("footprint block size must be 32, 64 or 128 bytes, not " +
                     std::to_string(options.footprintBlockBytes));
  }
  if (options.footprintBlockBytes != 0 &&
      (options.footprintTableBinding == options.binding || options.footprintBitmapBinding == options.binding ||
       options.footprintTableBinding == options.footprintBitmapBinding)) {
    return makeError("the counter, footprint table and footprint bitmap bindings must differ");
  }
  const uint32_t c = options.computeCopies;
  if (c == 0 || c > 256 || (c & (c - 1)) != 0) {
    return makeError("compute counter copies must be a power of two from 1 to 256, not " + std::to_string(c));
  }
  InstrumentOptions resolved = options;
  if (const char* study = std::getenv("TALLY_ACCUMULATE_STUDY");
      study != nullptr && *study != '\0' && options.mode.kind == CountMode::Accumulate) {
    auto bits = parseStudy(study);
    if (!bits) return makeError("TALLY_ACCUMULATE_STUDY: " + bits.error());
    resolved.study |= *bits;  // beside the caller's (tallyd instrument --partitioned)
  }
  auto noted = [&](Result<Instrumented> result) {
    if (result && (resolved.study & (kStudyNoAdds | kStudyNoFlush)) != 0) {
      result->notes.push_back(std::string("accumulate mode: ") +
                              ((resolved.study & kStudyNoAdds) != 0 ? "the adds " : "") +
                              ((resolved.study & kStudyNoFlush) != 0 ? "the flush " : "") +
                              "left out for the study of their cost: these counts are not the mode's");
    }
    if (result && (resolved.study & kStudyFpAltered) != 0) {
      result->notes.push_back("footprint: marks left out for the study of their cost (TALLY_ACCUMULATE_STUDY): "
                              "these footprints are not the mode's");
    }
    return result;
  };
  if (options.footprintBlockBytes == 0 || options.footprintDedup) return noted(run(words, resolved, true));
  resolved.footprintDedup = FootprintDedup{};
  const char* env = std::getenv("TALLY_FOOTPRINT_DEDUP");
  if (env == nullptr || *env == '\0') return noted(run(words, resolved, true));
  auto dedup = parseFootprintDedup(env);
  if (!dedup) return makeError("TALLY_FOOTPRINT_DEDUP: " + dedup.error());
  resolved.footprintDedup = *dedup;
  auto result = noted(run(words, resolved, true));
  // The module's notes then say what its marks were instrumented with, whatever the caller asked.
  if (result) result->notes.push_back("footprint: marks dedup '" + toString(*dedup) + "', from TALLY_FOOTPRINT_DEDUP");
  return result;
}

Result<Instrumented> analyze(std::span<const uint32_t> words, const InstrumentOptions& options) {
  return run(words, options, false);
}

bool usesDemote(std::span<const uint32_t> words) {
  constexpr uint32_t kOpDemoteToHelperInvocation = 5380;
  for (size_t at = 5; at < words.size();) {
    const uint32_t count = words[at] >> 16;
    if ((words[at] & 0xffffu) == kOpDemoteToHelperInvocation) return true;
    if (count == 0) break;
    at += count;
  }
  return false;
}

void foldCopies(std::span<uint64_t> counters, const CopyLayout& l) {
  for (uint32_t k = 1; k < l.copies; ++k) {
    for (uint32_t s = 0; s < l.slotCount; ++s) {
      size_t from = size_t(l.firstSlot) + size_t(k) * l.stride + s;
      if (from >= counters.size()) return;
      counters[l.firstSlot + s] += counters[from];
      counters[from] = 0;
    }
  }
}

void settleCounters(std::span<uint64_t> counters, const CopyLayout& l) {
  foldCopies(counters, l);
  for (const DerivedCount& d : l.derived) {
    if (d.from < counters.size() && d.to < counters.size()) counters[d.to] += uint64_t(d.times) * counters[d.from];
  }
}

nlohmann::json toJson(const Site& s) {
  nlohmann::json j;
  j["slot"] = s.slot;
  if (s.slotCount != 1) j["slots"] = s.slotCount;
  if (s.byAddress) j["by_address"] = true;
  j["stage"] = toString(s.stage);
  j["entry_point"] = s.entryPoint;
  j["kind"] = toString(s.kind);
  j["set"] = s.set;
  j["binding"] = s.binding;
  if (s.dynamicIndex) {
    j["index"] = "dynamic";
  } else if (s.index) {
    j["index"] = *s.index;
  } else {
    j["index"] = nullptr;
  }
  j["resource"] = s.resource;
  if (s.location) j["location"] = *s.location;
  j["element_type"] = s.elementType;
  j["element_bytes"] = s.elementBytes;
  j["opcode"] = s.opcode;
  if (s.footprint) j["footprint"] = true;
  if (s.line != 0) {
    j["file"] = s.file;
    j["line"] = s.line;
  }
  if (!s.disassembly.empty()) {
    j["function"] = s.function;
    j["instruction"] = s.instruction;
    j["disassembly"] = s.disassembly;
  }
  return j;
}

nlohmann::json countedSiteJson(const Site& s, const std::string& resource, bool write, const std::string& kind,
                               double count, double bytes) {
  const bool placed = s.line != 0;
  return {{"shader", s.shader},
          {"stage", toString(s.stage)},
          {"entry_point", s.entryPoint},
          {"function", s.function},
          {"instruction", s.instruction},
          {"opcode", s.opcode},
          {"resource", resource},
          {"access", write ? "write" : "read"},
          {"kind", kind},
          {"file", placed ? nlohmann::json(s.file) : nlohmann::json(nullptr)},
          {"line", placed ? nlohmann::json(s.line) : nlohmann::json(nullptr)},
          {"disassembly", s.disassembly},
          {"count", count},
          {"bytes", bytes}};
}

nlohmann::json toJson(const Instrumented& r, const InstrumentOptions& options) {
  nlohmann::json sites = nlohmann::json::array();
  for (const auto& s : r.sites) sites.push_back(toJson(s));
  nlohmann::json derived = nlohmann::json::array();
  for (const auto& d : r.derived) derived.push_back({{"from_slot", d.from}, {"to_slot", d.to}, {"times", d.times}});
  return {
      {"sites", std::move(sites)},
      {"slot_count", r.slotCount},
      {"first_slot", options.firstSlot},
      {"copies", r.copies},
      {"copy_stride", r.copyStride},
      {"reserved_slots", r.layout().reserved()},
      {"derived_counts", std::move(derived)},
      {"mode", toString(options.mode)},
      {"footprint",
       options.footprintBlockBytes == 0
           ? nlohmann::json(nullptr)
           : nlohmann::json{{"block_bytes", options.footprintBlockBytes},
                            {"table_binding", options.footprintTableBinding},
                            {"bitmap_binding", options.footprintBitmapBinding},
                            {"entry_words", footprint::kEntryWords},
                            {"dedup", toString(r.footprintDedup.value_or(FootprintDedup{}))}}},
      {"counters",
       {{"set", options.set},
        {"binding", options.binding},
        {"width", options.width == CounterWidth::Int64 ? "int64" : "uint32_pair"},
        {"bytes_per_slot", 8}}},
      {"spirv_version_in", versionString(r.versionIn)},
      {"spirv_version_out", versionString(r.versionOut)},
      {"inlined", r.inlined},
      {"notes", r.notes},
  };
}

}  // namespace tally::spirv
