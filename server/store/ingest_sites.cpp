// A pass's sites, draws and materials and a run's shader sources -> rows
// (migration 0011). Every field is checked before its row is written, and a
// fault throws IngestError naming the field; the caller's transaction then
// rolls back the whole result.
#include "store/ingest_sites.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>
#include <vector>

#include "store/ingest_input.hpp"
#include "store/site_records.hpp"

namespace tally::store::detail {

using nlohmann::json;
using json_fields::find;

namespace {

constexpr size_t kMaxName = 1024;         // characters of a name, resource, file, opcode
constexpr size_t kMaxDisassembly = 4096;  // characters of one instruction's text

std::string at(const std::string& path, const char* key, size_t i) {
  return path + "." + key + "[" + std::to_string(i) + "]";
}

// Text of at most `most` characters; empty where the result had nothing to
// say (an application's module may name no shader or entry point).
std::string text(const json& object, const char* key, const std::string& path, size_t most = kMaxName) {
  std::string value = kMembers.text(object, key, path);
  if (value.size() > most) bad(path + "." + key, "must be at most " + std::to_string(most) + " characters");
  return value;
}

// Absent, null or empty: none.
std::optional<std::string> optText(const json& object, const char* key, const std::string& path) {
  if (!find(object, key)) return std::nullopt;
  std::string value = text(object, key, path);
  return value.empty() ? std::nullopt : std::optional<std::string>(value);
}

double amount(const json& object, const char* key, const std::string& path) {
  double value = kMembers.number(object, key, path);
  if (value < 0) bad(path + "." + key, "must not be negative");
  return value;
}

int64_t whole(const json& object, const char* key, const std::string& path, int64_t least) {
  int64_t value = kMembers.integer(object, key, path);
  if (value < least) bad(path + "." + key, least == 0 ? "must not be negative" : "must be at least " + std::to_string(least));
  return value;
}

std::string access(const json& object, const std::string& path) {
  std::string value = kMembers.text(object, "access", path);
  if (value != "read" && value != "write") bad(path + ".access", "must be \"read\" or \"write\", got \"" + value + "\"");
  return value;
}

// Two sums of per-frame averages agree up to rounding.
bool same(double a, double b) { return std::fabs(a - b) <= 1e-6 * std::max({1.0, std::fabs(a), std::fabs(b)}); }

// bytes must be bytes_read + bytes_written.
void checkSplit(double read, double written, double bytes, const std::string& path) {
  if (!same(read + written, bytes)) {
    bad(path + ".bytes", "must be bytes_read + bytes_written (" + json(read + written).dump() + "), got " + json(bytes).dump());
  }
}

const json& list(const json& pass, const char* key, const std::string& path, size_t most, const char* what) {
  const json& items = kMembers.array(pass, key, path);
  if (most && items.size() > most) {
    bad(path + "." + key, "at most " + std::to_string(most) + " " + what + " per pass, got " + std::to_string(items.size()));
  }
  return items;
}

void insertSites(Connection* db, int64_t passId, const json& pass, const std::string& path) {
  const json& sites = list(pass, "sites", path, kMaxSitesPerPass, "sites");
  if (sites.empty()) return;
  // The pass's lines: a site must name one, and the sites of a counted line
  // (not a derived one) sum to its bytes.
  struct Line {
    double bytes = 0, sites = 0;
    bool counted = false;
  };
  std::map<std::pair<std::string, std::string>, Line> lines;
  for (const json& line : kMembers.array(pass, "resources", path)) {
    if (!line.is_object()) continue;
    Line& entry = lines[{kMembers.text(line, "name", path), kMembers.text(line, "access", path)}];
    entry.bytes += kMembers.number(line, "bytes", path);
    entry.counted = entry.counted || kMembers.optText(line, "source", path).value_or("counter") == "counter";
  }
  Statement insert(db,
                   "INSERT INTO pass_sites (pass_id, position, shader, stage, entry_point, instruction, opcode, "
                   "resource, access, kind, file, line, disassembly, count, bytes) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)");
  for (size_t i = 0; i < sites.size(); ++i) {
    std::string where = at(path, "sites", i);
    const json& site = sites[i];
    if (!site.is_object()) bad(where, "must be an object");
    std::string resource = text(site, "resource", where);
    std::string how = access(site, where);
    auto line = lines.find({resource, how});
    if (line == lines.end()) {
      bad(where + ".resource", "\"" + resource + "\" (" + how + ") is not a resource line of this pass");
    }
    std::optional<int64_t> sourceLine, instruction;
    if (find(site, "line")) sourceLine = whole(site, "line", where, 1);
    if (find(site, "instruction")) instruction = whole(site, "instruction", where, 0);
    double bytes = amount(site, "bytes", where);
    line->second.sites += bytes;
    insert.reset();
    insert.bind(1, passId)
        .bind(2, static_cast<int64_t>(i))
        .bind(3, text(site, "shader", where))
        .bind(4, text(site, "stage", where))
        .bind(5, text(site, "entry_point", where))
        .bind(6, instruction)
        .bind(7, text(site, "opcode", where))
        .bind(8, resource)
        .bind(9, how)
        .bind(10, optText(site, "kind", where))
        .bind(11, optText(site, "file", where))
        .bind(12, sourceLine)
        .bind(13, text(site, "disassembly", where, kMaxDisassembly))
        .bind(14, amount(site, "count", where))
        .bind(15, bytes)
        .run();
  }
  for (const auto& [key, line] : lines) {
    if (line.counted && line.sites > 0 && !same(line.bytes, line.sites)) {
      bad(path + ".sites", "the sites of \"" + key.first + "\" (" + key.second + ") sum to " + json(line.sites).dump() +
                               " bytes, its resource line has " + json(line.bytes).dump());
    }
  }
}

struct Draw {
  int64_t index = 0;
  std::string name;
  std::optional<std::string> mesh, material;
  double count = 0, read = 0, written = 0, bytes = 0;
};

Draw readDraw(const json& draw, const std::string& where) {
  if (!draw.is_object()) bad(where, "must be an object");
  Draw d{whole(draw, "index", where, 0), text(draw, "name", where), optText(draw, "mesh", where),
         optText(draw, "material", where), amount(draw, "count", where), amount(draw, "bytes_read", where),
         amount(draw, "bytes_written", where), amount(draw, "bytes", where)};
  checkSplit(d.read, d.written, d.bytes, where);
  return d;
}

// The rest as given, plus the draws beyond kMaxDrawsPerPass (a result may
// carry more; they are summed rather than refused, so totals stay whole).
void insertRest(Connection* db, int64_t passId, const json& pass, const std::string& path, const std::vector<Draw>& beyond) {
  int64_t draws = 0;
  double count = 0, read = 0, written = 0, bytes = 0;
  if (const json* rest = find(pass, "draws_rest")) {
    std::string where = path + ".draws_rest";
    if (!rest->is_object()) bad(where, "must be an object");
    draws = whole(*rest, "draws", where, 1);
    count = amount(*rest, "count", where);
    read = amount(*rest, "bytes_read", where);
    written = amount(*rest, "bytes_written", where);
    bytes = amount(*rest, "bytes", where);
    checkSplit(read, written, bytes, where);
  }
  for (const Draw& d : beyond) {
    ++draws;
    count += d.count;
    read += d.read;
    written += d.written;
    bytes += d.bytes;
  }
  if (draws == 0) return;
  Statement insert(db,
                   "INSERT INTO pass_draws_rest (pass_id, draws, count, bytes_read, bytes_written, bytes) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  insert.bind(1, passId).bind(2, draws).bind(3, count).bind(4, read).bind(5, written).bind(6, bytes).run();
}

void insertDraws(Connection* db, int64_t passId, const json& pass, const std::string& path) {
  const json& given = list(pass, "draws", path, 0, "draws");
  std::vector<Draw> draws;
  draws.reserve(given.size());
  for (size_t i = 0; i < given.size(); ++i) draws.push_back(readDraw(given[i], at(path, "draws", i)));
  std::stable_sort(draws.begin(), draws.end(), [](const Draw& a, const Draw& b) { return a.bytes > b.bytes; });
  size_t kept = std::min(draws.size(), kMaxDrawsPerPass);
  Statement insert(db,
                   "INSERT INTO pass_draws (pass_id, rank, draw_index, name, mesh, material, count, bytes_read, "
                   "bytes_written, bytes) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)");
  for (size_t r = 0; r < kept; ++r) {
    const Draw& d = draws[r];
    insert.reset();
    insert.bind(1, passId)
        .bind(2, static_cast<int64_t>(r))
        .bind(3, d.index)
        .bind(4, d.name)
        .bind(5, d.mesh)
        .bind(6, d.material)
        .bind(7, d.count)
        .bind(8, d.read)
        .bind(9, d.written)
        .bind(10, d.bytes)
        .run();
  }
  insertRest(db, passId, pass, path, std::vector<Draw>(draws.begin() + static_cast<std::ptrdiff_t>(kept), draws.end()));
}

void insertMaterials(Connection* db, int64_t passId, const json& pass, const std::string& path) {
  const json& given = list(pass, "materials", path, kMaxMaterialsPerPass, "materials");
  struct Material {
    std::string name;
    int64_t draws;
    double read, written, bytes;
  };
  std::vector<Material> materials;
  for (size_t i = 0; i < given.size(); ++i) {
    std::string where = at(path, "materials", i);
    const json& m = given[i];
    if (!m.is_object()) bad(where, "must be an object");
    materials.push_back({text(m, "material", where), whole(m, "draws", where, 0), amount(m, "bytes_read", where),
                         amount(m, "bytes_written", where), amount(m, "bytes", where)});
    checkSplit(materials.back().read, materials.back().written, materials.back().bytes, where);
    for (size_t j = 0; j + 1 < materials.size(); ++j) {
      if (materials[j].name == materials.back().name) bad(where + ".material", "\"" + materials.back().name + "\" is listed twice");
    }
  }
  std::stable_sort(materials.begin(), materials.end(), [](const Material& a, const Material& b) { return a.bytes > b.bytes; });
  Statement insert(db,
                   "INSERT INTO pass_materials (pass_id, rank, material, draws, bytes_read, bytes_written, bytes) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  for (size_t r = 0; r < materials.size(); ++r) {
    const Material& m = materials[r];
    insert.reset();
    insert.bind(1, passId).bind(2, static_cast<int64_t>(r)).bind(3, m.name).bind(4, m.draws).bind(5, m.read);
    insert.bind(6, m.written).bind(7, m.bytes).run();
  }
}

}  // namespace

std::string textHash(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

void insertPassSites(Connection* db, int64_t passId, const json& pass, const std::string& path) {
  if (find(pass, "sites")) insertSites(db, passId, pass, path);
  // An application's pass has "draws" as its number of draw commands (an
  // integer, also its "draw_count") unless the layer counted per draw: then
  // "draws" is the per-draw list, an array, as the built-in renderers'.
  const json* draws = find(pass, "draws");
  const bool drawList = draws != nullptr && !draws->is_number_integer();
  if (drawList || find(pass, "draws_rest")) insertDraws(db, passId, pass, path);
  if (find(pass, "materials")) insertMaterials(db, passId, pass, path);
}

void insertShaderSources(Connection* db, int64_t runId, const json& run, const std::string& path) {
  const json* sources = find(run, "shader_sources");
  if (!sources) return;
  std::string where = path + ".shader_sources";
  if (!sources->is_object()) bad(where, "must be an object of shader name -> source text");
  if (sources->size() > kMaxShadersPerRun) {
    bad(where, "at most " + std::to_string(kMaxShadersPerRun) + " shaders per run, got " + std::to_string(sources->size()));
  }
  Statement findText(db, "SELECT id FROM shader_sources WHERE hash = ?1 AND text = ?2");
  Statement insertText(db, "INSERT INTO shader_sources (hash, text, length) VALUES (?1, ?2, ?3) RETURNING id");
  Statement name(db, "INSERT INTO run_shaders (run_id, name, source_id) VALUES (?1, ?2, ?3)");
  for (const auto& [shader, source] : sources->items()) {
    std::string at = where + "[" + json(shader).dump() + "]";
    if (shader.empty() || shader.size() > kMaxName) bad(at, "a shader's name must be 1 to " + std::to_string(kMaxName) + " characters");
    if (!source.is_string()) bad(at, "must be the shader's source text, got " + std::string(source.type_name()));
    const std::string& text = source.get_ref<const std::string&>();
    if (text.size() > kMaxShaderSourceBytes) {
      bad(at, "at most " + std::to_string(kMaxShaderSourceBytes) + " bytes of source, got " + std::to_string(text.size()));
    }
    std::string hash = textHash(text);
    findText.reset();
    findText.bind(1, hash).bind(2, text);
    int64_t id = 0;
    if (findText.step()) {
      id = findText.getInt(0);
      findText.run();
    } else {
      insertText.reset();
      insertText.bind(1, hash).bind(2, text).bind(3, static_cast<int64_t>(text.size()));
      if (!insertText.step()) bad(at, "no id returned");
      id = insertText.getInt(0);
      insertText.run();
    }
    name.reset();
    name.bind(1, runId).bind(2, shader).bind(3, id).run();
  }
}

}  // namespace tally::store::detail
