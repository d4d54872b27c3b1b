// The GLSL corpus: every shader in corpus/ is compiled for Vulkan 1.0 and 1.3,
// instrumented in every mode and counter width, validated, and its site keys
// compared with the hand-derived set in corpus_expected.txt.

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "gpu/glsl.hpp"
#include "spirv/instrument.hpp"
#include "spirv/sites.hpp"
#include "spirv/validate.hpp"

// Debug info (OpLine) is compiled in for the Vulkan 1.3 target. Building with
// -DTALLY_CORPUS_DEBUG_INFO=0 turns it off, only to look past a glslang
// debug-info failure while diagnosing; the test as registered keeps it on.
#ifndef TALLY_CORPUS_DEBUG_INFO
#define TALLY_CORPUS_DEBUG_INFO 1
#endif

namespace tally {
namespace {

namespace fs = std::filesystem;
using spirv::CounterWidth;
using spirv::Site;
using spirv::SiteKind;
using spirv::Stage;

struct CorpusShader {
  std::string file;  // e.g. "textured.frag.glsl"
  Stage stage = Stage::Other;
  bool vulkan13Only = false;
  bool refused = false;
  std::set<std::string> expected;
};

// Readable test parameter in gtest messages.
void PrintTo(const CorpusShader& shader, std::ostream* os) { *os << shader.file; }

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string trim(const std::string& s) {
  auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

Stage stageOfFile(const std::string& file) {
  // <name>.<stage>.glsl
  auto glsl = file.rfind(".glsl");
  if (glsl == std::string::npos) return Stage::Other;
  auto dot = file.rfind('.', glsl - 1);
  if (dot == std::string::npos) return Stage::Other;
  std::string stage = file.substr(dot + 1, glsl - dot - 1);
  if (stage == "vert") return Stage::Vertex;
  if (stage == "frag") return Stage::Fragment;
  if (stage == "comp") return Stage::Compute;
  return Stage::Other;
}

// Parses corpus_expected.txt. A malformed file yields an entry named
// "<parse error: ...>" so that the failure shows up as a test.
std::vector<CorpusShader> loadCorpus() {
  std::vector<CorpusShader> shaders;
  std::ifstream in(TALLY_CORPUS_EXPECTED);
  if (!in) {
    shaders.push_back({"<cannot open " TALLY_CORPUS_EXPECTED ">"});
    return shaders;
  }
  std::string line;
  while (std::getline(in, line)) {
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    if (line[0] == '[') {
      auto close = line.find(']');
      CorpusShader shader;
      shader.file = line.substr(1, close == std::string::npos ? std::string::npos : close - 1);
      std::string flags = close == std::string::npos ? "" : trim(line.substr(close + 1));
      shader.vulkan13Only = flags.find("vulkan13-only") != std::string::npos;
      shader.refused = flags.find("refused") != std::string::npos;
      shader.stage = stageOfFile(shader.file);
      shaders.push_back(std::move(shader));
      continue;
    }
    if (shaders.empty()) {
      shaders.push_back({"<parse error: key before any [shader]: " + line + ">"});
      continue;
    }
    shaders.back().expected.insert(line);
  }
  return shaders;
}

const std::vector<CorpusShader>& corpus() {
  static const std::vector<CorpusShader> shaders = loadCorpus();
  return shaders;
}

// "KIND SET BINDING [N]|[dyn]", "output_write loc L", "vertex_input loc L", "invocation".
std::string siteKey(const Site& s) {
  std::string kind(spirv::toString(s.kind));
  if (s.kind == SiteKind::Invocation) return kind;
  if (s.kind == SiteKind::BufferRead && s.location) return "vertex_input loc " + std::to_string(*s.location);
  if (s.kind == SiteKind::OutputWrite) {
    return kind + " loc " + (s.location ? std::to_string(*s.location) : std::string("?"));
  }
  std::string key = kind + " " + std::to_string(s.set) + " " + std::to_string(s.binding);
  if (s.dynamicIndex) {
    key += " [dyn]";
  } else if (s.index) {
    key += " [" + std::to_string(*s.index) + "]";
  }
  return key;
}

std::string describe(const Site& s) {
  return siteKey(s) + " (slot " + std::to_string(s.slot) + "+" + std::to_string(s.slotCount) + ", resource '" +
         s.resource + "', " + s.opcode + ", " + s.elementType + " " + std::to_string(s.elementBytes) + "B" +
         (s.line ? ", " + s.file + ":" + std::to_string(s.line) : std::string()) + ")";
}

std::string join(const std::set<std::string>& keys) {
  std::string out;
  for (const auto& k : keys) out += "\n    " + k;
  return out.empty() ? "\n    (none)" : out;
}

const char* targetName(glsl::Target t) {
  switch (t) {
    case glsl::Target::Vulkan10: return "vulkan1.0";
    case glsl::Target::Vulkan11: return "vulkan1.1";
    case glsl::Target::Vulkan12: return "vulkan1.2";
    case glsl::Target::Vulkan13: return "vulkan1.3";
  }
  return "?";
}

struct Variant {
  spirv::Mode mode;
  CounterWidth width;
  uint32_t footprint = 0;  // block bytes, 0 off
  bool arithmetic = false;  // InstrumentOptions::countArithmetic
  std::string name() const {
    return spirv::toString(mode) + (width == CounterWidth::Int64 ? "/int64" : "/uint32_pair") +
           (footprint != 0 ? "+footprint:" + std::to_string(footprint) : "") + (arithmetic ? "+arithmetic" : "");
  }
};

std::vector<Variant> variants() {
  std::vector<Variant> out;
  for (const char* m : {"exact", "subgroup", "sampled:4", "sampled:64", "accumulate", "accumulate:subgroup", "accumulate:lane"}) {
    auto mode = spirv::parseMode(m);
    EXPECT_TRUE(mode.ok()) << m << ": " << (mode.ok() ? "" : mode.error());
    if (!mode.ok()) continue;
    for (auto w : {CounterWidth::Int64, CounterWidth::Uint32Pair}) out.push_back({*mode, w});
  }
  // Footprint marking beside three counting modes, at each block size.
  out.push_back({*spirv::parseMode("accumulate"), CounterWidth::Int64, 64, true});
  out.push_back({*spirv::parseMode("exact"), CounterWidth::Uint32Pair, 32});
  out.push_back({*spirv::parseMode("subgroup"), CounterWidth::Int64, 128});
  return out;
}

Result<std::vector<uint32_t>> compileCorpus(const CorpusShader& shader, glsl::Target target) {
  std::string source = readText(fs::path(TALLY_CORPUS_DIR) / shader.file);
  if (source.empty()) return makeError("empty or missing " + shader.file);
  glsl::CompileOptions options;
  options.target = target;
  // Debug info (OpLine/OpSource) on one of the two targets.
  options.debugInfo = TALLY_CORPUS_DEBUG_INFO && target == glsl::Target::Vulkan13;
  options.fileName = shader.file;
  return glsl::compile(source, shader.stage, options);
}

bool isAccess(SiteKind k) { return k != SiteKind::Invocation && k != SiteKind::OutputWrite; }
bool isBuffer(SiteKind k) { return k == SiteKind::BufferRead || k == SiteKind::BufferWrite; }

// Slot invariants of one instrumentation result.
void checkSlots(const spirv::Instrumented& r, uint32_t firstSlot) {
  // Every site lies in [firstSlot, firstSlot + slotCount).
  for (const auto& s : r.sites) {
    EXPECT_GE(s.slot, firstSlot) << describe(s);
    EXPECT_GE(s.slotCount, 1u) << describe(s);
    EXPECT_LE(uint64_t{s.slot} + s.slotCount, uint64_t{firstSlot} + r.slotCount)
        << describe(s) << " outside [" << firstSlot << ", " << firstSlot + r.slotCount << ")";
    if (s.dynamicIndex) {
      EXPECT_GT(s.slotCount, 1u) << "a dynamic index gets one slot per element: " << describe(s);
    } else {
      EXPECT_EQ(s.slotCount, 1u) << describe(s);
    }
  }
  // Same key -> one slot. Buffers are split by access width (docs/measurement.md:
  // "Two loads of different sizes from the same buffer get two slots"), so for
  // buffer sites the grouping is by (key, elementBytes).
  std::map<std::pair<std::string, uint32_t>, std::pair<uint32_t, uint32_t>> slotOfGroup;
  for (const auto& s : r.sites) {
    std::pair<std::string, uint32_t> group{siteKey(s), isBuffer(s.kind) ? s.elementBytes : 0u};
    auto [it, inserted] = slotOfGroup.emplace(group, std::make_pair(s.slot, s.slotCount));
    if (!inserted) {
      EXPECT_EQ(it->second.first, s.slot) << "sites with the same key must share a slot: " << describe(s);
      EXPECT_EQ(it->second.second, s.slotCount) << describe(s);
    }
  }
  // Different keys (or widths) -> disjoint slot ranges.
  std::vector<std::tuple<uint32_t, uint32_t, std::string>> ranges;
  for (const auto& [group, slot] : slotOfGroup) {
    ranges.emplace_back(slot.first, slot.first + slot.second, group.first + " /" + std::to_string(group.second) + "B");
  }
  std::sort(ranges.begin(), ranges.end());
  for (size_t i = 1; i < ranges.size(); ++i) {
    EXPECT_LE(std::get<1>(ranges[i - 1]), std::get<0>(ranges[i]))
        << "different keys share slots: '" << std::get<2>(ranges[i - 1]) << "' and '" << std::get<2>(ranges[i]) << "'";
  }
}

// A shader that declares set 7 binding 0 (the counters' default) is refused in
// every mode and width, and accepted once the counters move elsewhere.
void checkRefused(const CorpusShader& shader) {
  for (auto target : {glsl::Target::Vulkan10, glsl::Target::Vulkan13}) {
    SCOPED_TRACE(targetName(target));
    auto words = compileCorpus(shader, target);
    ASSERT_TRUE(words.ok()) << words.error();
    for (const auto& variant : variants()) {
      SCOPED_TRACE(variant.name());
      spirv::InstrumentOptions options;
      options.mode = variant.mode;
      options.width = variant.width;
      auto result = spirv::instrument(*words, options);
      ASSERT_FALSE(result.ok()) << shader.file << " uses set 7 binding 0 and must be refused";
      EXPECT_NE(result.error().find("set 7"), std::string::npos) << result.error();
      EXPECT_NE(result.error().find("binding 0"), std::string::npos) << result.error();
    }
    spirv::InstrumentOptions elsewhere;
    elsewhere.set = 6;
    auto moved = spirv::instrument(*words, elsewhere);
    EXPECT_TRUE(moved.ok()) << "with the counters at set 6: " << (moved.ok() ? "" : moved.error());
  }
}

class CorpusTest : public ::testing::TestWithParam<CorpusShader> {};

TEST_P(CorpusTest, SitesMatchExpectation) {
  const CorpusShader& shader = GetParam();
  ASSERT_NE(shader.stage, Stage::Other) << "bad corpus entry or file name: " << shader.file;
  ASSERT_TRUE(fs::exists(fs::path(TALLY_CORPUS_DIR) / shader.file)) << shader.file << " not in the corpus folder";
  if (shader.refused) {
    checkRefused(shader);
    return;
  }
  ASSERT_FALSE(shader.expected.empty()) << shader.file << " has no expected keys";
  ASSERT_EQ(shader.expected.count("invocation"), 1u) << "every shader has an invocation site";

  const auto modes = variants();
  ASSERT_EQ(modes.size(), 17u);
  for (auto target : {glsl::Target::Vulkan10, glsl::Target::Vulkan13}) {
    if (target == glsl::Target::Vulkan10 && shader.vulkan13Only) continue;
    SCOPED_TRACE(std::string(targetName(target)));
    auto words = compileCorpus(shader, target);
    ASSERT_TRUE(words.ok()) << words.error();
    ASSERT_EQ(spirv::validate(*words), std::nullopt) << "glslang output does not validate";
    const bool debugInfo = TALLY_CORPUS_DEBUG_INFO && target == glsl::Target::Vulkan13;
    std::optional<std::set<std::string>> firstKeys;

    for (const auto& variant : modes) {
      SCOPED_TRACE(variant.name());
      spirv::InstrumentOptions options;
      options.mode = variant.mode;
      options.width = variant.width;
      options.footprintBlockBytes = variant.footprint;
      options.countArithmetic = variant.arithmetic;
      // Every other variant keeps early fragment tests where safe, as the layer does: its outputs validate too.
      options.earlyFragmentTests = (&variant - modes.data()) % 2 == 1;
      auto result = spirv::instrument(*words, options);
      ASSERT_TRUE(result.ok()) << shader.file << ": " << result.error();
      const spirv::Instrumented& r = *result;
      // Footprint: marked sites only with it on; with it on, a site that is
      // not marked has a note naming what the model does not cover.
      size_t marked = 0, unmarkedAccesses = 0;
      for (const auto& s : r.sites) {
        marked += s.footprint;
        unmarkedAccesses += !s.footprint && s.kind != SiteKind::Invocation;
      }
      if (variant.footprint == 0) {
        EXPECT_EQ(marked, 0u) << "footprint marks without footprint on";
      } else if (unmarkedAccesses > 0) {
        bool noted = std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& n) {
          return n.starts_with("footprint: ") && n.ends_with(" not measured");
        });
        EXPECT_TRUE(noted) << unmarkedAccesses << " accesses without footprint and no note saying why";
      }

      // Valid, and really rewritten.
      auto error = spirv::validate(r.words);
      EXPECT_EQ(error, std::nullopt) << "instrumented module does not validate: " << error.value_or("");
      EXPECT_NE(r.words, *words) << "instrumented module is identical to the input";

      // Keys.
      std::set<std::string> actual;
      size_t invocations = 0;
      for (const auto& s : r.sites) {
        actual.insert(siteKey(s));
        if (s.kind == SiteKind::Invocation) ++invocations;
        EXPECT_EQ(s.stage, shader.stage) << describe(s);
        if (s.kind == SiteKind::OutputWrite) {
          EXPECT_EQ(shader.stage, Stage::Fragment) << "output_write outside a fragment shader: " << describe(s);
        }
        if (s.set == -1 && s.binding == -1 && isBuffer(s.kind) && !s.location) {
          EXPECT_EQ(s.resource, "physical_storage_buffer") << describe(s);
        }
        if (debugInfo && isAccess(s.kind) && !s.location) {  // vertex inputs have no source line
          EXPECT_GT(s.line, 0u) << "no OpLine source line with debug info: " << describe(s);
        }
      }
      EXPECT_EQ(invocations, 1u) << "exactly one invocation site per entry point";
      if (!firstKeys) {
        // The expectation is compared once per target (the first mode/width)...
        firstKeys = actual;
        if (actual != shader.expected) {
          std::set<std::string> missing, unexpected;
          std::set_difference(shader.expected.begin(), shader.expected.end(), actual.begin(), actual.end(),
                              std::inserter(missing, missing.end()));
          std::set_difference(actual.begin(), actual.end(), shader.expected.begin(), shader.expected.end(),
                              std::inserter(unexpected, unexpected.end()));
          std::string all;
          for (const auto& s : r.sites) all += "\n    " + describe(s);
          for (const auto& n : r.notes) all += "\n    note: " + n;
          ADD_FAILURE() << shader.file << ": site keys differ from corpus_expected.txt\n  missing:" << join(missing)
                        << "\n  unexpected:" << join(unexpected) << "\n  all sites:" << all;
        }
      } else {
        // ...and every other mode and width must find the same sites.
        EXPECT_EQ(actual, *firstKeys) << "site keys depend on the mode or counter width:\n  this:" << join(actual)
                                      << "\n  first:" << join(*firstKeys);
      }

      // Slots.
      checkSlots(r, options.firstSlot);

      // firstSlot = 100 shifts every slot by exactly 100.
      spirv::InstrumentOptions shifted = options;
      shifted.firstSlot = 100;
      auto moved = spirv::instrument(*words, shifted);
      ASSERT_TRUE(moved.ok()) << "firstSlot=100: " << moved.error();
      ASSERT_EQ(moved->sites.size(), r.sites.size());
      EXPECT_EQ(moved->slotCount, r.slotCount);
      for (size_t i = 0; i < r.sites.size(); ++i) {
        EXPECT_EQ(siteKey(moved->sites[i]), siteKey(r.sites[i]));
        EXPECT_EQ(moved->sites[i].slot, r.sites[i].slot + 100) << describe(r.sites[i]);
        EXPECT_EQ(moved->sites[i].slotCount, r.sites[i].slotCount) << describe(r.sites[i]);
      }
      checkSlots(*moved, 100);

      // The output now uses the counter binding: instrumenting it again is refused.
      auto again = spirv::instrument(r.words, options);
      EXPECT_FALSE(again.ok()) << "re-instrumenting the output with the same set/binding must fail";
      if (!again.ok()) {
        EXPECT_NE(again.error().find("set 7"), std::string::npos) << again.error();
        EXPECT_NE(again.error().find("binding 0"), std::string::npos) << again.error();
      }
    }
  }
}

std::string testName(const ::testing::TestParamInfo<CorpusShader>& info) {
  std::string name = info.param.file;
  if (name.size() > 5 && name.ends_with(".glsl")) name.resize(name.size() - 5);
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return name.empty() ? "shader" + std::to_string(info.index) : name;
}

INSTANTIATE_TEST_SUITE_P(Corpus, CorpusTest, ::testing::ValuesIn(corpus()), testName);

// Output digests: the instrumented words of every corpus case (the variants
// above, plus settings they leave at their defaults), hashed and compared
// with instrumented_digests.txt, so that a restructuring of the injector is
// seen to change no word. The input is glslang's output, so a new glslang
// changes them too. After an intended change of the output (or of glslang),
// rewrite the file with TALLY_WRITE_DIGESTS=1 and review its diff.
uint64_t hashWords(const std::vector<uint32_t>& words) {
  uint64_t h = 14695981039346656037ull;  // FNV-1a, bytes little-endian
  for (uint32_t w : words) {
    for (int b = 0; b < 4; ++b) {
      h ^= (w >> (8 * b)) & 0xffu;
      h *= 1099511628211ull;
    }
  }
  return h;
}

struct DigestCase {
  std::string name;
  spirv::InstrumentOptions options;
};

// The corpus test's variants, each with and without early fragment tests,
// and the settings the corpus test leaves at their defaults: no subgroup
// stages, every flush per lane or none, unstriped compute copies, the
// footprint at every block size and with each of its dedups, and a moved
// counter binding.
std::vector<DigestCase> digestCases() {
  std::vector<DigestCase> out;
  for (const auto& variant : variants()) {
    for (bool early : {false, true}) {
      spirv::InstrumentOptions options;
      options.mode = variant.mode;
      options.width = variant.width;
      options.footprintBlockBytes = variant.footprint;
      options.countArithmetic = variant.arithmetic;
      options.earlyFragmentTests = early;
      out.push_back({variant.name() + (early ? "+early" : ""), options});
    }
  }
  auto accumulate = *spirv::parseMode("accumulate");
  auto add = [&](const std::string& name, auto&& change) {
    spirv::InstrumentOptions options;
    options.mode = accumulate;
    change(options);
    out.push_back({name, options});
  };
  add("accumulate/no-subgroup-stages", [](auto& o) { o.subgroupStages = 0; });
  add("accumulate/auto-lane-everywhere", [](auto& o) { o.autoLaneStages = spirv::kAllStages; });
  add("accumulate/auto-lane-nowhere", [](auto& o) { o.autoLaneStages = 0; });
  add("accumulate/copies:1", [](auto& o) { o.computeCopies = 1; });
  // Long descriptor arrays' caches flushed by partitioning the subgroup
  // (VK_NV_shader_subgroup_partitioned, the study's), in the per-lane and reduced flushes.
  add("accumulate/partitioned", [](auto& o) {
    o.partitionedStages = spirv::kAllStages;
    o.study = spirv::kStudyPartitioned;
  });
  add("accumulate/partitioned+auto-lane-nowhere", [](auto& o) {
    o.partitionedStages = spirv::kAllStages;
    o.study = spirv::kStudyPartitioned;
    o.autoLaneStages = 0;
  });
  add("accumulate/copies:256/uint32_pair", [](auto& o) {
    o.computeCopies = 256;
    o.width = CounterWidth::Uint32Pair;
  });
  add("accumulate:subgroup/arithmetic/uint32_pair", [](auto& o) {
    o.mode = *spirv::parseMode("accumulate:subgroup");
    o.countArithmetic = true;
    o.width = CounterWidth::Uint32Pair;
  });
  add("accumulate:lane/arithmetic+footprint:128", [](auto& o) {
    o.mode = *spirv::parseMode("accumulate:lane");
    o.countArithmetic = true;
    o.footprintBlockBytes = 128;
  });
  add("subgroup/no-subgroup-stages", [](auto& o) {
    o.mode = *spirv::parseMode("subgroup");
    o.subgroupStages = 0;
  });
  add("sampled:16/footprint:64+early", [](auto& o) {
    o.mode = *spirv::parseMode("sampled:16");
    o.footprintBlockBytes = 64;
    o.earlyFragmentTests = true;
  });
  // What footprint marks skip: both ways (the subgroup's in every stage), and neither.
  add("accumulate/footprint:64+dedup:all", [](auto& o) {
    o.footprintBlockBytes = 64;
    o.footprintDedup = *spirv::parseFootprintDedup("all");
  });
  add("exact/footprint:32+dedup:none", [](auto& o) {
    o.mode = *spirv::parseMode("exact");
    o.footprintBlockBytes = 32;
    o.footprintDedup = *spirv::parseFootprintDedup("none");
  });
  add("exact/set:6/binding:3/first:40", [](auto& o) {
    o.mode = *spirv::parseMode("exact");
    o.set = 6;
    o.binding = 3;
    o.firstSlot = 40;
    o.footprintBlockBytes = 32;
    o.footprintTableBinding = 6;
    o.footprintBitmapBinding = 7;
  });
  return out;
}

// "case hash" per line, in corpus order; refused cases hash their error.
std::vector<std::pair<std::string, std::string>> computeDigests() {
  std::vector<std::pair<std::string, std::string>> out;
  const auto cases = digestCases();
  for (const auto& shader : corpus()) {
    if (shader.stage == Stage::Other) continue;
    for (auto target : {glsl::Target::Vulkan10, glsl::Target::Vulkan13}) {
      if (target == glsl::Target::Vulkan10 && shader.vulkan13Only) continue;
      std::string prefix = shader.file + " " + targetName(target) + " ";
      auto words = compileCorpus(shader, target);
      if (!words.ok()) {
        out.emplace_back(prefix + "compile", "error: " + words.error());
        continue;
      }
      for (const auto& c : cases) {
        auto result = spirv::instrument(*words, c.options);
        char hex[17];
        std::snprintf(hex, sizeof hex, "%016llx",
                      static_cast<unsigned long long>(result.ok() ? hashWords(result->words) : 0));
        out.emplace_back(prefix + c.name, result.ok() ? std::string(hex) : "error: " + result.error());
      }
    }
  }
  return out;
}

// The digests are the gcc build's words. A clang build numbers some of the
// footprint pass's new ids in another order (seen in the footprint cases
// only; most likely a call whose arguments each make an id, an order C++
// leaves unspecified): its words differ, so the sanitizer build (clang)
// leaves this test out (scripts/test.sh).
TEST(CorpusDigests, InstrumentedWordsMatchTheRecordedDigests) {
  const auto digests = computeDigests();
  ASSERT_GT(digests.size(), 1000u);
  if (const char* write = std::getenv("TALLY_WRITE_DIGESTS"); write != nullptr && std::string(write) == "1") {
    std::ofstream out(TALLY_CORPUS_DIGESTS, std::ios::binary);
    out << "# Digests of the instrumented corpus (tests/spirv/corpus_test.cpp, CorpusDigests):\n"
           "# shader target case, then FNV-1a 64 of the output words or the error.\n";
    for (const auto& [name, digest] : digests) out << name << " " << digest << "\n";
    ASSERT_TRUE(out.good()) << "cannot write " << TALLY_CORPUS_DIGESTS;
    GTEST_SKIP() << "wrote " << digests.size() << " digests to " << TALLY_CORPUS_DIGESTS;
  }
  std::map<std::string, std::string> recorded;
  std::ifstream in(TALLY_CORPUS_DIGESTS);
  ASSERT_TRUE(in) << "cannot open " << TALLY_CORPUS_DIGESTS;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    // The case name has spaces; the digest is the last field, or "error: ...".
    auto error = line.find(" error: ");
    auto split = error != std::string::npos ? error : line.rfind(' ');
    ASSERT_NE(split, std::string::npos) << "malformed line in " << TALLY_CORPUS_DIGESTS << ": " << line;
    recorded[line.substr(0, split)] = line.substr(split + 1);
  }
  size_t differ = 0;
  for (const auto& [name, digest] : digests) {
    auto it = recorded.find(name);
    if (it == recorded.end()) {
      ADD_FAILURE() << name << ": not in " << TALLY_CORPUS_DIGESTS;
    } else if (it->second != digest) {
      ++differ;
      ADD_FAILURE() << name << ": output differs (recorded " << it->second << ", now " << digest << ")";
    }
    if (it != recorded.end()) recorded.erase(it);
  }
  for (const auto& [name, digest] : recorded) ADD_FAILURE() << name << ": recorded but no longer computed";
  EXPECT_EQ(differ, 0u) << "of " << digests.size() << " cases";
}

// Every file in corpus/ has an expectation and vice versa; the corpus is big enough.
TEST(CorpusFiles, ExpectationsCoverTheCorpusFolder) {
  std::set<std::string> files;
  for (const auto& entry : fs::directory_iterator(TALLY_CORPUS_DIR)) {
    if (entry.path().extension() == ".glsl") files.insert(entry.path().filename().string());
  }
  std::set<std::string> listed;
  std::map<Stage, int> perStage;
  for (const auto& s : corpus()) {
    EXPECT_TRUE(listed.insert(s.file).second) << "listed twice: " << s.file;
    ++perStage[s.stage];
  }
  for (const auto& f : files) EXPECT_TRUE(listed.count(f)) << f << " has no entry in corpus_expected.txt";
  for (const auto& f : listed) EXPECT_TRUE(files.count(f)) << f << " is listed but not in corpus/";
  EXPECT_GE(files.size(), 32u);
  // The reserved-binding shader is there and expected to be refused.
  auto reserved = std::find_if(corpus().begin(), corpus().end(),
                               [](const CorpusShader& s) { return s.file == "reserved_binding.frag.glsl"; });
  ASSERT_NE(reserved, corpus().end()) << "reserved_binding.frag.glsl missing from corpus_expected.txt";
  EXPECT_TRUE(reserved->refused);
  EXPECT_GE(perStage[Stage::Vertex], 3);
  EXPECT_GE(perStage[Stage::Fragment], 3);
  EXPECT_GE(perStage[Stage::Compute], 3);
}

}  // namespace
}  // namespace tally
