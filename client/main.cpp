// tally: the command-line client of a tallyd service.
#include <iostream>

#include <CLI/CLI.hpp>

#include "protocol.hpp"

int main(int argc, char** argv) {
  CLI::App app{"tally: client for a tallyd capture service"};
  bool version = false;
  app.add_flag("--version", version, "Print the client and API versions");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (version) {
    std::cout << "tally " << tally::protocol::kVersion << " (API v" << tally::protocol::kApiVersion << ")\n";
    return 0;
  }
  std::cout << app.help();
  return 0;
}
