// tallyd serve's setup: everything its flags decide, checked before anything
// starts; serve.cpp runs the daemon from it.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "capture/application_policy.hpp"
#include "commands/commands.hpp"
#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::cli {

// The rules for running applications (docs/operating.md, "Security model"),
// checked before anything starts: --allow-applications needs an application
// token (to serve the API), roots, and a user to run them as when tallyd is
// root (to run them). Returns the policy, and the arguments every capture
// child gets so that it checks each spec again where it runs.
struct ApplicationSetup {
  capture::ApplicationPolicy policy;
  std::vector<std::string> captureArgs;
};

// Everything the flags decide, checked before anything starts: which parts
// run, where the store and the dashboard are, this host's name.
struct ServeSetup {
  std::string self;        // this executable: the worker runs it as `tallyd capture`
  bool serveHttp = false;  // role api or all
  bool runWorker = false;  // role worker or all
  bool postgres = false;
  ApplicationSetup applications;
  std::string dbPath;
  std::string dbName;  // dbPath for messages: a PostgreSQL URL without its password
  std::string webRoot;
  std::string hostName;
  std::string selector;  // --device, or "auto"
  std::chrono::milliseconds lease{0}, staleAfter{0};
};

// The setup, or why the flags are refused (printed after "tallyd serve: ").
// self: this executable.
Result<ServeSetup> resolveServeSetup(const ServeArgs& args, std::string self);

// This host as the fleet sees it (docs/fleet.md): its name, build, role and
// device, probed now.
store::HostInfo workerHost(const ServeArgs& args, const ServeSetup& setup);

}  // namespace tally::cli
