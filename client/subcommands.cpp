// The tally subcommands' flags and what each runs, by command group.
#include "subcommands.hpp"

#include "hotspots.hpp"

namespace tally::client {
namespace {

void addFilters(CLI::App* sub, RunFilters& f) {
  sub->add_option("--renderer", f.renderer, "Only this renderer (e.g. deferred)");
  sub->add_option("--variant", f.variant, "Only this variant, its exact label (e.g. \"visbuffer barycentrics=float32\")");
  sub->add_option("--scene", f.scene, "Only this scene (e.g. atrium)");
  sub->add_option("--width", f.width, "Only this width in pixels")->check(CLI::PositiveNumber);
  sub->add_option("--height", f.height, "Only this height in pixels")->check(CLI::PositiveNumber);
  sub->add_option("--device", f.device, "Only this device (its exact name, or its id)");
  sub->add_option("--capture", f.capture, "Only runs of this capture id");
}

}  // namespace

const Subcommands::Entry* Subcommands::parsed() const {
  for (const auto& entry : entries_) {
    if (entry.sub->parsed()) return &entry;
  }
  return nullptr;
}

void addCaptureCommands(CLI::App& app, Subcommands& subcommands) {
  CaptureArgs& capture = subcommands.hold<CaptureArgs>();
  auto* cap =
      app.add_subcommand("capture", "Submit a capture spec and follow its progress until it finishes");
  cap->add_option("--spec", capture.spec,
                  "Capture spec JSON file, or - for stdin (docs/result-schema.md); a spec with \"sweep\" runs a "
                  "stability sweep")
      ->required();
  cap->add_option("--label", capture.labels,
                  "NAME=VALUE added to the spec's \"labels\" (repeatable): commit, branch, ... shown on its runs");
  cap->add_flag("--no-wait", capture.noWait, "Print the capture id and exit without waiting");
  cap->add_option("--idempotency-key", capture.idempotencyKey,
                  "A key that makes resubmitting the same capture return the first one");
  cap->add_option("--interval", capture.intervalS, "Seconds between status polls")
      ->check(CLI::Range(0.01, 3600.0));
  cap->footer(
      "Exit status: 0 when the capture is done, 1 when it failed or was cancelled.\n"
      "Example:\n  tally capture --spec atrium.json\n  echo '{\"renderers\":[\"forward\"],"
      "\"resolutions\":[[320,180]]}' | tally capture --spec - --no-wait\n"
      "  tally capture --spec atrium.json --label commit=$(git rev-parse --short HEAD) --label branch=main");

  ProfileArgs& profile = subcommands.hold<ProfileArgs>();
  auto* prof = app.add_subcommand(
      "profile", "Capture an application (or a GFXReconstruct replay) under the Tally Vulkan layer (docs/layer.md)");
  prof->add_option("command", profile.command, "The application and its arguments, after --");
  prof->add_option("--replay", profile.replay, "A GFXReconstruct capture file (on the daemon's host) to replay instead");
  prof->add_option("--frames", profile.frames, "Frames to read back (1..1000)")->check(CLI::Range(1, 1000));
  prof->add_option("--skip-frames", profile.skipFrames, "Frames to let pass first")->check(CLI::NonNegativeNumber);
  prof->add_option("--frame-submits", profile.frameSubmits,
                   "For applications that never present: a frame is this many submissions with draws or dispatches")
      ->check(CLI::NonNegativeNumber);
  prof->add_flag("--xvfb", profile.xvfb, "Run it under a virtual X server on the daemon's host");
  prof->add_option("--name", profile.name, "The run's name (app:NAME); default the application's");
  prof->add_option("--env", profile.env, "KEY=VALUE for the application (repeatable)");
  prof->add_option("--timeout-s", profile.timeoutS, "Seconds the application may take (1..3600)")
      ->check(CLI::Range(1, 3600));
  prof->add_option("--counting", profile.counting, "accumulate (default) or exact");
  prof->add_flag("--no-wait", profile.capture.noWait, "Print the capture id and exit without waiting");
  prof->add_option("--idempotency-key", profile.capture.idempotencyKey,
                   "A key that makes resubmitting the same capture return the first one");
  prof->add_option("--interval", profile.capture.intervalS, "Seconds between status polls")
      ->check(CLI::Range(0.01, 3600.0));
  prof->footer(
      "The daemon must run with --allow-applications; the application runs on its host. $TALLY_TOKEN\n"
      "must be the daemon's application token, the program must lie in one of its --application-root\n"
      "folders, and --env may set only the variables it allows (docs/operating.md, \"Security model\").\n"
      "Exit status: 0 when the capture is done, 1 when it failed or was cancelled.\n"
      "Example:\n  tally profile --xvfb --skip-frames 20 --frames 10 -- vkcube --c 100\n"
      "  tally profile --frame-submits 1 --frames 5 -- ./my-compute-app --iterations 50");

  std::string& statusId = subcommands.hold<std::string>();
  auto* status = app.add_subcommand(
      "status",
      "Show one capture job (its host, attempts and why an earlier one ended, why it waits), or list them");
  status->add_option("ID", statusId, "Capture id (omit for the list)");
  status->footer("Example:\n  tally status\n  tally status 7");

  auto* hosts = app.add_subcommand(
      "hosts", "List the daemons that share the store: their device, build, last heartbeat and jobs");
  hosts->footer(
      "STATE: alive, or stale when no heartbeat came within the server's stale_after_s.\n"
      "Example:\n  tally hosts\n  tally hosts --json");

  std::string& cancelId = subcommands.hold<std::string>();
  auto* cancel = app.add_subcommand(
      "cancel", "Cancel a queued or running capture (a finished one is left as it is: exit status 1)");
  cancel->add_option("ID", cancelId, "Capture id")->required();
  cancel->footer("Example:\n  tally cancel 7");

  subcommands.on(cap, [&capture](ApiClient& api, Io& io) { return runCapture(api, capture, io); });
  subcommands.on(prof, [&profile](ApiClient& api, Io& io) { return runProfile(api, profile, io); });
  subcommands.on(status, [&statusId](ApiClient& api, Io& io) { return runStatus(api, statusId, io); });
  subcommands.on(cancel, [&cancelId](ApiClient& api, Io& io) { return runCancel(api, cancelId, io); });
  subcommands.on(hosts, [](ApiClient& api, Io& io) { return runHosts(api, io); });
}

void addRunCommands(CLI::App& app, Subcommands& subcommands) {
  RunsArgs& runs = subcommands.hold<RunsArgs>();
  auto* runsCmd =
      app.add_subcommand("runs", "List runs (renderer x scene x resolution on a device), newest first");
  addFilters(runsCmd, runs.filters);
  runsCmd->add_option("--host", runs.filters.host,
                      "Only runs captured on this host (its exact name; see `tally hosts`)");
  runsCmd->add_option("--label", runs.filters.label, "Only runs of captures with this label, NAME=VALUE");
  runsCmd->add_option("--limit", runs.limit, "Page size (1..1000)")->check(CLI::Range(1, 1000));
  runsCmd->add_flag("--all", runs.all, "Fetch every page");
  runsCmd->footer(
      "Example:\n  tally runs --renderer visbuffer --scene atrium --width 1920 --height 1080 --all\n"
      "  tally runs --host gpu-a");

  std::string& showId = subcommands.hold<std::string>();
  auto* show = app.add_subcommand("show", "Show a run and its samples (one per camera)");
  show->add_option("RUN", showId, "Run id")->required();
  show->footer("Example:\n  tally show 12");

  CompareArgs& compareArgs = subcommands.hold<CompareArgs>();
  auto* compare = app.add_subcommand(
      "compare", "Compare 2 to 4 runs per pass and per resource, against the first, with each difference's significance");
  compare->add_option("RUN", compareArgs.runs, "Run ids (2 to 4); deltas and ratios are against the first")
      ->required()
      ->expected(2, 4);
  compare->add_option("--confidence", compareArgs.confidence, "Level of the intervals (default 0.95); alpha = 1 - it")
      ->check(CLI::Range(0.5, 0.999999));
  compare->add_option("--threshold", compareArgs.threshold,
                      "Practical threshold: faster or slower also needs |ratio - 1| above it (default 0)")
      ->check(CLI::Range(0.0, 10.0));
  compare->add_flag("--frames-only", compareArgs.framesOnly,
                    "Do not widen intervals by the spread of repeated captures of the runs' configurations");
  compare->add_flag("--pooled", compareArgs.pooled,
                    "Pool the raw frames of all cameras instead of aligning each camera's on its median");
  compare->footer("Example:\n  tally compare 12 15\n  tally compare 12 15 --confidence 0.99 --threshold 0.02");

  CrossoverArgs& crossoverArgs = subcommands.hold<CrossoverArgs>();
  auto* crossoverCmd = app.add_subcommand(
      "crossover", "Fit each renderer's bytes or frame time against pixel count over a capture, and where they cross");
  crossoverCmd->add_option("CAPTURE", crossoverArgs.capture, "Capture id (a capture over several resolutions)")
      ->required();
  crossoverCmd->add_option("--metric", crossoverArgs.metric, "bytes (per frame) or frame_ms")
      ->check(CLI::IsMember({"bytes", "frame_ms"}))
      ->capture_default_str();
  crossoverCmd->footer(
      "Model: y = a + b * pixels by least squares, 95% t intervals; the crossing (a2 - a1) / (b1 - b2) with a\n"
      "Fieller interval, also as the 16:9 resolution of that pixel count (docs/measurement.md, \"Crossover\").\n"
      "Example:\n  tally crossover 7\n  tally crossover 7 --metric frame_ms --json");

  HeatmapArgs& heatmapArgs = subcommands.hold<HeatmapArgs>();
  auto* heatmapCmd = app.add_subcommand(
      "heatmap", "Show a camera heatmap capture: one renderer per cell, or the ratio of two and where it is significant");
  heatmapCmd->add_option("CAPTURE", heatmapArgs.capture, "Capture id (a spec with \"heatmap\")")->required();
  heatmapCmd->add_option("--renderer", heatmapArgs.renderer, "The variant measured (its label, e.g. deferred)")
      ->required();
  heatmapCmd->add_option("--versus", heatmapArgs.versus, "A second variant: cells show versus / renderer");
  heatmapCmd->add_option("--metric", heatmapArgs.metric, "frame_ms or bytes (per frame)")
      ->check(CLI::IsMember({"bytes", "frame_ms"}))
      ->capture_default_str();
  heatmapCmd->add_option("--yaw", heatmapArgs.yaw, "mean (over a cell's yaws), worst, or a yaw index")
      ->capture_default_str();
  heatmapCmd->add_option("--scene", heatmapArgs.scene, "The scene, where the capture has several");
  heatmapCmd->add_option("--width", heatmapArgs.width, "The resolution's width, where the capture has several");
  heatmapCmd->add_option("--height", heatmapArgs.height, "The resolution's height, where the capture has several");
  heatmapCmd->add_option("--counting", heatmapArgs.counting, "The counting mode, where the capture has several");
  heatmapCmd->footer(
      "A cell's time is the median frame time of its samples (the mean over its yaws with --yaw mean); with\n"
      "--versus a cell is marked * when the Mann-Whitney test and the 95% interval of the ratio of per-frame times\n"
      "both say the difference is real (docs/measurement.md, \"Camera heatmaps\").\n"
      "Example:\n  tally heatmap 9 --renderer deferred --versus visbuffer\n"
      "  tally heatmap 9 --renderer deferred --metric bytes --yaw worst --json");

  HotspotsArgs& hotspotsArgs = subcommands.hold<HotspotsArgs>();
  auto* hotspotsCmd = app.add_subcommand(
      "hotspots", "Where a run's bytes go per pass: by shader source line, draw or material, with shares of the pass");
  hotspotsCmd->add_option("RUN", hotspotsArgs.run, "Run id (captured with \"sites\": true)")->required();
  hotspotsCmd->add_option("--pass", hotspotsArgs.pass, "Only this pass (by name)");
  hotspotsCmd->add_option("--by", hotspotsArgs.by, "line, draw or material")
      ->check(CLI::IsMember({"line", "draw", "material"}))
      ->capture_default_str();
  hotspotsCmd->add_option("--top", hotspotsArgs.top, "Rows per pass; the rest summed")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  hotspotsCmd->add_option("--sample", hotspotsArgs.sample, "A sample id of the run (default: its first camera's)");
  hotspotsCmd->footer(
      "Bytes are per frame; SHARE is of the pass's bytes (all its resource lines), so each pass's rows, its rest\n"
      "and what no row covers (lines without sites, such as derived depth writes; work outside any draw) sum\n"
      "to 100 % (docs/api.md, \"Sites, draws and shaders\").\n"
      "Example:\n  tally hotspots 12\n  tally hotspots 12 --pass lighting --by material --top 5\n"
      "  tally hotspots 12 --by draw --json");

  subcommands.on(runsCmd, [&runs](ApiClient& api, Io& io) { return runRuns(api, runs, io); });
  subcommands.on(show, [&showId](ApiClient& api, Io& io) { return runShow(api, showId, io); });
  subcommands.on(compare, [&compareArgs](ApiClient& api, Io& io) { return runCompare(api, compareArgs, io); });
  subcommands.on(crossoverCmd,
                 [&crossoverArgs](ApiClient& api, Io& io) { return runCrossover(api, crossoverArgs, io); });
  subcommands.on(heatmapCmd, [&heatmapArgs](ApiClient& api, Io& io) { return runHeatmap(api, heatmapArgs, io); });
  subcommands.on(hotspotsCmd, [&hotspotsArgs](ApiClient& api, Io& io) { return runHotspots(api, hotspotsArgs, io); });
}

void addSweepAndExportCommands(CLI::App& app, Subcommands& subcommands) {
  SweepsArgs& sweeps = subcommands.hold<SweepsArgs>();
  auto* sweepsCmd = app.add_subcommand("sweeps", "List stability sweeps, newest first, with where they fail");
  sweepsCmd->add_option("--name", sweeps.filters.name, "Only this sweep (e.g. depth-reconstruction)");
  sweepsCmd->add_option("--device", sweeps.filters.device, "Only this device (its exact name, or its id)");
  sweepsCmd->add_option("--capture", sweeps.filters.capture, "Only the sweep of this capture id");
  sweepsCmd->add_option("--limit", sweeps.limit, "Page size (1..1000)")->check(CLI::Range(1, 1000));
  sweepsCmd->add_flag("--all", sweeps.all, "Fetch every page");
  sweepsCmd->footer(
      "FAILING GROUPS: per swept parameter, the groups of points whose error reaches the threshold, of all.\n"
      "Example:\n  tally sweeps --name depth-reconstruction");

  std::string& sweepId = subcommands.hold<std::string>();
  auto* sweepCmd =
      app.add_subcommand("sweep", "Show a stability sweep: its threshold, where it fails, and its points");
  sweepCmd->add_option("SWEEP", sweepId, "Sweep id")->required();
  sweepCmd->footer(
      "Submit a sweep with `tally capture --spec SPEC` (a spec with \"sweep\", docs/result-schema.md).\n"
      "Example:\n  tally sweep 3\n  tally sweep 3 --json");

  ExportArgs& exportArgs = subcommands.hold<ExportArgs>();
  auto* exportCmd =
      app.add_subcommand("export", "Export runs as CSV or JSON, exactly as the server writes it");
  auto* formatOpt =
      exportCmd->add_option("--format", exportArgs.format, "csv or json")->check(CLI::IsMember({"csv", "json"}));
  addFilters(exportCmd, exportArgs.filters);
  exportCmd->add_option("--runs", exportArgs.filters.runs, "Comma-separated run ids");
  exportCmd->add_option("-o,--output", exportArgs.output,
                        "Write to this file (atomically) instead of stdout");
  auto* traceOpt = exportCmd->add_option(
      "--trace", exportArgs.trace,
      "Export this sample as a Chrome trace-event JSON trace (open it in ui.perfetto.dev) instead of runs");
  // A trace is one sample: no run filters, no format.
  for (auto* option : exportCmd->get_options()) {
    const std::string& name = option->get_name();
    if (option != traceOpt && option != formatOpt && name.rfind("--", 0) == 0 && name != "--output" &&
        name != "--help") {
      traceOpt->excludes(option);
    }
  }
  traceOpt->excludes(formatOpt);
  exportCmd->footer(
      "Example:\n  tally export --format csv --scene atrium -o atrium.csv\n"
      "  tally export --trace 42 -o sample42.trace.json");

  subcommands.on(sweepsCmd, [&sweeps](ApiClient& api, Io& io) { return runSweeps(api, sweeps, io); });
  subcommands.on(sweepCmd, [&sweepId](ApiClient& api, Io& io) { return runSweep(api, sweepId, io); });
  subcommands.on(exportCmd, [&exportArgs](ApiClient& api, Io& io) { return runExport(api, exportArgs, io); });
}

void addAlertCommands(CLI::App& app, Subcommands& subcommands) {
  auto* baselineCmd = app.add_subcommand(
      "baseline", "Mark a run's configuration with that run as its baseline; list or remove baselines");
  baselineCmd->require_subcommand(1);
  BaselineSetArgs& baselineSet = subcommands.hold<BaselineSetArgs>();
  auto* baselineSetCmd = baselineCmd->add_subcommand(
      "set", "Make RUN the baseline of its configuration (renderer, options, scene, resolution, device, counting)");
  baselineSetCmd->add_option("RUN", baselineSet.run, "Run id")->required();
  baselineSetCmd->add_option("--threshold", baselineSet.threshold,
                             "|ratio - 1| beyond which a significant time change alerts (default 0.05)")
      ->check(CLI::Range(0.0, 10.0));
  baselineSetCmd->add_option("--name", baselineSet.name, "A name for the baseline");
  bool& baselineAll = subcommands.hold<bool>();
  auto* baselineListCmd = baselineCmd->add_subcommand("list", "List the active baselines");
  baselineListCmd->add_flag("--all", baselineAll, "Also the replaced and removed ones");
  std::string& baselineRmId = subcommands.hold<std::string>();
  auto* baselineRmCmd = baselineCmd->add_subcommand("rm", "Remove a baseline (its alerts stay)");
  baselineRmCmd->add_option("ID", baselineRmId, "Baseline id")->required();
  baselineCmd->footer(
      "New runs of a baselined configuration are tested against the baseline run: a significant change of\n"
      "frame or pass time beyond the threshold, or any change of counts, raises an alert (`tally alerts`).\n"
      "Example:\n  tally baseline set 12 --threshold 0.03\n  tally baseline list\n  tally baseline rm 2");

  AlertsArgs& alertsArgs = subcommands.hold<AlertsArgs>();
  auto* alertsCmd = app.add_subcommand("alerts", "List regression alerts, newest first; acknowledge one");
  alertsCmd->add_option("--status", alertsArgs.status, "open, acknowledged, invalid or fixed")
      ->check(CLI::IsMember({"open", "acknowledged", "invalid", "fixed"}));
  alertsCmd->add_option("--baseline", alertsArgs.baseline, "Only alerts of this baseline id");
  alertsCmd->add_option("--limit", alertsArgs.limit, "Page size (1..1000)")->check(CLI::Range(1, 1000));
  std::string& alertId = subcommands.hold<std::string>();
  std::string& alertStatus = subcommands.hold<std::string>();
  auto* alertAckCmd = alertsCmd->add_subcommand("ack", "Acknowledge an alert");
  alertAckCmd->add_option("ID", alertId, "Alert id")->required();
  auto* alertSetCmd = alertsCmd->add_subcommand("set", "Set an alert's status");
  alertSetCmd->add_option("ID", alertId, "Alert id")->required();
  alertSetCmd->add_option("STATUS", alertStatus, "open, acknowledged, invalid or fixed")
      ->required()
      ->check(CLI::IsMember({"open", "acknowledged", "invalid", "fixed"}));
  alertsCmd->footer(
      "RATIO: B / A of the medians (time) or of the total bytes (counts); INTERVAL: its 95% interval; A, B:\n"
      "the baseline's and the run's medians in ms, or total bytes per frame.\n"
      "Example:\n  tally alerts --status open\n  tally alerts ack 7\n  tally alerts set 7 invalid");

  subcommands.on(baselineSetCmd,
                 [&baselineSet](ApiClient& api, Io& io) { return runBaselineSet(api, baselineSet, io); });
  subcommands.on(baselineListCmd,
                 [&baselineAll](ApiClient& api, Io& io) { return runBaselineList(api, baselineAll, io); });
  subcommands.on(baselineRmCmd,
                 [&baselineRmId](ApiClient& api, Io& io) { return runBaselineRemove(api, baselineRmId, io); });
  // Before alerts itself: `tally alerts ack 7` parses both.
  subcommands.on(alertAckCmd,
                 [&alertId](ApiClient& api, Io& io) { return runAlertStatus(api, alertId, "acknowledged", io); });
  subcommands.on(alertSetCmd, [&alertId, &alertStatus](ApiClient& api, Io& io) {
    return runAlertStatus(api, alertId, alertStatus, io);
  });
  subcommands.on(alertsCmd, [&alertsArgs](ApiClient& api, Io& io) { return runAlerts(api, alertsArgs, io); });
}

}  // namespace tally::client
