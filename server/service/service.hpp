// Tally's service layer: capture jobs, runs, samples, comparison and export
// as JSON routes. Handlers see api::Request/Response only (never HTTP) and
// the SQLite store: writes (create/cancel a job) through the one writer,
// reads through a read-only Store per request thread (readers).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "api/router.hpp"
#include "capture/application_policy.hpp"
#include "store/store.hpp"

namespace tally::service {

class StoreHealth;
class ReadStores;

struct ServiceOptions {
  uint64_t maxPixels = 3840ull * 2160ull;  // per resolution: 4K; larger belongs to `tallyd capture`
  uint32_t maxFrames = 200;                // per sample
  uint64_t maxMatrix = 1000;               // samples per job ("auto" cameras count 10 per scene)
  std::vector<std::filesystem::path> sceneFolders;  // glTF files are allowed only under these
  // {"application": ...} and {"replay": ...} specs run a program on the
  // daemon's host (tallyd serve --allow-applications); refused when false,
  // and from any principal but the application token (403) when true.
  bool allowApplications = false;
  // Where their programs and replay files may lie, what env they may set.
  capture::ApplicationPolicy applicationPolicy;
  // The fleet (docs/fleet.md): a host without a heartbeat this long is not
  // alive (GET /api/hosts, a queued job's "waiting"); claims of a new job.
  int64_t staleAfterMs = 30000;
  int maxAttempts = 3;
  // What one capture may render, in pixel-frames (capture::CaptureSpec::cost:
  // samples x frames x pixels; tallyd serve --max-cost). The largest spec in
  // the tree (tests/gpu/crossover-atrium.json) costs 1.8e10.
  uint64_t maxCost = 100'000'000'000ull;
  // Queued jobs (tallyd serve --max-queued, --max-queued-per-client): beyond
  // either, POST /api/captures answers 429 with Retry-After. 0: no limit.
  // With PostgreSQL the count is the store's, shared by every API daemon.
  int64_t maxQueued = 1000;
  int64_t maxQueuedPerClient = 100;
  int retryAfterSeconds = 30;  // the Retry-After of those 429s
};

struct ServiceContext {
  store::Store* writer = nullptr;  // job creation and cancellation
  std::string dbPath;              // readers open this, read-only
  std::vector<std::string> rendererNames;
  ServiceOptions options;
  std::function<void()> onJobQueued;  // wakes the worker; may be empty
  std::function<void(int64_t)> onQueuedJobCancelled;  // a job cancelled before it ran (metrics); may be empty
  // A capture refused by a queue limit, "queue" or "client" (metrics); may be empty.
  std::function<void(const std::string&)> onQueueLimited;
  std::function<void(std::string_view)> log;  // internal errors; default stderr
  // Store faults met by requests are reported to it, and write routes are
  // refused while it says the store is damaged; may be null.
  StoreHealth* health = nullptr;
  // The request threads' read-only stores over dbPath; addServiceRoutes
  // creates them when this is empty (each store opens at its thread's first read).
  std::shared_ptr<ReadStores> readers;
};

// POST/GET /api/captures, GET/DELETE /api/captures/{id}, /api/runs...,
// /api/sweeps..., /api/samples..., /api/compare, /api/export, /api/devices,
// /api/scenes.
// (GET /api/renderers is a builtin route.) `context` must outlive the router.
void addServiceRoutes(api::Router& router, ServiceContext& context);

// Exposed for tests: "a,b" -> CSV-quoted cell.
std::string csvCell(const std::string& value);

}  // namespace tally::service
