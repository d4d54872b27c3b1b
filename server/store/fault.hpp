// Store faults: what is wrong with the store itself rather than with a
// request, named from the engine's error code (SQLite's result code, the
// PostgreSQL SQLSTATE or a lost connection). The service answers them 503
// with Retry-After and the reason (docs/operating.md, "Store faults"); the
// worker waits them out before it records a job's end.
#pragma once

#include <exception>
#include <string>

namespace tally::store {

class DbError;

enum class Fault {
  kNone,         // no fault of the store (bad input, a constraint, a bug)
  kBusy,         // another connection held the lock past the busy timeout
  kFull,         // the disk (or the server's) is full
  kIoError,      // reading or writing the file failed
  kReadOnly,     // the file or its folder cannot be written
  kDamaged,      // the file is not a database, or its pages are damaged
  kUnreachable,  // PostgreSQL: the connection is gone and not re-established
};

// "busy", "full", "io_error", "read_only", "damaged", "unreachable"; "none".
const char* toString(Fault fault);
// One line for clients: "the disk holding the store is full", ...
std::string describe(Fault fault);
// A fault goes by itself (busy, unreachable) or once space or the file is
// back (full, io_error, read_only); damage stays until the file is repaired.
bool isWriteFault(Fault fault);  // full, io_error, read_only

Fault faultOf(const DbError& error);
// The fault of an exception thrown by the store's engines (kNone for others).
Fault faultOf(const std::exception& error);

// The fault of this thread's last failed store call (Store's functions and
// Store::open), in the way of errno: kNone when it failed for another
// reason; meaningful only right after a call that failed. A Result carries
// the message only; this says whether the store is to blame.
Fault lastFault();
void setLastFault(Fault fault);

}  // namespace tally::store
