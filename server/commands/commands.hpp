// tallyd subcommands, callable from main() and from tests.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace tally::cli {

struct InstrumentArgs {
  std::string input;
  std::string output;
  std::string mode = "accumulate";
  uint32_t set = 7;
  uint32_t binding = 0;
  uint32_t firstSlot = 0;
  std::string width = "int64";
  uint32_t computeCopies = 16;
  bool partitioned = false;
  uint32_t footprintBlockBytes = 0;  // 0 off; 32, 64 or 128
  bool analyzeOnly = false;
  bool perSite = false;  // counter slots per access site, with each site's instruction
};

// Prints the site table as JSON on stdout; on bad input prints one line on
// stderr and returns 1. Writes the output file atomically (temp + rename).
int runInstrument(const InstrumentArgs& args);

struct DemoArgs {
  std::string shaderDir;  // "" : the renderers' shaders (renderers::shaderDirectory)
  std::string mode = "exact";
};

// Instruments every <pass>.<stage>.glsl under shaderDir and prints each site table.
int runDemo(const DemoArgs& args);

struct CaptureArgs {
  std::string spec;    // file, or - for standard input
  std::string out;     // result JSON; "" or - for standard output
  std::string device;  // index or name substring
  bool quiet = false;
  bool summary = false;  // print the per-pass, per-resource summary table
  // An application or replay spec held to the daemon's policy (the worker
  // passes these; capture/application_policy.hpp): without a root, none runs.
  bool confineApplications = false;
  std::vector<std::string> applicationRoots;  // --application-root
  std::vector<std::string> applicationEnv;    // --application-env NAME or PREFIX*
  std::string runAs;                          // --run-as: the application's user (tallyd runs as root)
};

// Runs one capture and writes the result JSON (docs/result-schema.md);
// screenshots go beside it in <out>-screenshots/. Bad specs get one line
// naming the field and exit 1.
int runCapture(const CaptureArgs& args);

struct PlayArgs {
  std::string renderer;    // a renderer or workload name
  std::string options;     // its options as a JSON object; "" none
  std::string scene;       // a scene name, a scene spec as JSON, or a .gltf/.glb file
  std::string resolution;  // WxH
  std::string frames;      // how many frames to render
  std::string camera = "0";  // index into the scene's automatic camera set
  std::string device;      // index or name substring
  std::string lights = "400";
  bool quiet = false;      // no line per frame on standard error
  bool verbose = false;    // a line after setup too (descriptor sets, names)
  bool json = false;       // the run's summary as JSON on standard output
};

// Renders frames of one renderer, uninstrumented, as an ordinary Vulkan
// application whose images, buffers and passes carry their names through
// VK_EXT_debug_utils (capture/play.hpp). Bad input: one line naming the
// flag, exit 2; a failure on the device: exit 1.
int runPlay(const PlayArgs& args);

struct AccuracyArgs {
  std::string result;  // a capture result file
  bool json = false;   // JSON rows instead of the table
};

// Prints, for every run of a capture result counted in a mode other than
// exact, its overhead ratio and counting errors against the exact run of the
// same frames (docs/accuracy.md). Uninstrumented time is every run's baseline.
int runAccuracy(const AccuracyArgs& args);

struct RepeatsArgs {
  std::vector<std::string> results;  // capture result files, one per capture
  bool json = false;                 // JSON groups instead of the table
};

// Groups the runs of several capture results by configuration and prints, for
// every group of two or more, the across-capture median, IQR and range of
// frame time and total bytes, the within-run noise, whether every run lies in
// the band (docs/measurement.md, "Repeatability") and whether the counts are
// identical.
int runRepeats(const RepeatsArgs& args);

struct DeviceArgs {
  std::string device;  // index or name substring; "": the first discrete GPU
  bool json = false;
};

// Prints the device captures would run on (its result "device" object with --json).
int runDevice(const DeviceArgs& args);

struct ServeArgs {
  std::string db;                   // SQLite file or postgresql:// URL; "": $XDG_DATA_HOME/tally/tally.db
  std::string role = "all";         // api | worker | all (docs/fleet.md)
  std::string hostName;             // this daemon's name among the hosts; "": gethostname()
  std::string deviceNameOverride;   // report this device name instead of the real one
  double leaseSeconds = 30;         // a claimed job's lease; renewed every third of it
  double staleSeconds = 30;         // a host without a heartbeat this long is not alive
  int maxAttempts = 3;              // claims of a job before it fails
  std::string bind = "127.0.0.1";
  int port = 8377;                  // protocol::kDefaultPort; 0: an ephemeral port (printed)
  std::string tokenFile;            // required for a non-loopback bind
  std::string device;               // passed to each capture as --device
  std::string web;                  // dashboard files; "": the data folder's web/ (common/paths.hpp)
  std::vector<std::string> scenes;  // folders glTF scenes may come from
  // Application and replay specs run a program on this host under the Vulkan
  // layer: refused (400 naming the field) unless this is set. It needs a token
  // file with an application= line (to serve the API), at least one
  // application root, and, when tallyd starts as root, --run-as (to run them).
  bool allowApplications = false;
  std::vector<std::string> applicationRoots;  // programs and replay files resolve inside these
  std::vector<std::string> applicationEnv;    // env names (or PREFIX*) a spec may set, over the defaults
  std::string runAs;                          // the user applications run as when tallyd is root
  int jobDeadlineSeconds = 1800;    // per capture job
  // The store's health check (SQLite quick_check) at start and then this
  // often; 0: at start only (docs/operating.md, "Store faults").
  int storeCheckSeconds = 3600;
  double requestTimeoutSeconds = 10;  // a request must arrive whole within this of its connection
  int maxConnectionsPerPeer = 64;     // open connections per remote address
  // Limits on the queue (docs/operating.md, "Limits"); 0: none. Beyond
  // either, POST /api/captures answers 429 with Retry-After.
  int64_t maxQueued = 1000;          // queued jobs in the store
  int64_t maxQueuedPerClient = 100;  // queued jobs per token (or per peer address without tokens)
  double maxCost = 1e11;             // pixel-frames (samples x frames x pixels) of one capture
  // Regression alerts (docs/api.md, "Baselines and alerts"): API daemons
  // evaluate new runs against their baselines; with a webhook, each alert is
  // posted to it from the store's outbox.
  std::string alertWebhook;           // http:// URL; "": none
  int alertWebhookAttempts = 8;       // posts of one alert before its delivery fails
  std::string dashboardUrl;           // for links in webhook bodies; "": none
};

// Serves the REST API (and the dashboard) until SIGINT/SIGTERM; runs queued
// captures one at a time in child processes. Prints "http://ADDR:PORT/".
int runServe(const ServeArgs& args);

}  // namespace tally::cli
