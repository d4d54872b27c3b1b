#include "service/read_stores.hpp"

#include "service/errors.hpp"

namespace tally::service {

store::Store& ReadStores::forThisThread() {
  const std::thread::id self = std::this_thread::get_id();
  {
    std::lock_guard lock(mutex_);
    auto it = stores_.find(self);
    if (it != stores_.end()) return *it->second;
  }
  // Opened outside the lock: another thread's first read need not wait for it.
  auto opened = store::Store::open(dbPath_, {.readOnly = true});
  if (!opened) {
    // A store that cannot be opened is a fault of the store, named or not.
    store::Fault fault = store::lastFault();
    if (fault == store::Fault::kNone) {
      fault = store::isPostgresUrl(dbPath_) ? store::Fault::kUnreachable : store::Fault::kDamaged;
    }
    throw detail::StoreUnavailable(fault, "cannot open a reader: " + opened.error());
  }
  std::lock_guard lock(mutex_);
  auto& slot = stores_[self];
  slot = std::move(opened).value();
  return *slot;
}

}  // namespace tally::service
