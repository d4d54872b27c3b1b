// The tally subcommands' flags (CLI11), one function per command group as
// the groups' files have them (commands.cpp, run_commands.cpp,
// fleet_commands.cpp, alert_commands.cpp). Each adds its subcommands to the
// app, and for each the call to make when it is the one parsed.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"

namespace tally::client {

class Subcommands {
 public:
  // What a subcommand runs, with the flags it parsed; returns the exit status.
  using Run = std::function<int(ApiClient&, Io&)>;
  struct Entry {
    CLI::App* sub;
    Run run;
  };

  // A place for a subcommand's flags to be parsed into, living as long as this.
  template <class T>
  T& hold() {
    auto value = std::make_shared<T>();
    held_.push_back(value);
    return *value;
  }
  // sub runs `run` when parsed; a nested subcommand goes before its parent,
  // which is parsed too.
  void on(CLI::App* sub, Run run) { entries_.push_back({sub, std::move(run)}); }
  // The first parsed, in the order added; null when none was.
  const Entry* parsed() const;

 private:
  std::vector<std::shared_ptr<void>> held_;
  std::vector<Entry> entries_;
};

// capture, profile, status, hosts, cancel: capture jobs and the hosts that run them.
void addCaptureCommands(CLI::App& app, Subcommands& subcommands);
// runs, show, compare, crossover, heatmap: stored runs and what is computed from them.
void addRunCommands(CLI::App& app, Subcommands& subcommands);
// sweeps, sweep, export: stability sweeps and exports.
void addSweepAndExportCommands(CLI::App& app, Subcommands& subcommands);
// baseline, alerts: baselines and the alerts raised against them.
void addAlertCommands(CLI::App& app, Subcommands& subcommands);

}  // namespace tally::client
