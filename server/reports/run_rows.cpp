#include "reports/run_rows.hpp"

#include <algorithm>

namespace tally::reports {

Result<std::vector<store::RunRow>> selectRuns(store::Store& store, const store::RunFilter& filter, int maxRuns,
                                              bool& complete) {
  std::vector<store::RunRow> rows;
  store::Page page{1000, ""};
  complete = false;
  for (int pages = 0; pages < maxRuns / 1000; ++pages) {
    auto got = store.runs().list(filter, page);
    if (!got) return makeError(got.error());
    rows.insert(rows.end(), got->runs.begin(), got->runs.end());
    if (got->nextCursor.empty()) {
      complete = true;
      break;
    }
    page.cursor = got->nextCursor;
  }
  std::reverse(rows.begin(), rows.end());
  return rows;
}

analysis::RunConfig runConfigOf(const store::RunRow& r) {
  analysis::RunConfig c;
  c.id = std::to_string(r.id);
  c.renderer = r.renderer;
  c.options = r.options.dump();
  c.scene = r.scene;
  c.sceneParams = r.sceneParams.dump();
  c.device = std::to_string(r.deviceId);
  c.counting = r.counting;
  c.width = r.width;
  c.height = r.height;
  c.lights = r.lights;
  return c;
}

std::string lineKey(const std::string& pass, const store::Counter& counter) {
  return pass + "/" + counter.resource + " " + counter.access;
}

}  // namespace tally::reports
