// The tally subcommands, one function each: they take parsed options, call
// tallyd through ApiClient and print. Return the process exit code
// (0 success, 1 failure with a one-line reason on err).
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "api_client.hpp"
#include "colour.hpp"

namespace tally::client {

struct Io {
  std::ostream& out;
  std::ostream& err;
  bool json = false;         // --json: print the server's JSON instead of tables
  bool progressTty = false;  // redraw the progress bar in place (stderr is a terminal)
  Colour colour;             // of tables on out (--color; off: plain text)
};

struct CaptureArgs {
  std::string spec;  // a file, or "-" for stdin
  bool noWait = false;
  std::string idempotencyKey;
  double intervalS = 1.0;  // between status polls
  std::vector<std::string> labels;  // --label NAME=VALUE, added to the spec's "labels"
};
// The spec with `labels` (NAME=VALUE each) added to its "labels", or the one that is wrong.
Result<nlohmann::json> withLabels(nlohmann::json spec, const std::vector<std::string>& labels);
int runCapture(ApiClient& api, const CaptureArgs& args, Io& io);

// `tally profile -- COMMAND ARGS...`: an application capture spec built from
// flags (docs/layer.md), submitted and followed as `tally capture` does.
struct ProfileArgs {
  std::vector<std::string> command;  // the application and its arguments; empty with replay
  std::string replay;                // a GFXReconstruct capture file instead
  int frames = 10;
  int skipFrames = 0;
  int frameSubmits = 0;  // 0: frames end at present
  bool xvfb = false;
  std::string name;
  std::vector<std::string> env;  // KEY=VALUE
  int timeoutS = 0;              // 0: the server's default
  std::string counting;          // "" : the server's default (accumulate)
  CaptureArgs capture;           // --no-wait, --idempotency-key, --interval
};
// The spec, or the flag that is wrong.
Result<nlohmann::json> profileSpec(const ProfileArgs& args);
int runProfile(ApiClient& api, const ProfileArgs& args, Io& io);

// One job when id is set, else the job list.
int runStatus(ApiClient& api, const std::string& id, Io& io);
int runCancel(ApiClient& api, const std::string& id, Io& io);
// The daemons that share the store: device, build, heartbeat, jobs.
int runHosts(ApiClient& api, Io& io);

// The arguments of a listing: its filters, a page size, or every page.
template <class Filters>
struct ListArgs {
  Filters filters;
  std::optional<int> limit;
  bool all = false;  // follow next_cursor to the end
};
using RunsArgs = ListArgs<RunFilters>;
int runRuns(ApiClient& api, const RunsArgs& args, Io& io);
int runShow(ApiClient& api, const std::string& runId, Io& io);
struct CompareArgs {
  std::vector<std::string> runs;
  std::optional<double> confidence;  // of the intervals; the server's default 0.95
  std::optional<double> threshold;   // practical threshold on |ratio - 1|; default 0
  bool framesOnly = false;           // no widening by repeated captures' spread
  bool pooled = false;               // raw frames pooled, not aligned per camera
};
// The comparison table, then each later run's significance against the first
// (times tested over per-frame times, counts exact).
int runCompare(ApiClient& api, const CompareArgs& args, Io& io);

// `tally crossover CAPTURE`: each variant's fit y = a + b * pixels with its
// intervals, R² and residuals, and where pairs of variants cross.
struct CrossoverArgs {
  std::string capture;
  std::string metric = "bytes";  // or frame_ms
};
int runCrossover(ApiClient& api, const CrossoverArgs& args, Io& io);

// `tally heatmap CAPTURE --renderer A [--versus B]`: a heatmap capture's
// map as a text grid (client/heatmap.cpp) and a summary: where B gains and
// loses most (lowest and highest ratio), by how much, and how many cells differ
// significantly.
struct HeatmapArgs {
  std::string capture;
  std::string renderer;
  std::string versus;             // "": one renderer's values
  std::string metric = "frame_ms";  // or bytes
  std::string yaw = "mean";       // mean | worst | a yaw index
  std::string scene;              // "": the capture's one heatmap scene
  std::optional<int> width, height;
  std::string counting;
};
int runHeatmap(ApiClient& api, const HeatmapArgs& args, Io& io);

using SweepsArgs = ListArgs<SweepFilters>;
int runSweeps(ApiClient& api, const SweepsArgs& args, Io& io);
// Its threshold, where it fails (fails_at) and its points.
int runSweep(ApiClient& api, const std::string& sweepId, Io& io);

struct ExportArgs {
  std::string format = "csv";
  RunFilters filters;
  std::string output;  // empty: stdout; else written atomically (temp file + rename)
  // A sample id: export that sample as a Chrome trace-event JSON trace
  // (GET /api/samples/{id}/trace) instead of runs; no filters, no format.
  std::optional<std::string> trace;
};
int runExport(ApiClient& api, const ExportArgs& args, Io& io);

// Baselines and alerts (docs/api.md, "Baselines and alerts").
struct BaselineSetArgs {
  std::string run;
  std::optional<double> threshold;  // the server's default (0.05) when absent
  std::optional<std::string> name;
};
int runBaselineSet(ApiClient& api, const BaselineSetArgs& args, Io& io);
int runBaselineList(ApiClient& api, bool all, Io& io);
int runBaselineRemove(ApiClient& api, const std::string& id, Io& io);
struct AlertsArgs {
  std::optional<std::string> status;    // open | acknowledged | invalid | fixed
  std::optional<std::string> baseline;  // a baseline id
  std::optional<int> limit;
};
int runAlerts(ApiClient& api, const AlertsArgs& args, Io& io);
// Sets an alert's status (ack: acknowledged).
int runAlertStatus(ApiClient& api, const std::string& id, const std::string& status, Io& io);

// Writes data to path via a temporary file in the same folder and rename().
Result<bool> writeFileAtomically(const std::string& path, const std::string& data);

}  // namespace tally::client
