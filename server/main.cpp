// tallyd: the capture daemon. Parses flags and calls into the core library.
#include <CLI/CLI.hpp>

#include <iostream>
#include <string>

#include "commands/commands.hpp"
#include "common/version.hpp"

namespace {

// One function per subcommand: its flags, bound to its arguments.
CLI::App* addInstrument(CLI::App& app, tally::cli::InstrumentArgs& args) {
  auto* instrument = app.add_subcommand("instrument", "Instrument a SPIR-V module and print its site table as JSON");
  instrument->add_option("input", args.input, "SPIR-V module (.spv), or - for standard input")->required();
  instrument->add_option("-o,--output", args.output, "Where to write the instrumented module");
  instrument->add_option("--mode", args.mode,
                         "accumulate | accumulate:subgroup | accumulate:lane | exact | subgroup | sampled:N")
      ->capture_default_str();
  instrument->add_option("--set", args.set, "Descriptor set of the counter buffer")->capture_default_str();
  instrument->add_option("--binding", args.binding, "Binding of the counter buffer")->capture_default_str();
  instrument->add_option("--first-slot", args.firstSlot, "First counter slot")->capture_default_str();
  instrument->add_option("--width", args.width, "int64 | uint32_pair")->capture_default_str();
  instrument->add_option("--compute-copies", args.computeCopies,
                         "accumulate: copies of each compute counter (a power of two, 1 to 256; the reader sums them)")
      ->capture_default_str();
  instrument->add_option("--footprint", args.footprintBlockBytes,
                         "also mark the blocks each access touches, in blocks of this many bytes (32, 64 or 128; "
                         "0: off); the table and bitmaps bind at --binding + 1 and + 2")
      ->capture_default_str();
  instrument->add_flag("--partitioned", args.partitioned,
                       "accumulate: flush long descriptor arrays' caches by partitioning each subgroup by element "
                       "(for a device with VK_NV_shader_subgroup_partitioned; the study's 'partitioned')");
  instrument->add_flag("--analyze", args.analyzeOnly, "Print the site table without rewriting");
  instrument->add_flag("--sites", args.perSite,
                       "Give every access site counter slots of its own, and print its function, instruction and disassembly");
  return instrument;
}

CLI::App* addDemo(CLI::App& app, tally::cli::DemoArgs& args) {
  auto* demo = app.add_subcommand("demo", "Instrument the project's own shaders and print their site tables");
  demo->add_option("--shaders", args.shaderDir, "Folder of <pass>.<stage>.glsl files (default: the data folder's shaders/)");
  demo->add_option("--mode", args.mode, "exact | subgroup | sampled:N")->capture_default_str();
  return demo;
}

CLI::App* addCapture(CLI::App& app, tally::cli::CaptureArgs& args) {
  auto* capture = app.add_subcommand("capture", "Run a capture spec and write the result JSON");
  capture->add_option("--spec", args.spec, "Capture spec (JSON file, or - for standard input)")->required();
  capture->add_option("--out", args.out, "Result JSON (default: standard output)");
  capture->add_option("--device", args.device, "Device index or name substring");
  capture->add_flag("--quiet", args.quiet, "No progress lines on standard error");
  capture->add_flag("--summary", args.summary, "Print a per-pass, per-resource summary (with --out)");
  capture->add_flag(
      "--confine-applications", args.confineApplications,
      "Hold an application or replay spec to the daemon's policy: its program and replay file inside "
      "an --application-root, its env from the allowlist (what tallyd serve's worker passes)");
  capture->add_option(
      "--application-root", args.applicationRoots,
      "With --confine-applications: a folder programs and replay files may come from (repeatable)");
  capture->add_option(
      "--application-env", args.applicationEnv,
      "With --confine-applications: a variable (NAME or PREFIX*) a spec's env may set (repeatable)");
  capture->add_option("--run-as", args.runAs,
                      "Run the application as this user (tallyd must run as root)");
  return capture;
}

CLI::App* addPlay(CLI::App& app, tally::cli::PlayArgs& args) {
  auto* play = app.add_subcommand(
      "play", "Render frames of one renderer as a plain Vulkan application (names and labels through VK_EXT_debug_utils)");
  play->add_option("--renderer", args.renderer, "Renderer or workload name");
  play->add_option("--options", args.options, "Its options as a JSON object, e.g. '{\"output\":\"overdraw\"}'");
  play->add_option("--scene", args.scene, "Scene name, scene spec as JSON, or a .gltf/.glb file");
  play->add_option("--resolution", args.resolution, "WIDTHxHEIGHT, e.g. 1280x720");
  play->add_option("--frames", args.frames, "Frames to render");
  play->add_option("--camera", args.camera, "Index into the scene's automatic camera set")->capture_default_str();
  play->add_option("--device", args.device, "Device index or name substring");
  play->add_option("--lights", args.lights, "Point lights (0 to 400)")->capture_default_str();
  play->add_flag("--quiet", args.quiet, "No line per frame on standard error");
  play->add_flag("--verbose", args.verbose, "Also a line after setup: passes, descriptor sets, debug utils");
  play->add_flag("--json", args.json, "The run's summary as JSON on standard output");
  return play;
}

CLI::App* addAccuracy(CLI::App& app, tally::cli::AccuracyArgs& args) {
  auto* accuracy = app.add_subcommand("accuracy", "Counting error and overhead of each mode against exact, from a result");
  accuracy->add_option("--result", args.result, "Capture result JSON (tallyd capture --out)")->required();
  accuracy->add_flag("--json", args.json, "JSON rows instead of the table");
  return accuracy;
}

CLI::App* addRepeats(CLI::App& app, tally::cli::RepeatsArgs& args) {
  auto* repeats = app.add_subcommand("repeats", "Agreement of repeated captures of one spec, from their results");
  repeats->add_option("--result", args.results, "Capture result JSON (repeat for each capture)")->required();
  repeats->add_flag("--json", args.json, "JSON groups instead of the table");
  return repeats;
}

CLI::App* addDevice(CLI::App& app, tally::cli::DeviceArgs& args) {
  auto* deviceCmd = app.add_subcommand("device", "Show the Vulkan device captures run on (what a fleet worker registers)");
  deviceCmd->add_option("--device", args.device, "Device index or name substring");
  deviceCmd->add_flag("--json", args.json, "The device object a result records, as JSON");
  return deviceCmd;
}

CLI::App* addServe(CLI::App& app, tally::cli::ServeArgs& args) {
  auto* serve = app.add_subcommand("serve", "Serve the REST API and dashboard; run queued captures");
  serve->add_option("--db,--store", args.db,
                    "SQLite database file (default: $XDG_DATA_HOME/tally/tally.db), or a postgresql:// URL that a "
                    "fleet of daemons shares (docs/fleet.md)");
  serve->add_option("--role", args.role,
                    "api: serve REST and the dashboard; worker: claim and run captures; all: both")
      ->capture_default_str()->check(CLI::IsMember({"api", "worker", "all"}));
  serve->add_option("--host-name", args.hostName,
                    "This daemon's name among the fleet's hosts (default: the machine's host name)");
  serve->add_option("--device-name-override", args.deviceNameOverride,
                    "Register and record this device name instead of the real one (tests; sites naming their GPUs)");
  serve->add_option("--lease", args.leaseSeconds,
                    "Seconds a worker's claim on a job lasts unless renewed (every third of it)")
      ->capture_default_str()->check(CLI::Range(1.0, 3600.0));
  serve->add_option("--stale-after", args.staleSeconds, "Seconds without a heartbeat before a host is not alive")
      ->capture_default_str()->check(CLI::Range(1.0, 86400.0));
  serve->add_option("--max-attempts", args.maxAttempts, "Claims of a job before it fails with their reasons")
      ->capture_default_str()->check(CLI::Range(1, 100));
  serve->add_option("--bind", args.bind, "Address to listen on")->capture_default_str();
  serve->add_option("--port", args.port, "Port (0: any free port)")->capture_default_str()->check(CLI::Range(0, 65535));
  serve->add_option("--token-file", args.tokenFile, "Token file (required off loopback)");
  serve->add_option("--device", args.device, "Device index or name substring for captures");
  serve->add_option("--web", args.web, "Dashboard folder (default: the installed dashboard)");
  serve->add_option("--scenes", args.scenes, "Folder glTF scenes may be loaded from (repeatable)");
  serve->add_flag(
      "--allow-applications", args.allowApplications,
      "Accept capture specs that run a program on this host ({\"application\": ...} and {\"replay\": ...}, "
      "under the Vulkan layer) from holders of the token file's application token; needs "
      "--application-root, and --run-as when tallyd runs as root (docs/operating.md, \"Security model\")");
  serve->add_option("--application-root", args.applicationRoots,
                    "A folder an application's program or a replay file must resolve into, links followed "
                    "(repeatable; with --allow-applications)");
  serve->add_option(
      "--application-env", args.applicationEnv,
      "A variable a spec's env may set, NAME or PREFIX*, over the defaults (display, Vulkan driver "
      "choice, MESA_*); LD_*, PATH and VK_*LAYER* never (repeatable)");
  serve->add_option(
      "--run-as", args.runAs,
      "The unprivileged user applications run as when tallyd runs as root (e.g. a user of their own: "
      "useradd --system tally-apps)");
  serve->footer(
      "Environment:\n"
      "  XDG_DATA_HOME    the database's folder is $XDG_DATA_HOME/tally without --db (else HOME)\n"
      "  HOME             $HOME/.local/share/tally without --db and XDG_DATA_HOME\n"
      "  TALLY_DATA_DIR   the data folder (shaders/, web/) where none is found beside the binary\n"
      "                   (bin/../share/tally)\n"
      "  TALLY_SHADER_DIR the renderers' shaders, over the data folder's (for shader work)\n"
      "  VK_DRIVER_FILES, VK_ICD_FILENAMES  the Vulkan loader's choice of driver (captures)\n"
      "  TMPDIR           where each capture job's spec, result and screenshots are written\n"
      "  TALLY_LAYER_PATH the Vulkan layer's manifest folder for application captures, over build/layer\n"
      "                   and share/vulkan/explicit_layer.d beside the binary\n"
      "  JOURNAL_STREAM   set by systemd: log lines then carry their syslog priority (<6>) and no time");
  serve->add_option("--job-deadline", args.jobDeadlineSeconds, "Seconds a capture job may run")
      ->capture_default_str()->check(CLI::Range(1, 7 * 24 * 3600));
  serve->add_option("--store-check-interval", args.storeCheckSeconds,
                    "Seconds between the store's health checks (SQLite quick_check; 0: at start only)")
      ->capture_default_str()->check(CLI::Range(0, 7 * 24 * 3600));
  serve->add_option("--request-timeout", args.requestTimeoutSeconds,
                    "Seconds from a connection to its whole request (header and body), else 408")
      ->capture_default_str()->check(CLI::Range(0.1, 3600.0));
  serve->add_option("--alert-webhook", args.alertWebhook,
                    "POST each regression alert as JSON to this http:// URL (retried with backoff; docs/api.md)");
  serve->add_option("--alert-webhook-attempts", args.alertWebhookAttempts,
                    "Posts of one alert before its delivery fails for good")
      ->capture_default_str()->check(CLI::Range(1, 100));
  serve->add_option("--dashboard-url", args.dashboardUrl,
                    "The dashboard's public address, for links in webhook bodies (default: none)");
  serve->add_option("--max-connections-per-peer", args.maxConnectionsPerPeer,
                    "Open connections one remote address may hold, else 503 (behind a reverse proxy, raise it)")
      ->capture_default_str()->check(CLI::Range(1, 100000));
  serve
      ->add_option(
          "--max-queued", args.maxQueued,
          "Queued captures the store may hold, else 429 with Retry-After (0: no limit; with PostgreSQL, "
          "the store's queue, shared by every API daemon)")
      ->capture_default_str()
      ->check(CLI::Range(int64_t{0}, int64_t{1'000'000'000}));
  serve
      ->add_option("--max-queued-per-client", args.maxQueuedPerClient,
                   "Queued captures per client (per token; per peer address without tokens), else 429 with "
                   "Retry-After (0: no limit)")
      ->capture_default_str()
      ->check(CLI::Range(int64_t{0}, int64_t{1'000'000'000}));
  serve
      ->add_option(
          "--max-cost", args.maxCost,
          "Pixel-frames one capture may render (samples x frames x pixels), else 400 naming max_cost")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e18));
  return serve;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tallyd: Tally's capture daemon and instrumentation tool"};
  app.set_version_flag("--version", tally::versionLine("tallyd"), "Print the version and the commit it was built from");
  app.require_subcommand(1);
  tally::cli::InstrumentArgs instrumentArgs;
  tally::cli::DemoArgs demoArgs;
  tally::cli::CaptureArgs captureArgs;
  tally::cli::PlayArgs playArgs;
  tally::cli::AccuracyArgs accuracyArgs;
  tally::cli::RepeatsArgs repeatsArgs;
  tally::cli::DeviceArgs deviceArgs;
  tally::cli::ServeArgs serveArgs;
  CLI::App* instrument = addInstrument(app, instrumentArgs);
  CLI::App* demo = addDemo(app, demoArgs);
  CLI::App* capture = addCapture(app, captureArgs);
  CLI::App* play = addPlay(app, playArgs);
  CLI::App* accuracy = addAccuracy(app, accuracyArgs);
  CLI::App* repeats = addRepeats(app, repeatsArgs);
  CLI::App* deviceCmd = addDevice(app, deviceArgs);
  CLI::App* serve = addServe(app, serveArgs);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // tallyd play: bad arguments are one line and exit 2, as its own checks.
    const bool help = dynamic_cast<const CLI::CallForHelp*>(&e) != nullptr ||
                      dynamic_cast<const CLI::CallForAllHelp*>(&e) != nullptr;
    if (argc > 1 && std::string(argv[1]) == "play" && !help) {
      std::cerr << "tallyd play: " << e.what() << "\n";
      return 2;
    }
    return app.exit(e);
  }
  if (*instrument) return tally::cli::runInstrument(instrumentArgs);
  if (*demo) return tally::cli::runDemo(demoArgs);
  if (*capture) return tally::cli::runCapture(captureArgs);
  if (*play) return tally::cli::runPlay(playArgs);
  if (*accuracy) return tally::cli::runAccuracy(accuracyArgs);
  if (*repeats) return tally::cli::runRepeats(repeatsArgs);
  if (*deviceCmd) return tally::cli::runDevice(deviceArgs);
  if (*serve) return tally::cli::runServe(serveArgs);
  return 2;
}
