#include "service/store_health.hpp"

#include <algorithm>

namespace tally::service {
namespace {

using Clock = std::chrono::steady_clock;

std::string nowIso() {
  auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::system_clock::now().time_since_epoch());
  return store::isoTimeFromMs(ms.count());
}

// A store call's fault, or the engine's likeliest one when the call named none.
store::Fault faultOrElse(store::Fault fallback) {
  store::Fault f = store::lastFault();
  return f == store::Fault::kNone ? fallback : f;
}

// A damaged file makes requests fail again and again; its check runs at most
// this often on their account (the schedule's checks come on top).
constexpr std::chrono::seconds kMinRecheck{60};
// PostgreSQL's round trip: every this many retry intervals (30 s by default).
constexpr int kPingEvery = 15;
// The engine's message of a fault met by a request: logged at most this often.
constexpr std::chrono::seconds kDetailEvery{10};

}  // namespace

StoreHealth::StoreHealth(StoreHealthOptions options)
    : options_(std::move(options)), postgres_(store::isPostgresUrl(options_.location)) {}

StoreHealth::~StoreHealth() { stop(); }

void StoreHealth::setFault(store::Fault fault, std::string reason, bool keepReason) {
  std::string line;
  {
    std::lock_guard lock(mutex_);
    // Damage outlasts the faults it causes (a read error, a failed write).
    if (state_.fault == store::Fault::kDamaged && fault != store::Fault::kNone &&
        fault != store::Fault::kDamaged) {
      return;
    }
    if (state_.fault == fault && (state_.reason == reason || keepReason)) return;
    if (fault == store::Fault::kNone) {
      line = "store: healthy again (was " + std::string(store::toString(state_.fault)) + ")";
      state_.since.clear();
      state_.reason.clear();
    } else {
      if (state_.fault != fault) state_.since = nowIso();
      state_.reason = reason;
      line = "store: " + reason;
    }
    state_.fault = fault;
  }
  if (options_.log) options_.log(line);
}

void StoreHealth::noteFault(store::Fault fault, const std::string& detail) {
  if (fault == store::Fault::kNone || fault == store::Fault::kBusy) return;
  bool logIt = false;
  {
    std::lock_guard lock(mutex_);
    if (fault == store::Fault::kDamaged) recheck_ = true;
    // The engine's words for each fault, at most every kDetailEvery: a
    // dashboard polling a damaged store would otherwise fill the log.
    const auto now = Clock::now();
    if (fault != lastDetailFault_ || now - lastDetail_ >= kDetailEvery) {
      lastDetailFault_ = fault;
      lastDetail_ = now;
      logIt = true;
    }
  }
  if (logIt && options_.log)
    options_.log("store fault (" + std::string(store::toString(fault)) + "): " + detail);
  // The check's words for the same fault say more than a request's.
  setFault(fault, store::describe(fault), /*keepReason=*/true);
  loop_.wake();
}

void StoreHealth::noteWriteOk() {
  store::Fault now = state().fault;
  if (store::isWriteFault(now) || now == store::Fault::kUnreachable) setFault(store::Fault::kNone, "");
}

StoreHealth::State StoreHealth::state() const {
  std::lock_guard lock(mutex_);
  return state_;
}

nlohmann::json StoreHealth::toJson() const {
  State s = state();
  auto orNull = [](const std::string& v) { return v.empty() ? nlohmann::json(nullptr) : nlohmann::json(v); };
  return {{"status", s.fault == store::Fault::kNone ? "ok" : store::toString(s.fault)},
          {"engine", postgres_ ? "postgresql" : "sqlite"},
          {"reason", orNull(s.reason)},
          {"since", orNull(s.since)},
          {"checked_at", orNull(s.checkedAt)},
          {"check_seconds", s.checkSeconds},
          {"check", orNull(s.checkResult)}};
}

void StoreHealth::runCheck() {
  const auto started = Clock::now();
  std::string result;
  store::Fault fault = store::Fault::kNone;
  if (!checker_) {
    auto opened = store::Store::open(options_.location, {.readOnly = true});
    if (opened) {
      checker_ = std::move(opened).value();
    } else {
      fault = faultOrElse(postgres_ ? store::Fault::kUnreachable : store::Fault::kDamaged);
      result = opened.error();
    }
  }
  if (checker_) {
    auto checked = checker_->quickCheck();
    if (checked && *checked == "ok") {
      result = "ok";
    } else if (checked) {
      fault = store::Fault::kDamaged;
      result = *checked;
    } else {
      fault = faultOrElse(postgres_ ? store::Fault::kUnreachable : store::Fault::kDamaged);
      result = checked.error();
      checker_.reset();  // a new connection next time
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  {
    std::lock_guard lock(mutex_);
    state_.checkedAt = nowIso();
    state_.checkSeconds = seconds;
    state_.checkResult = result;
  }
  const store::Fault current = state().fault;
  if (fault == store::Fault::kNone) {
    // The check reads; it ends damage and an unreachable server, not a full disk.
    if (current == store::Fault::kDamaged || current == store::Fault::kUnreachable) setFault(fault, "");
  } else if (fault == store::Fault::kDamaged) {
    setFault(fault, store::describe(fault) + ": " + (postgres_ ? "" : "quick_check: ") + result);
  } else {
    setFault(fault, store::describe(fault));
    if (options_.log) options_.log("store check: " + result);
  }
}

void StoreHealth::probe() {
  if (!prober_) {
    auto opened = store::Store::open(options_.location);
    if (!opened) return;  // still failing: tried again at the next interval
    prober_ = std::move(opened).value();
  }
  auto probed = prober_->probeWrite();
  if (probed) {
    noteWriteOk();
  } else if (store::lastFault() == store::Fault::kNone || store::lastFault() == store::Fault::kUnreachable) {
    prober_.reset();
  }
}

void StoreHealth::checkNow() { runCheck(); }

void StoreHealth::start() {
  loop_.start([this] {
    auto lastCheck = Clock::now(), lastRecheck = Clock::time_point{}, lastPing = Clock::now();
    while (loop_.next(false, options_.retryInterval)) {
      const auto now = Clock::now();
      const State s = state();
      if (store::isWriteFault(s.fault)) probe();
      bool recheck = false;
      {
        std::lock_guard lock(mutex_);
        if (recheck_ && now - lastRecheck >= kMinRecheck) {
          recheck = true;
          recheck_ = false;
        }
      }
      const bool scheduled = options_.checkInterval.count() > 0 && now - lastCheck >= options_.checkInterval;
      const bool ping = postgres_ && (s.fault == store::Fault::kUnreachable ||
                                      now - lastPing >= kPingEvery * options_.retryInterval);
      if (scheduled || recheck || ping) {
        runCheck();
        lastPing = Clock::now();
        if (scheduled) lastCheck = lastPing;
        if (recheck) lastRecheck = lastPing;
      }
    }
  });
}

void StoreHealth::stop() { loop_.stop(); }

}  // namespace tally::service
