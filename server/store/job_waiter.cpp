#include "store/job_waiter.hpp"

#include <libpq-fe.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <mutex>

#include "store/db.hpp"

namespace tally::store {

const char* toString(JobWaiter::Wake wake) {
  switch (wake) {
    case JobWaiter::Wake::kPosted: return "posted";
    case JobWaiter::Wake::kTimeout: return "timeout";
    case JobWaiter::Wake::kInterrupted: return "interrupted";
  }
  return "unknown";
}

namespace {

// One SQLite database's announcements within this process: a counter that
// each announcement advances, and the waiters' condition variable.
struct Channel {
  std::mutex mutex;
  std::condition_variable changed;
  uint64_t generation = 0;
};

// Two spellings of one file ("a.db", "./a.db") are one channel.
std::string channelKey(const std::string& location) {
  std::error_code error;
  auto canonical = std::filesystem::weakly_canonical(location, error);
  return error ? location : canonical.string();
}

std::shared_ptr<Channel> channelOf(const std::string& location) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<Channel>> channels;
  std::lock_guard lock(mutex);
  auto& channel = channels[channelKey(location)];
  if (!channel) channel = std::make_shared<Channel>();
  return channel;
}

class SqliteWaiter final : public JobWaiter {
 public:
  explicit SqliteWaiter(const std::string& location) : channel_(channelOf(location)) {}
  void arm() override {
    std::lock_guard lock(channel_->mutex);
    seen_ = channel_->generation;
  }
  Wake wait(std::chrono::milliseconds timeout) override {
    std::unique_lock lock(channel_->mutex);
    channel_->changed.wait_for(lock, timeout, [&] { return interrupted_ || channel_->generation != seen_; });
    if (interrupted_) {
      interrupted_ = false;
      return Wake::kInterrupted;
    }
    return channel_->generation != seen_ ? Wake::kPosted : Wake::kTimeout;
  }
  void interrupt() override {
    {
      std::lock_guard lock(channel_->mutex);
      interrupted_ = true;
    }
    channel_->changed.notify_all();
  }
  bool hearsOtherProcesses() const override { return false; }

 private:
  std::shared_ptr<Channel> channel_;
  uint64_t seen_ = 0;
  bool interrupted_ = false;  // guarded by channel_->mutex
};

// A connection of its own that LISTENs; waits in poll() on its socket and
// on an eventfd that interrupt() writes.
class PostgresWaiter final : public JobWaiter {
 public:
  PostgresWaiter(std::string url, int wakeFd) : url_(std::move(url)), wakeFd_(wakeFd) {}
  ~PostgresWaiter() override {
    if (conn_) PQfinish(conn_);
    ::close(wakeFd_);
  }

  // Connects and listens; the reason when it cannot.
  std::string listen() {
    if (conn_) PQfinish(conn_);
    const char* keywords[] = {"dbname", "connect_timeout", "application_name", nullptr};
    const char* values[] = {url_.c_str(), "10", "tallyd-listener", nullptr};
    conn_ = PQconnectdbParams(keywords, values, /*expand_dbname=*/1);
    listening_ = false;
    if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
      return "cannot connect to " + redactUrl(url_) + ": " + (conn_ ? PQerrorMessage(conn_) : "out of memory");
    }
    std::string sql = std::string("LISTEN ") + kJobChannel;
    PGresult* result = PQexec(conn_, sql.c_str());
    bool ok = result && PQresultStatus(result) == PGRES_COMMAND_OK;
    std::string why = ok ? "" : "LISTEN failed on " + redactUrl(url_) + ": " + PQerrorMessage(conn_);
    PQclear(result);
    listening_ = ok;
    return why;
  }

  void arm() override {
    if (!listening_ || PQstatus(conn_) != CONNECTION_OK) listen();
    if (listening_) takeNotifications();
  }

  Wake wait(std::chrono::milliseconds timeout) override {
    auto deadline = std::chrono::steady_clock::now() + (listening_ ? timeout : std::min(timeout, kRetryAfterLoss));
    for (;;) {
      if (interrupted_.exchange(false)) return Wake::kInterrupted;
      if (listening_ && takeNotifications()) return Wake::kPosted;
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return Wake::kTimeout;
      pollfd fds[2] = {{wakeFd_, POLLIN, 0}, {listening_ ? PQsocket(conn_) : -1, POLLIN, 0}};
      int ready = ::poll(fds, 2, static_cast<int>(std::min<int64_t>(left.count(), 60'000)));
      if (ready > 0 && (fds[0].revents & POLLIN)) {
        uint64_t count = 0;
        ssize_t got = ::read(wakeFd_, &count, sizeof count);
        (void)got;
      }
      if (ready > 0 && listening_ && (fds[1].revents & (POLLIN | POLLERR | POLLHUP))) {
        if (PQconsumeInput(conn_) == 0) {
          listening_ = false;  // lost: from now on, the short wait until arm() reconnects
          deadline = std::min(deadline, std::chrono::steady_clock::now() + kRetryAfterLoss);
        }
      }
    }
  }

  void interrupt() override {
    interrupted_ = true;
    uint64_t one = 1;
    ssize_t put = ::write(wakeFd_, &one, sizeof one);
    (void)put;
  }
  bool hearsOtherProcesses() const override { return listening_; }

 private:
  // Reads what the socket holds; true when a notification was among it.
  bool takeNotifications() {
    if (PQconsumeInput(conn_) == 0) {
      listening_ = false;
      return false;
    }
    bool any = false;
    while (PGnotify* note = PQnotifies(conn_)) {
      any = true;
      PQfreemem(note);
    }
    return any;
  }

  std::string url_;
  int wakeFd_;
  PGconn* conn_ = nullptr;
  bool listening_ = false;  // used by the waiting thread only
  std::atomic<bool> interrupted_{false};
};

}  // namespace

Result<std::unique_ptr<JobWaiter>> JobWaiter::open(const std::string& location) {
  if (!isPostgresUrl(location)) return std::unique_ptr<JobWaiter>(new SqliteWaiter(location));
  int wakeFd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wakeFd < 0) return makeError("job waiter: cannot create an eventfd");
  auto waiter = std::make_unique<PostgresWaiter>(location, wakeFd);
  std::string why = waiter->listen();
  if (!why.empty()) return makeError("job waiter: " + why);
  return std::unique_ptr<JobWaiter>(std::move(waiter));
}

namespace detail {

void announceJobsInProcess(const std::string& location) {
  auto channel = channelOf(location);
  {
    std::lock_guard lock(channel->mutex);
    ++channel->generation;
  }
  channel->changed.notify_all();
}

}  // namespace detail

}  // namespace tally::store
