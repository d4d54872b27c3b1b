// One line per event on stderr, in logfmt (key=value), fit for journald:
//   level=info job=12 msg="done, 10 runs"
// Under systemd (JOURNAL_STREAM set, stderr connected to the journal) each
// line starts with its syslog priority ("<6>"), so `journalctl -p warning`
// filters by level and journald adds the time; elsewhere a ts= field leads.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tally::log {

enum class Level { kDebug, kInfo, kWarning, kError };

const char* levelName(Level level);  // "debug", "info", "warning", "error"

struct Event {
  Level level = Level::kInfo;
  std::optional<int64_t> job;  // the capture job the event is about
  std::string message;
};

// The line for an event (no trailing newline). journal: with the priority
// prefix and no timestamp; otherwise with ts=<UTC ISO 8601, ms>.
std::string format(const Event& event, bool journal);

// Writes format(event, stderr is the journal) and a newline to stderr, one
// write(2) per line so that lines of different threads never interleave.
void write(const Event& event);

inline void info(std::string_view message, std::optional<int64_t> job = {}) {
  write({Level::kInfo, job, std::string(message)});
}
inline void warning(std::string_view message, std::optional<int64_t> job = {}) {
  write({Level::kWarning, job, std::string(message)});
}
inline void error(std::string_view message, std::optional<int64_t> job = {}) {
  write({Level::kError, job, std::string(message)});
}

}  // namespace tally::log
