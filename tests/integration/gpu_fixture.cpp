#include "gpu_fixture.hpp"

#include <cstdlib>
#include <fstream>
#include <memory>
#include <mutex>
#include <set>
#include <utility>

#include <gtest/gtest.h>

namespace tally::test {
namespace {

// Owns the context for the whole process; gtest destroys environments at exit.
class ContextEnvironment : public ::testing::Environment {
 public:
  void TearDown() override {
    if (context_) gpu::destroyContext(*context_);
    context_.reset();
  }
  const gpu::Context* get(std::string* error) {
    std::call_once(once_, [this] {
      gpu::ContextOptions options;
      if (const char* device = std::getenv("TALLY_TEST_DEVICE")) options.device = device;
      if (const char* validation = std::getenv("TALLY_VALIDATION"))
        options.validation = std::string(validation) == "1";
      auto created = gpu::createContext(options);
      if (created) {
        context_ = std::make_unique<gpu::Context>(std::move(created).value());
      } else {
        error_ = created.error();
      }
    });
    if (!context_ && error != nullptr) *error = error_;
    return context_.get();
  }

 private:
  std::once_flag once_;
  std::unique_ptr<gpu::Context> context_;
  std::string error_;
};

ContextEnvironment* environment() {
  // Registered once; gtest takes ownership.
  static ContextEnvironment* env =
      static_cast<ContextEnvironment*>(::testing::AddGlobalTestEnvironment(new ContextEnvironment));
  return env;
}

// Registers the environment before main() runs the tests, so its TearDown runs.
[[maybe_unused]] const bool kRegistered = (environment(), true);

}  // namespace

const gpu::Context* testContext(std::string* error) { return environment()->get(error); }

std::string shaderDir() {
  if (const char* dir = std::getenv("TALLY_SHADER_DIR"); dir != nullptr && *dir != '\0') return dir;
  return TALLY_INTEGRATION_SHADER_DIR;
}

namespace {
std::set<std::pair<uint32_t, uint32_t>> ranges(const std::vector<spirv::Site>& sites, spirv::SiteKind kind,
                                               spirv::Stage stage) {
  std::set<std::pair<uint32_t, uint32_t>> out;
  for (const auto& s : sites) {
    if (s.kind == kind && s.stage == stage) out.insert({s.slot, s.slotCount});
  }
  return out;
}
}  // namespace

uint64_t sumKind(const std::vector<spirv::Site>& sites, const std::vector<uint64_t>& counters,
                 spirv::SiteKind kind, spirv::Stage stage) {
  uint64_t sum = 0;
  for (auto [slot, count] : ranges(sites, kind, stage)) {
    for (uint32_t i = slot; i < slot + count && i < counters.size(); ++i) sum += counters[i];
  }
  return sum;
}

size_t slotRanges(const std::vector<spirv::Site>& sites, spirv::SiteKind kind, spirv::Stage stage) {
  return ranges(sites, kind, stage).size();
}

TileShape tileShape(uint32_t n) {
  uint32_t th = 1;
  for (uint32_t d = 1; uint64_t(d) * d <= n; ++d) {
    if (n % d == 0) th = d;
  }
  return {n / th, th};
}

uint64_t partialTiles(uint32_t width, uint32_t height, TileShape tile) {
  bool partialX = width % tile.width != 0;
  bool partialY = height % tile.height != 0;
  uint64_t tilesX = (width + tile.width - 1) / tile.width;
  uint64_t tilesY = (height + tile.height - 1) / tile.height;
  return (partialX ? tilesY : 0) + (partialY ? tilesX : 0) - (partialX && partialY ? 1 : 0);
}

uint64_t sampledBound(const spirv::Mode& mode, uint32_t width, uint32_t height,
                      uint64_t accessesPerInvocation) {
  if (mode.kind != spirv::CountMode::Sampled) return 0;
  return uint64_t(mode.sampleRate) * accessesPerInvocation *
         partialTiles(width, height, tileShape(mode.sampleRate));
}

void appendStatsLine(const nlohmann::json& line) {
  static std::mutex mutex;
  std::lock_guard lock(mutex);
  std::ofstream out("exactness_stats.json", std::ios::app);
  out << line.dump() << "\n";
}

std::string modeLabel(const spirv::Mode& mode, spirv::CounterWidth width) {
  std::string label = spirv::toString(mode);
  if (width == spirv::CounterWidth::Uint32Pair) label += "/uint32_pair";
  return label;
}

std::vector<std::pair<spirv::Mode, spirv::CounterWidth>> exactModes(const gpu::Context& ctx) {
  using spirv::CounterWidth;
  const std::pair<const char*, CounterWidth> all[] = {
      {"exact", CounterWidth::Int64},          {"exact", CounterWidth::Uint32Pair},
      {"subgroup", CounterWidth::Int64},       {"accumulate", CounterWidth::Int64},
      {"accumulate", CounterWidth::Uint32Pair}, {"accumulate:subgroup", CounterWidth::Int64},
      {"accumulate:subgroup", CounterWidth::Uint32Pair}, {"accumulate:lane", CounterWidth::Int64},
      {"accumulate:lane", CounterWidth::Uint32Pair}};
  std::vector<std::pair<spirv::Mode, CounterWidth>> out;
  for (const auto& [name, width] : all) {
    if (width == CounterWidth::Int64 && !ctx.int64Atomics) continue;
    out.emplace_back(*spirv::parseMode(name), width);
  }
  return out;
}

}  // namespace tally::test
