// Reads of sites, draws, materials and shader sources (migration 0011):
// ranked by bytes, grouped by source line where asked, and paged.
#include <algorithm>
#include <map>
#include <tuple>

#include "store/internal.hpp"
#include "store/runs.hpp"

namespace tally::store {

using detail::guarded;

namespace {

bool sampleExists(Connection* db, int64_t sampleId) {
  Statement query(db, "SELECT 1 FROM samples WHERE id = ?1");
  query.bind(1, sampleId);
  bool found = query.step();
  query.run();
  return found;
}

// Every pass of the sample with its lines' bytes and its stored rows.
std::vector<PassBytes> passBytes(Connection* db, int64_t sampleId) {
  Statement query(db,
                  "SELECT p.position, p.name, COALESCE((SELECT SUM(c.bytes) FROM " +
                      detail::countersOfPass(*db, {"bytes"}) + "), 0), "
                  "(SELECT COUNT(*) FROM pass_sites s WHERE s.pass_id = p.id), "
                  "(SELECT COUNT(*) FROM pass_draws d WHERE d.pass_id = p.id), "
                  "(SELECT COUNT(*) FROM pass_materials m WHERE m.pass_id = p.id) "
                  "FROM passes p WHERE p.sample_id = ?1 ORDER BY p.position");
  query.bind(1, sampleId);
  std::vector<PassBytes> out;
  while (query.step()) {
    RowReader row(query);
    PassBytes pass;
    pass.position = static_cast<int>(row.getInt());
    pass.name = row.getText();
    pass.bytes = row.getDouble();
    pass.sites = row.getInt();
    pass.draws = row.getInt();
    pass.materials = row.getInt();
    row.end();
    out.push_back(std::move(pass));
  }
  return out;
}

// " AND p.name = ?2" where one pass is asked for.
std::string passClause(const std::optional<std::string>& pass) { return pass ? " AND p.name = ?2" : ""; }

// The page's bounds, numbered after the pass's parameter where there is one.
std::string limitClause(const std::optional<std::string>& pass) {
  return pass ? " LIMIT ?3 OFFSET ?4" : " LIMIT ?2 OFFSET ?3";
}

void bindPage(Statement& query, int64_t sampleId, const DrawQuery& q) {
  query.bind(1, sampleId);
  int next = 2;
  if (q.pass) query.bind(next++, *q.pass);
  query.bind(next, q.limit).bind(next + 1, q.offset);
}

std::vector<SiteRow> readSites(Connection* db, int64_t sampleId, const std::optional<std::string>& pass) {
  Statement query(db,
                  "SELECT p.position, p.name, s.shader, s.stage, s.entry_point, s.instruction, s.opcode, s.resource, "
                  "s.access, s.kind, s.file, s.line, s.disassembly, s.count, s.bytes FROM pass_sites s "
                  "JOIN passes p ON p.id = s.pass_id WHERE p.sample_id = ?1" +
                      passClause(pass) + " ORDER BY s.bytes DESC, p.position, s.position");
  query.bind(1, sampleId);
  if (pass) query.bind(2, *pass);
  std::vector<SiteRow> out;
  while (query.step()) {
    RowReader row(query);
    SiteRow site;
    site.passPosition = static_cast<int>(row.getInt());
    site.pass = row.getText();
    site.shader = row.getText();
    site.stage = row.getText();
    site.entryPoint = row.getText();
    site.instruction = row.getOptInt();
    site.opcode = row.getText();
    site.resource = row.getText();
    site.access = row.getText();
    site.kind = row.getOptText();
    site.file = row.getOptText();
    site.line = row.getOptInt();
    site.disassembly = row.getText();
    site.count = row.getDouble();
    site.bytes = row.getDouble();
    row.end();
    site.resources = {site.resource + " (" + site.access + ")"};
    out.push_back(std::move(site));
  }
  return out;
}

// Sums the sites (heaviest first) per pass and source line; a site without a
// line is a row of its own. Each row keeps its heaviest site's fields, and
// its resource lines by bytes.
std::vector<SiteRow> byLine(std::vector<SiteRow> sites) {
  using Key = std::tuple<int, std::string, std::string, int64_t, size_t>;
  std::map<Key, size_t> index;
  std::vector<SiteRow> rows;
  std::vector<std::map<std::string, double>> resourceBytes;
  for (size_t i = 0; i < sites.size(); ++i) {
    SiteRow& site = sites[i];
    // A site without a line: its own key (its position among the sites).
    Key key = site.line ? Key{site.passPosition, site.shader, site.file.value_or(""), *site.line, 0}
                        : Key{site.passPosition, site.shader, "", 0, i + 1};
    auto [it, added] = index.emplace(key, rows.size());
    if (added) {
      rows.push_back(site);
      rows.back().sites = 0;
      rows.back().count = rows.back().bytes = 0;
      resourceBytes.emplace_back();
    }
    SiteRow& row = rows[it->second];
    row.sites += 1;
    row.count += site.count;
    row.bytes += site.bytes;
    resourceBytes[it->second][site.resources.front()] += site.bytes;
  }
  for (size_t r = 0; r < rows.size(); ++r) {
    std::vector<std::pair<std::string, double>> list(resourceBytes[r].begin(), resourceBytes[r].end());
    std::stable_sort(list.begin(), list.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    rows[r].resources.clear();
    for (auto& [name, unused] : list) rows[r].resources.push_back(name);
  }
  std::stable_sort(rows.begin(), rows.end(), [](const SiteRow& a, const SiteRow& b) { return a.bytes > b.bytes; });
  return rows;
}

template <class T>
std::vector<T> slice(std::vector<T> rows, int64_t offset, int64_t limit) {
  if (offset >= static_cast<int64_t>(rows.size())) return {};
  auto begin = rows.begin() + offset;
  auto end = rows.end() - begin > limit ? begin + limit : rows.end();
  return std::vector<T>(std::make_move_iterator(begin), std::make_move_iterator(end));
}

// The paging's fault, if any.
std::optional<std::string> badPaging(int64_t limit, int64_t offset) {
  if (limit < 1 || limit > 1000) return "limit: must be between 1 and 1000";
  if (offset < 0) return "offset: must not be negative";
  return std::nullopt;
}

std::vector<DrawRow> readDraws(Connection* db, int64_t sampleId, const DrawQuery& q) {
  Statement query(db,
                  "SELECT p.position, p.name, d.rank, d.draw_index, d.name, d.mesh, d.material, d.count, d.bytes_read, "
                  "d.bytes_written, d.bytes FROM pass_draws d JOIN passes p ON p.id = d.pass_id WHERE p.sample_id = ?1" +
                      passClause(q.pass) + " ORDER BY d.bytes DESC, p.position, d.rank" + limitClause(q.pass));
  bindPage(query, sampleId, q);
  std::vector<DrawRow> out;
  while (query.step()) {
    RowReader row(query);
    DrawRow d;
    d.passPosition = static_cast<int>(row.getInt());
    d.pass = row.getText();
    d.rank = row.getInt();
    d.index = row.getInt();
    d.name = row.getText();
    d.mesh = row.getOptText();
    d.material = row.getOptText();
    d.count = row.getDouble();
    d.bytesRead = row.getDouble();
    d.bytesWritten = row.getDouble();
    d.bytes = row.getDouble();
    row.end();
    out.push_back(std::move(d));
  }
  return out;
}

std::vector<MaterialRow> readMaterials(Connection* db, int64_t sampleId, const DrawQuery& q) {
  Statement query(db,
                  "SELECT p.position, p.name, m.material, m.draws, m.bytes_read, m.bytes_written, m.bytes "
                  "FROM pass_materials m JOIN passes p ON p.id = m.pass_id WHERE p.sample_id = ?1" +
                      passClause(q.pass) + " ORDER BY m.bytes DESC, p.position, m.rank" + limitClause(q.pass));
  bindPage(query, sampleId, q);
  std::vector<MaterialRow> out;
  while (query.step()) {
    RowReader row(query);
    MaterialRow m;
    m.passPosition = static_cast<int>(row.getInt());
    m.pass = row.getText();
    m.material = row.getText();
    m.draws = row.getInt();
    m.bytesRead = row.getDouble();
    m.bytesWritten = row.getDouble();
    m.bytes = row.getDouble();
    row.end();
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<DrawRest> readRests(Connection* db, int64_t sampleId, const std::optional<std::string>& pass) {
  Statement query(db,
                  "SELECT p.position, p.name, r.draws, r.count, r.bytes_read, r.bytes_written, r.bytes "
                  "FROM pass_draws_rest r JOIN passes p ON p.id = r.pass_id WHERE p.sample_id = ?1" +
                      passClause(pass) + " ORDER BY p.position");
  query.bind(1, sampleId);
  if (pass) query.bind(2, *pass);
  std::vector<DrawRest> out;
  while (query.step()) {
    RowReader row(query);
    DrawRest r{static_cast<int>(row.getInt()), row.getText(), row.getInt(), row.getDouble(),
               row.getDouble(), row.getDouble(), row.getDouble()};
    row.end();
    out.push_back(std::move(r));
  }
  return out;
}

int64_t lineCount(const std::string& text) {
  if (text.empty()) return 0;
  auto newlines = std::count(text.begin(), text.end(), '\n');
  return newlines + (text.back() == '\n' ? 0 : 1);
}

}  // namespace

Result<std::optional<SitePage>> Runs::sites(int64_t sampleId, const SiteQuery& q) {
  if (auto fault = badPaging(q.limit, q.offset)) return makeError(*fault);
  std::lock_guard lock(mutex_);
  return guarded<std::optional<SitePage>>("reading sites", [&]() -> Result<std::optional<SitePage>> {
    Transaction tx(db_, Transaction::Kind::Read);
    if (!sampleExists(db_, sampleId)) return std::optional<SitePage>();
    SitePage page;
    page.passes = passBytes(db_, sampleId);
    std::vector<SiteRow> rows = readSites(db_, sampleId, q.pass);
    if (q.grouping == SiteGrouping::Line) rows = byLine(std::move(rows));
    page.total = static_cast<int64_t>(rows.size());
    page.rows = slice(std::move(rows), q.offset, q.limit);
    return std::optional<SitePage>(std::move(page));
  });
}

Result<std::optional<DrawPage>> Runs::draws(int64_t sampleId, const DrawQuery& q) {
  if (auto fault = badPaging(q.limit, q.offset)) return makeError(*fault);
  std::lock_guard lock(mutex_);
  return guarded<std::optional<DrawPage>>("reading draws", [&]() -> Result<std::optional<DrawPage>> {
    Transaction tx(db_, Transaction::Kind::Read);
    if (!sampleExists(db_, sampleId)) return std::optional<DrawPage>();
    DrawPage page;
    page.passes = passBytes(db_, sampleId);
    for (const PassBytes& pass : page.passes) {
      if (!q.pass || pass.name == *q.pass) page.total += q.byMaterial ? pass.materials : pass.draws;
    }
    if (q.byMaterial) {
      page.materials = readMaterials(db_, sampleId, q);
    } else {
      page.draws = readDraws(db_, sampleId, q);
    }
    page.rests = readRests(db_, sampleId, q.pass);
    return std::optional<DrawPage>(std::move(page));
  });
}

Result<std::vector<ShaderSource>> Runs::shaderSources(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<ShaderSource>>("reading shader sources", [&]() -> Result<std::vector<ShaderSource>> {
    Statement query(db_,
                    "SELECT r.name, s.hash, s.length FROM run_shaders r JOIN shader_sources s ON s.id = r.source_id "
                    "WHERE r.run_id = ?1 ORDER BY r.name");
    query.bind(1, runId);
    std::vector<ShaderSource> out;
    while (query.step()) {
      RowReader row(query);
      ShaderSource source;
      source.name = row.getText();
      source.hash = row.getText();
      source.length = row.getInt();
      row.end();
      out.push_back(std::move(source));
    }
    return out;
  });
}

Result<std::optional<ShaderSource>> Runs::shaderSource(int64_t runId, const std::string& name) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<ShaderSource>>("reading a shader source", [&]() -> Result<std::optional<ShaderSource>> {
    Statement query(db_,
                    "SELECT r.name, s.hash, s.length, s.text FROM run_shaders r JOIN shader_sources s "
                    "ON s.id = r.source_id WHERE r.run_id = ?1 AND r.name = ?2");
    query.bind(1, runId).bind(2, name);
    if (!query.step()) return std::optional<ShaderSource>();
    RowReader row(query);
    ShaderSource source;
    source.name = row.getText();
    source.hash = row.getText();
    source.length = row.getInt();
    source.text = row.getText();
    row.end();
    query.run();
    source.lines = lineCount(source.text);
    return std::optional<ShaderSource>(std::move(source));
  });
}

}  // namespace tally::store
