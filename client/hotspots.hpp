// `tally hotspots RUN`: where a sample's bytes go, per pass, by source line,
// draw or material (GET /api/samples/{id}/sites and /draws; docs/api.md,
// "Sites, draws and shaders"), heaviest first with their share of the pass,
// the rest summed, so that every pass's shares add up to 100 %.
#pragma once

#include <string>

#include "commands.hpp"

namespace tally::client {

struct HotspotsArgs {
  std::string run;
  std::string pass;         // "": every pass with rows
  std::string by = "line";  // line | draw | material
  int top = 10;             // rows shown per pass; the rest summed
  std::string sample;       // a sample id of the run; "": its first camera's
};
int runHotspots(ApiClient& api, const HotspotsArgs& args, Io& io);

}  // namespace tally::client
