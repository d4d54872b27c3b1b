// A stored sample as a trace in the Chrome trace-event JSON format (opens in
// the Perfetto UI and chrome://tracing): GET /api/samples/{id}/trace and
// `tally export --trace`. Pure: store rows in, JSON out.
//
// Layout (docs/api.md, "Trace export"): one process named after the run
// (variant, scene, resolution, device, host) with one thread "GPU". Each
// uninstrumented frame is a complete slice ("X") "frame N", laid end to end
// with the measured frame times; each pass is a slice nested inside its
// frame, laid end to end from the frame's start, lasting that frame's
// gpu_ms_frames entry. Without stored per-frame times every frame and pass
// lasts its median (metadata.frame_times "medians", else "measured"). A pass
// that would end after its frame is cut at the frame's end (its args keep the
// measured time; metadata.clipped_passes counts them), so slices nest.
// Counter events ("C"), one series per resource, give its bytes per frame
// (read + write, summed over passes) at each frame's start. Times are in
// microseconds (whole nanoseconds, so nesting survives the conversion).
// Where the sample has per-site counts, each pass slice's args carry
// "top_lines": its heaviest source lines (topLines, by pass position).
#pragma once

#include <map>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/store.hpp"

namespace tally::service {

// {"traceEvents": [...], "displayTimeUnit": "ms", "metadata": {...}}.
nlohmann::json sampleTrace(const store::RunRow& run, const store::Sample& sample,
                           const std::map<int, std::vector<store::SiteRow>>& topLines = {});

}  // namespace tally::service
