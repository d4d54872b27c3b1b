// A result JSON into ingest: store::Store::ingestCapture for a queued job,
// in a SQLite store in memory. Ingest replaces the job's previous runs, so
// the store stays the size of one result.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/store.hpp"

namespace {

using namespace tally;

std::unique_ptr<store::Store> db;
int64_t jobId = 0;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  auto opened = store::Store::open(":memory:");
  if (!opened.ok()) {
    std::fprintf(stderr, "fuzz_ingest: %s\n", opened.error().c_str());
    std::abort();
  }
  db = std::move(*opened);
  auto job = db->jobs().create({{"renderers", {"forward"}}});
  if (!job.ok()) {
    std::fprintf(stderr, "fuzz_ingest: %s\n", job.error().c_str());
    std::abort();
  }
  jobId = job->job.id;
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto result = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (result.is_discarded()) return 0;
  // A one-pixel PNG's signature stands for any screenshot the result names.
  static const std::map<std::string, std::vector<uint8_t>> screenshots = {
      {"0.png", {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'}}};
  auto stored = db->runs().ingestCapture(jobId, result, screenshots);
  (void)stored;
  return 0;
}
