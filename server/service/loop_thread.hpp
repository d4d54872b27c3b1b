// A background thread that runs passes until stopped: after a pass that found
// work the next one starts at once; after an idle one it waits `idle`, a
// wake() or a stop(). The alert evaluator and the webhook sender run on one.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <utility>

namespace tally::service {

class LoopThread {
 public:
  LoopThread() = default;
  LoopThread(const LoopThread&) = delete;
  LoopThread& operator=(const LoopThread&) = delete;
  ~LoopThread() { stop(); }

  // `body` runs on the thread and calls next() between its passes.
  template <class Body>
  void start(Body&& body) {
    thread_ = std::thread(std::forward<Body>(body));
  }

  // Ends the wait at once and joins the thread; idempotent.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  // Ends the current wait, or the next one, early.
  void wake() {
    {
      std::lock_guard lock(mutex_);
      woken_ = true;
    }
    cv_.notify_all();
  }

  // Between passes: false once stopped; otherwise true, at once when the
  // pass was busy, else after `idle` or a wake().
  bool next(bool busy, std::chrono::milliseconds idle) {
    std::unique_lock lock(mutex_);
    if (stop_) return false;
    if (!busy) cv_.wait_for(lock, idle, [this] { return stop_ || woken_; });
    woken_ = false;
    return !stop_;
  }

 private:
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false, woken_ = false;
};

}  // namespace tally::service
