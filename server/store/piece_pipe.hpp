// Pieces of a COPY formatted on a thread of their own while the caller's
// thread writes the tables before them: the ingest's passes (most of a
// capture's rows) are read and formatted while the runs, resources,
// screenshots and samples are sent, and then only sent
// (ingest_capture.cpp, CaptureRows::writePasses).
//
//   PiecePipe pipe([&](PiecePipe& out) { ... out.push(rows.take()); ... });
//   ... write the tables before ...
//   while (auto piece = pipe.pop()) stream.send(*piece);   // rethrows the producer's exception
//
// The producer runs `produce` once; push() returns false once the pipe is
// cancelled (the consumer gave up), and the producer should then return.
// Destroying the pipe cancels it and joins the thread, so an exception on
// the consumer's side never leaves the producer reading what is freed.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace tally::store::detail {

class PiecePipe {
 public:
  explicit PiecePipe(std::function<void(PiecePipe&)> produce)
      : thread_([this, produce = std::move(produce)] { run(produce); }) {}
  ~PiecePipe() {
    {
      std::lock_guard lock(mutex_);
      cancelled_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  PiecePipe(const PiecePipe&) = delete;
  PiecePipe& operator=(const PiecePipe&) = delete;

  // Producer: hands a piece over; false once cancelled.
  bool push(std::string piece) {
    {
      std::lock_guard lock(mutex_);
      if (cancelled_) return false;
      pieces_.push_back(std::move(piece));
    }
    changed_.notify_all();
    return true;
  }

  // Consumer: the next piece, or nothing once the producer has returned and
  // every piece was taken; rethrows what the producer threw.
  std::optional<std::string> pop() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return !pieces_.empty() || done_; });
    if (!pieces_.empty()) {
      std::string piece = std::move(pieces_.front());
      pieces_.pop_front();
      return piece;
    }
    if (error_) std::rethrow_exception(error_);
    return std::nullopt;
  }

 private:
  void run(const std::function<void(PiecePipe&)>& produce) {
    std::exception_ptr error;
    try {
      produce(*this);
    } catch (...) {
      error = std::current_exception();
    }
    {
      std::lock_guard lock(mutex_);
      error_ = error;
      done_ = true;
    }
    changed_.notify_all();
  }

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::string> pieces_;
  bool done_ = false, cancelled_ = false;
  std::exception_ptr error_;
  std::thread thread_;  // last: started once the members above exist
};

}  // namespace tally::store::detail
