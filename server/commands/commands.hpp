// tallyd subcommands, callable from main() and from tests.
#pragma once

#include <cstdint>
#include <string>

namespace tally::cli {

struct InstrumentArgs {
  std::string input;
  std::string output;
  std::string mode = "exact";
  uint32_t set = 7;
  uint32_t binding = 0;
  uint32_t firstSlot = 0;
  std::string width = "int64";
  bool analyzeOnly = false;
};

// Prints the site table as JSON on stdout; on bad input prints one line on
// stderr and returns 1. Writes the output file atomically (temp + rename).
int runInstrument(const InstrumentArgs& args);

struct DemoArgs {
  std::string shaderDir = TALLY_SHADER_DIR;
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
};

// Runs one capture and writes the result JSON (docs/result-schema.md);
// screenshots go beside it in <out>-screenshots/. Bad specs get one line
// naming the field and exit 1.
int runCapture(const CaptureArgs& args);

}  // namespace tally::cli
