// StatisticsKeeper: ANALYZE on a thread and connection of its own (statistics_keeper.hpp).
#include "store/statistics_keeper.hpp"

#include <exception>

namespace tally::store {

StatisticsKeeper::~StatisticsKeeper() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void StatisticsKeeper::request() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    asked_ = true;
    if (!thread_.joinable()) thread_ = std::thread([this] { loop(); });
  }
  changed_.notify_all();
}

void StatisticsKeeper::waitIdle() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (!asked_ && !running_) || !thread_.joinable(); });
}

StatisticsKeeper::State StatisticsKeeper::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

void StatisticsKeeper::loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return asked_ || stopping_; });
    if (stopping_) return;
    asked_ = false;
    running_ = true;
    lock.unlock();
    analyse();
    lock.lock();
    running_ = false;
    changed_.notify_all();
  }
}

void StatisticsKeeper::analyse() {
  try {
    if (!db_) db_ = openPostgres(location_);
    // Only the columns that queries filter or join the big tables by: the
    // others' statistics (the passes' JSON and arrays above all) were half
    // of the time, and no plan reads them. counters: a view of passes.
    db_->exec(
        "ANALYZE runs (id, job_id, device_id, scene_id, renderer, width, height, variant, host, created_at, "
        "evaluated), samples (id, run_id, camera_index, screenshot_id), passes (id, sample_id, position, name), "
        "run_resources (run_id, position), screenshots (id)");
    Statement held(*db_, "SELECT reltuples::bigint FROM pg_class WHERE oid = 'samples'::regclass");
    int64_t samples = held.step() ? held.getInt(0) : 0;
    held.run();
    std::lock_guard lock(mutex_);
    ++state_.analyses;
    state_.samplesAtAnalyze = samples;
  } catch (const std::exception& e) {
    db_.reset();  // a new connection at the next request
    std::lock_guard lock(mutex_);
    ++state_.failures;
    state_.lastFailure = e.what();
  }
}

}  // namespace tally::store
