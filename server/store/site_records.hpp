// The store's records of sites, draws and materials (migration 0011;
// docs/result-schema.md, "Sites, draws and materials"): what Runs::sites,
// Runs::draws and Runs::shaderSources read. Bytes and counts are per frame,
// averaged over the sample's counted frames, like counters.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace tally::store {

// What ingest keeps of a pass (documented in docs/result-schema.md, "Limits").
inline constexpr size_t kMaxSitesPerPass = 4096;      // more is refused
inline constexpr size_t kMaxDrawsPerPass = 256;       // the heaviest kept, the rest summed
inline constexpr size_t kMaxMaterialsPerPass = 4096;  // more is refused
inline constexpr size_t kMaxShadersPerRun = 256;      // more is refused
inline constexpr size_t kMaxShaderSourceBytes = size_t{1} << 20;  // 1 MiB; a larger text is refused

// One pass of a sample and its requested bytes (the sum over its lines), the
// denominator of every share.
struct PassBytes {
  int position = 0;
  std::string name;
  double bytes = 0;
  int64_t sites = 0, draws = 0, materials = 0;  // rows stored for the pass
};

// Sites one by one, or summed per source line (sites without a line stay
// one row each, keyed by their instruction).
enum class SiteGrouping { Site, Line };

struct SiteQuery {
  std::optional<std::string> pass;  // one pass by name; every pass when absent
  SiteGrouping grouping = SiteGrouping::Site;
  int64_t limit = 100;  // 1..1000
  int64_t offset = 0;
};

struct SiteRow {
  int passPosition = 0;
  std::string pass;
  std::string shader, stage, entryPoint;
  std::optional<int64_t> instruction;  // SPIR-V result id; absent where the result gave none. By line: the heaviest site's
  std::string opcode;       // by line: the heaviest site's
  std::string resource, access;  // by line: the heaviest site's
  std::optional<std::string> kind, file;
  std::optional<int64_t> line;
  std::string disassembly;  // by line: the heaviest site's
  double count = 0, bytes = 0;
  int64_t sites = 1;  // by line: how many sites the row sums
  // By line: every resource line the row's sites touch ("name (read)"), by bytes.
  std::vector<std::string> resources;
};

struct SitePage {
  std::vector<PassBytes> passes;  // every pass of the sample, in frame order
  std::vector<SiteRow> rows;      // by bytes, heaviest first (ties: pass order, then result order)
  int64_t total = 0;              // rows before paging
};

struct DrawRow {
  int passPosition = 0;
  std::string pass;
  int64_t rank = 0;   // within its pass, 0 the heaviest
  int64_t index = 0;  // the draw's position in the frame (recording order)
  std::string name;
  std::optional<std::string> mesh, material;
  double count = 0, bytesRead = 0, bytesWritten = 0, bytes = 0;
};

// The draws of a pass beyond the kept ones, summed.
struct DrawRest {
  int passPosition = 0;
  std::string pass;
  int64_t draws = 0;
  double count = 0, bytesRead = 0, bytesWritten = 0, bytes = 0;
};

struct MaterialRow {
  int passPosition = 0;
  std::string pass;
  std::string material;
  int64_t draws = 0;
  double bytesRead = 0, bytesWritten = 0, bytes = 0;
};

struct DrawQuery {
  std::optional<std::string> pass;
  bool byMaterial = false;
  int64_t limit = 100;  // 1..1000
  int64_t offset = 0;
};

struct DrawPage {
  std::vector<PassBytes> passes;
  std::vector<DrawRow> draws;          // by bytes, heaviest first (empty by material)
  std::vector<MaterialRow> materials;  // by bytes, heaviest first (only by material)
  std::vector<DrawRest> rests;         // every selected pass's rest, whatever the page
  int64_t total = 0;
};

struct ShaderSource {
  std::string name, hash;
  int64_t length = 0;  // bytes
  int64_t lines = 0;
  std::string text;  // empty in lists
};

}  // namespace tally::store
