// The fleet's hosts, a facet of the Store (store.hosts()): each worker
// daemon registers under its name and beats while it lives (docs/fleet.md).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "store/facet.hpp"
#include "store/job_records.hpp"

namespace tally::store {

class Hosts : public Facet {
 public:
  // Registers (or re-registers) a worker under its name; refused
  // while another live instance (heartbeat within staleAfterMs) holds the name.
  // instanceIsGone: says whether a live-looking holder is in fact gone (the
  // same machine, its process dead: a restart after a crash need not wait).
  Result<bool> join(const HostInfo& info, int64_t staleAfterMs,
                    const std::function<bool(const std::string&)>& instanceIsGone = {});
  // The host's heartbeat and current job; false when another instance took the name.
  Result<bool> heartbeat(const std::string& name, const std::string& instance,
                         std::optional<int64_t> currentJob);
  // Every host by name, alive when its heartbeat is within staleAfterMs.
  Result<std::vector<Host>> list(int64_t staleAfterMs);

 private:
  friend class Store;
  explicit Hosts(Shared& shared) : Facet(shared) {}
};

}  // namespace tally::store
