// What every sweep is run with besides its spec: where its images go and whom
// to tell how far it is. The device is the caller's (capture::runSweep opens it).
#pragma once

#include <functional>
#include <string>

#include "common/progress.hpp"

namespace tally::sweeps {

struct SweepOptions {
  std::string screenshotDir;  // PNGs of the points are written here; "" keeps none
  std::function<void(const Progress&)> progress;
};

}  // namespace tally::sweeps
