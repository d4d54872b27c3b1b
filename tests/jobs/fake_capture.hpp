// A stand-in for `tallyd capture` in worker tests: a shell script that copies
// a prepared capture result (one run, one sample, no screenshot) to the
// --out path, so that a worker's job is a child process, an ingest and a
// finish without a device.
#pragma once

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "../store/store_fixture.hpp"

namespace tally::store::testing {

// Writes the result and the script into `dir`; the script's path.
inline std::filesystem::path writeFakeCapture(const std::filesystem::path& dir) {
  json result = makeCapture({makeRun("forward", "atrium", 64, 36,
                                     {makeSample(0, 1.5,
                                                 {makePass("gbuffer", 0.5, 2304,
                                                           {makeCounter("albedo", "read", 10, 40)})})})});
  for (auto& run : result["runs"])
    for (auto& sample : run["samples"]) sample.erase("screenshot");
  std::ofstream(dir / "result.json") << result.dump();
  std::filesystem::path script = dir / "fake-tallyd.sh";
  {
    // Called as: capture --spec SPEC --out OUT
    std::ofstream out(script);
    out << "#!/bin/sh\ncp '" << (dir / "result.json").string() << "' \"$5\"\n";
  }
  ::chmod(script.c_str(), 0755);
  return script;
}

}  // namespace tally::store::testing
