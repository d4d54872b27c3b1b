// tally: the command-line client of a tallyd service. Parses flags (the
// subcommands' in subcommands.cpp) and calls into tally_client
// (commands.hpp); everything else lives there.
#include <unistd.h>

#include <cstdlib>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common/version.hpp"
#include "protocol.hpp"
#include "subcommands.hpp"

using namespace tally::client;

int main(int argc, char** argv) {
  CLI::App app{
      "tally: client for a tallyd capture service.\n"
      "The server comes from --server, else $TALLY_SERVER, else " +
      defaultServer() +
      "; a token from $TALLY_TOKEN is sent as a bearer token.\n"
      "Exit status: 0 success, 1 failure (reason on stderr), 2 usage error."};
  app.footer("Example:\n  tally --server http://127.0.0.1:8377 runs --renderer deferred");
  app.require_subcommand(0, 1);
  app.fallthrough();  // global flags may follow the subcommand: tally runs --json

  std::string server, colorMode = "auto";
  bool jsonOut = false, version = false;
  int timeoutS = 60;
  app.add_option("--server", server, "tallyd base URL, e.g. http://127.0.0.1:8377");
  app.add_flag("--json", jsonOut, "Print the server's JSON instead of tables");
  app.add_option("--timeout", timeoutS, "Seconds to wait for a response")->check(CLI::PositiveNumber);
  app.add_flag("--version", version, "Print the client and API versions");
  app.add_option(
         "--color", colorMode,
         "Colour tables: auto (when stdout is a terminal and NO_COLOR is unset; CLICOLOR_FORCE forces), "
         "always or never")
      ->check(CLI::IsMember({"auto", "always", "never"}))
      ->default_str("auto");

  Subcommands subcommands;
  addCaptureCommands(app, subcommands);
  addRunCommands(app, subcommands);
  addSweepAndExportCommands(app, subcommands);
  addAlertCommands(app, subcommands);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help is 0; usage errors 2
  }
  if (version) {
    std::cout << tally::versionLine("tally") << ", API v" << tally::protocol::kApiVersion << "\n";
    return 0;
  }
  if (app.get_subcommands().empty()) {
    std::cout << app.help();
    return 0;
  }

  ClientOptions options;
  options.server = resolveServer(server);
  options.token = tokenFromEnv();
  options.readTimeoutS = timeoutS;
  ApiClient api(options);
  Io io{std::cout, std::cerr, jsonOut, ::isatty(STDERR_FILENO) != 0};
  io.colour = decideColour(*parseColourMode(colorMode), ::isatty(STDOUT_FILENO) != 0,
                           [](const char* name) { return std::getenv(name); });

  if (const auto* parsed = subcommands.parsed()) return parsed->run(api, io);
  std::cout << app.help();
  return 0;
}
