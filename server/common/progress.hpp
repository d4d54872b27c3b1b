// Progress of a long piece of work (a capture matrix, a sweep), reported to
// the job queue and the CLI as it goes.
#pragma once

#include <cstddef>
#include <string>

namespace tally {

struct Progress {
  size_t done = 0;      // steps finished
  size_t total = 0;     // steps in all
  std::string current;  // what runs now: "deferred atrium 320x180 camera 3"
};

}  // namespace tally
