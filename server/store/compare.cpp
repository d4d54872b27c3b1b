// Runs::compare, passes and exportRows: per-frame totals averaged over a run's samples.
#include <algorithm>
#include <set>

#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;

namespace {

// A footprint and the requested bytes of the same counters, summed; empty
// where no counter has a footprint.
struct FootprintSums {
  std::optional<double> footprint, requested;
  void add(const FootprintSums& other) {
    if (!other.footprint) return;
    footprint = footprint.value_or(0) + *other.footprint;
    requested = requested.value_or(0) + other.requested.value_or(0);
  }
};

struct RunTotals {
  int samples = 0;
  std::optional<double> frameMs;
  double totalBytes = 0;
  FootprintSums totalFootprint;
  // pass name -> (gpu_ms, bytes, fragment invocations, footprint), summed over samples
  struct PassSums {
    double gpuMs = 0, bytes = 0;
    std::optional<double> fragments;
    FootprintSums footprint;
  };
  struct ResourceSums {
    double count = 0, bytes = 0;
    FootprintSums footprint;
  };
  std::vector<std::string> passOrder;
  std::map<std::string, PassSums> passes;
  std::map<std::pair<std::string, std::string>, ResourceSums> resources;  // (name, access)
};

RunTotals totalsOf(Connection* db, int64_t runId) {
  RunTotals t;
  Statement frame(db, "SELECT COUNT(*), AVG(frame_ms) FROM samples WHERE run_id = ?1");
  frame.bind(1, runId);
  frame.step();
  RowReader totals(frame);
  t.samples = static_cast<int>(totals.getInt());
  t.frameMs = totals.getOptDouble();
  totals.end();
  Statement passes(db,
                   "SELECT p.name, SUM(p.gpu_ms), SUM(p.fragment_invocations), "
                   "SUM((SELECT COALESCE(SUM(c.bytes), 0) FROM " + detail::countersOfPass(*db, {"bytes"}) + ")), " +
                       "SUM((SELECT SUM(c.footprint_bytes) FROM " + detail::countersOfPass(*db, {"footprint_bytes"}) +
                       ")), " + "SUM((SELECT SUM(c.bytes) FROM " +
                       detail::countersOfPass(*db, {"bytes", "footprint_bytes"}) +
                       " AND c.footprint_bytes IS NOT NULL)) "
                       "FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?1 "
                   "GROUP BY p.name ORDER BY MIN(p.position), p.name");
  passes.bind(1, runId);
  while (passes.step()) {
    RowReader row(passes);
    std::string name = row.getText();
    RunTotals::PassSums sums;
    sums.gpuMs = row.getDouble();
    sums.fragments = row.getOptDouble();
    sums.bytes = row.getDouble();
    sums.footprint = FootprintSums{row.getOptDouble(), row.getOptDouble()};
    row.end();
    t.passOrder.push_back(name);
    t.passes[name] = sums;
  }
  Statement resources(db,
                      "SELECT c.resource, c.access, SUM(c.count), SUM(c.bytes), SUM(c.footprint_bytes), "
                      "SUM(CASE WHEN c.footprint_bytes IS NOT NULL THEN c.bytes END) "
                      "FROM samples s JOIN passes p ON p.sample_id = s.id" +
                          detail::joinPassCounters(*db, {"resource", "access", "count", "bytes", "footprint_bytes"}) +
                          " WHERE s.run_id = ?1 GROUP BY c.resource, c.access");
  resources.bind(1, runId);
  while (resources.step()) {
    RowReader row(resources);
    std::pair<std::string, std::string> key{row.getText(), row.getText()};  // (name, access)
    RunTotals::ResourceSums sums{row.getDouble(), row.getDouble(),
                                 FootprintSums{row.getOptDouble(), row.getOptDouble()}};
    row.end();
    t.totalBytes += sums.bytes;
    t.totalFootprint.add(sums.footprint);
    t.resources[key] = sums;
  }
  return t;
}

// Values against the first: delta = v - v0, ratio = v / v0 (v0 != 0).
std::vector<Compared> against(const std::vector<std::optional<double>>& values) {
  std::vector<Compared> out;
  for (const auto& v : values) {
    Compared c;
    c.value = v;
    if (v && values[0]) {
      c.delta = *v - *values[0];
      if (*values[0] != 0) c.ratio = *v / *values[0];
    }
    out.push_back(c);
  }
  return out;
}

std::optional<double> average(double sum, int samples) {
  return samples > 0 ? std::optional<double>(sum / samples) : std::nullopt;
}

std::optional<double> average(std::optional<double> sum, int samples) {
  return sum ? average(*sum, samples) : std::nullopt;
}

// Requested bytes / footprint of the same counters; empty without a
// footprint, or at a footprint of 0.
std::optional<double> reuseOf(const FootprintSums& f) {
  if (!f.footprint || *f.footprint <= 0) return std::nullopt;
  return f.requested.value_or(0) / *f.footprint;
}

}  // namespace

Result<Comparison> Runs::compare(const std::vector<int64_t>& runIds) {
  if (runIds.size() < 2 || runIds.size() > 4) {
    return makeError("runs: compare 2 to 4 runs, got " + std::to_string(runIds.size()));
  }
  if (std::set<int64_t>(runIds.begin(), runIds.end()).size() != runIds.size()) {
    return makeError("runs: each run at most once");
  }
  std::lock_guard lock(mutex_);
  return guarded<Comparison>("compareRuns", [&]() -> Result<Comparison> {
    Transaction tx(db_, Transaction::Kind::Read);
    Comparison out;
    std::vector<RunTotals> totals;
    for (size_t i = 0; i < runIds.size(); ++i) {
      Statement query(db_, detail::runSelect(*db_, "WHERE r.id = ?1"));
      query.bind(1, runIds[i]);
      if (!query.step())
        return makeError("runs[" + std::to_string(i) + "]: run " + std::to_string(runIds[i]) + " not found");
      out.runs.push_back(detail::readRunRow(query));
      totals.push_back(totalsOf(db_, runIds[i]));
    }
    tx.commit();

    std::vector<std::optional<double>> frame, bytes, footprint, reuse;
    for (const auto& t : totals) {
      frame.push_back(t.frameMs);
      bytes.push_back(average(t.totalBytes, t.samples));
      footprint.push_back(average(t.totalFootprint.footprint, t.samples));
      reuse.push_back(reuseOf(t.totalFootprint));
    }
    out.frameMs = against(frame);
    out.totalBytes = against(bytes);
    out.totalFootprintBytes = against(footprint);
    out.reuse = against(reuse);

    std::vector<std::string> passOrder;  // the first run's order, then passes only later runs have
    for (const auto& t : totals) {
      for (const auto& name : t.passOrder) {
        if (std::find(passOrder.begin(), passOrder.end(), name) == passOrder.end()) passOrder.push_back(name);
      }
    }
    for (const auto& name : passOrder) {
      std::vector<std::optional<double>> gpu, passBytes, fragments, passFootprint, passReuse;
      for (const auto& t : totals) {
        auto it = t.passes.find(name);
        if (it == t.passes.end()) {
          gpu.emplace_back();
          passBytes.emplace_back();
          fragments.emplace_back();
          passFootprint.emplace_back();
          passReuse.emplace_back();
          continue;
        }
        gpu.push_back(average(it->second.gpuMs, t.samples));
        passBytes.push_back(average(it->second.bytes, t.samples));
        fragments.push_back(it->second.fragments ? average(*it->second.fragments, t.samples) : std::nullopt);
        passFootprint.push_back(average(it->second.footprint.footprint, t.samples));
        passReuse.push_back(reuseOf(it->second.footprint));
      }
      out.passes.push_back(PassComparison{name, against(gpu), against(passBytes), against(fragments),
                                          against(passFootprint), against(passReuse)});
    }

    std::set<std::pair<std::string, std::string>> keys;
    for (const auto& t : totals) {
      for (const auto& [key, sums] : t.resources) keys.insert(key);
    }
    for (const auto& key : keys) {
      std::vector<std::optional<double>> count, resourceBytes, resourceFootprint, resourceReuse;
      for (const auto& t : totals) {
        auto it = t.resources.find(key);
        bool has = it != t.resources.end();
        count.push_back(has ? average(it->second.count, t.samples) : std::nullopt);
        resourceBytes.push_back(has ? average(it->second.bytes, t.samples) : std::nullopt);
        resourceFootprint.push_back(has ? average(it->second.footprint.footprint, t.samples) : std::nullopt);
        resourceReuse.push_back(has ? reuseOf(it->second.footprint) : std::nullopt);
      }
      out.resources.push_back(ResourceComparison{key.first, key.second, against(count), against(resourceBytes),
                                                 against(resourceFootprint), against(resourceReuse)});
    }
    return out;
  });
}

Result<std::vector<Pass>> Runs::passes(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Pass>>("runPasses", [&]() -> Result<std::vector<Pass>> {
    Transaction tx(db_, Transaction::Kind::Read);
    Statement count(db_, "SELECT COUNT(*) FROM samples WHERE run_id = ?1");
    count.bind(1, runId);
    count.step();
    auto out = detail::readRunPasses(db_, runId, static_cast<int>(count.getInt(0)));
    tx.commit();
    return out;
  });
}

Result<std::vector<ExportRow>> Runs::exportRows(const RunFilter& filter) {
  if (filter.runIds.size() > 1000) return makeError("runs: at most 1000 run ids");
  std::lock_guard lock(mutex_);
  return guarded<std::vector<ExportRow>>("exportRuns", [&]() -> Result<std::vector<ExportRow>> {
    std::string sql =
        "SELECT r.id, r.renderer, sc.name, r.width, r.height, d.name, p.name, c.resource, c.access, "
        "SUM(c.count) / (SELECT COUNT(*) FROM samples s2 WHERE s2.run_id = r.id), "
        "SUM(c.bytes) / (SELECT COUNT(*) FROM samples s2 WHERE s2.run_id = r.id), "
        "SUM(c.footprint_bytes) / (SELECT COUNT(*) FROM samples s2 WHERE s2.run_id = r.id), "
        "SUM(CASE WHEN c.footprint_bytes IS NOT NULL THEN c.bytes END) / "
        "(SELECT COUNT(*) FROM samples s2 WHERE s2.run_id = r.id) "
        "FROM runs r JOIN devices d ON d.id = r.device_id JOIN scenes sc ON sc.id = r.scene_id "
        "JOIN samples s ON s.run_id = r.id JOIN passes p ON p.sample_id = s.id" +
        detail::joinPassCounters(*db_, {"resource", "access", "count", "bytes", "footprint_bytes"}) +
        " WHERE TRUE" +
        detail::runFilterSql(filter) +
        " GROUP BY r.id, sc.name, d.name, p.name, c.resource, c.access ORDER BY r.id, MIN(p.position), c.resource, c.access";
    Statement query(db_, sql);
    detail::bindRunFilter(query, filter, 1);
    std::vector<ExportRow> rows;
    while (query.step()) {
      RowReader row(query);
      rows.push_back(ExportRow{row.getInt(), row.getText(), row.getText(), static_cast<int>(row.getInt()),
                               static_cast<int>(row.getInt()), row.getText(), row.getText(), row.getText(),
                               row.getText(), row.getDouble(), row.getDouble(), row.getOptDouble(),
                               row.getOptDouble()});
      row.end();
    }
    return rows;
  });
}

}  // namespace tally::store
