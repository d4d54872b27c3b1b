#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>

#include "commands/commands.hpp"
#include "spirv/instrument.hpp"

namespace tally::cli {
namespace {

Result<std::vector<uint8_t>> readAll(const std::string& path) {
  std::vector<uint8_t> bytes;
  if (path == "-") {
    bytes.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
    return bytes;
  }
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return makeError("is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError("cannot open for reading");
  bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return bytes;
}

// Write to a temporary file beside the target, then rename: a reader never
// sees a half-written module.
Result<bool> writeAtomically(const std::string& path, const std::vector<uint32_t>& words) {
  std::string temp = path + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) return makeError("cannot open for writing");
    out.write(reinterpret_cast<const char*>(words.data()), static_cast<std::streamsize>(words.size() * 4));
    out.flush();
    if (!out) return makeError("write failed");
  }
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::filesystem::remove(temp, ec);
    return makeError("cannot replace: " + ec.message());
  }
  return true;
}

}  // namespace

int runInstrument(const InstrumentArgs& args) {
  auto fail = [&](const std::string& where, const std::string& message) {
    std::cerr << "tallyd instrument: " << where << ": " << message << "\n";
    return 1;
  };
  auto mode = spirv::parseMode(args.mode);
  if (!mode) return fail("--mode", mode.error());
  spirv::InstrumentOptions options;
  options.mode = *mode;
  options.set = args.set;
  options.binding = args.binding;
  options.firstSlot = args.firstSlot;
  options.computeCopies = args.computeCopies;
  if (args.partitioned) {
    options.partitionedStages = spirv::kAllStages;
    options.study |= spirv::kStudyPartitioned;
  }
  options.footprintBlockBytes = args.footprintBlockBytes;
  options.perSite = args.perSite;
  options.footprintTableBinding = args.binding + 1;
  options.footprintBitmapBinding = args.binding + 2;
  if (args.width == "int64") {
    options.width = spirv::CounterWidth::Int64;
  } else if (args.width == "uint32_pair") {
    options.width = spirv::CounterWidth::Uint32Pair;
  } else {
    return fail("--width", "unknown counter width '" + args.width + "' (expected int64 or uint32_pair)");
  }
  if (!args.analyzeOnly && args.output.empty()) return fail("-o", "an output path is required (or --analyze)");

  auto bytes = readAll(args.input);
  if (!bytes) return fail(args.input, bytes.error());
  auto words = spirv::wordsFromBytes(*bytes);
  if (!words) return fail(args.input, words.error());
  auto result = args.analyzeOnly ? spirv::analyze(*words, options) : spirv::instrument(*words, options);
  if (!result) return fail(args.input, result.error());
  if (!args.analyzeOnly) {
    auto written = writeAtomically(args.output, result->words);
    if (!written) return fail(args.output, written.error());
  }
  std::cout << spirv::toJson(*result, options).dump(2) << "\n";
  return 0;
}

}  // namespace tally::cli
