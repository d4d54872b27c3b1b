// The whole flow through the `tally` binary against a real `tallyd serve`:
// capture (with progress), status, runs, show, compare, export, cancel. Every
// value the client shows is checked against the database file, read with SQL
// of this test's own (not the server's queries); numbers in the tables are
// allowed exactly the rounding of client/tables.cpp's formats.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sqlite3.h>
#include <sys/socket.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "daemon.hpp"
#include "store/sqlite.hpp"
#include "store/store.hpp"

namespace {
using namespace tally::service::test;

// ---- running tally --------------------------------------------------------------

struct Outcome {
  int rc = -1;  // exit status; -1 when killed or not started
  std::string out, err;
};

// Runs the tally binary with args; $TALLY_SERVER and $TALLY_TOKEN are left
// out so only the flags count. Killed after `limit` (a hung client fails).
Outcome runTally(const fs::path& dir, const std::vector<std::string>& args,
                 std::chrono::seconds limit = 120s) {
  fs::path out = dir / "tally.out", err = dir / "tally.err";
  std::vector<std::string> all = {TALLY_PATH};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    std::string entry(*e);
    if (entry.rfind("TALLY_SERVER=", 0) != 0 && entry.rfind("TALLY_TOKEN=", 0) != 0) env.push_back(entry);
  }
  std::vector<char*> envp;
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  Outcome r;
  if (spawned != 0) return r;
  int status = 0;
  auto deadline = std::chrono::steady_clock::now() + limit;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() >= deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  if (WIFEXITED(status)) r.rc = WEXITSTATUS(status);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// A table row's cells: Table separates columns by two spaces at least, and
// no cell holds two spaces in a row.
std::vector<std::string> cells(const std::string& row) {
  static const std::regex kGap(" {2,}");
  std::vector<std::string> out;
  size_t start = row.find_first_not_of(' ');
  if (start == std::string::npos) return out;
  std::string trimmed = row.substr(start);
  for (std::sregex_token_iterator it(trimmed.begin(), trimmed.end(), kGap, -1), end; it != end; ++it)
    out.push_back(*it);
  return out;
}

// The rows of a printed table (title line first) whose first cell is `key`.
std::vector<std::vector<std::string>> rowsStartingWith(const std::string& table, const std::string& key) {
  std::vector<std::vector<std::string>> out;
  for (const auto& line : lines(table)) {
    auto c = cells(line);
    if (!c.empty() && c[0] == key) out.push_back(c);
  }
  return out;
}

// ---- the client's number formats, read back -----------------------------------

// A printed number and half a unit of its last printed digit: the most that
// "%.Nf" rounding can have moved it.
struct Shown {
  double value = 0, tolerance = 0;
};

// fixed()/percent()/ratio(): "%.Nf" with an optional suffix ("%", "x").
std::optional<Shown> parseFixed(const std::string& cell, const std::string& suffix = "") {
  static const std::regex kNumber(R"([+-]?\d+(?:\.(\d+))?)");  // group 1: the decimals
  std::smatch m;
  std::string text = cell;
  if (!suffix.empty()) {
    if (text.size() < suffix.size() || text.compare(text.size() - suffix.size(), suffix.size(), suffix) != 0)
      return std::nullopt;
    text.resize(text.size() - suffix.size());
  }
  if (!std::regex_match(text, m, kNumber)) return std::nullopt;
  return Shown{std::stod(text), 0.5 * std::pow(10.0, -static_cast<double>(m[1].length()))};
}

// humanBytes()/signedBytes(): "%.0f B" below 1024, else "%.2f KiB|MiB|..."
// after dividing by 1024 per unit.
std::optional<Shown> parseBytes(const std::string& cell) {
  static const std::regex kBytes(R"(([+-]?\d+(?:\.\d+)?) (B|KiB|MiB|GiB|TiB|PiB))");
  static const std::vector<std::string> kUnits = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  std::smatch m;
  if (!std::regex_match(cell, m, kBytes)) return std::nullopt;
  auto fixed = parseFixed(m[1]);
  size_t unit = std::find(kUnits.begin(), kUnits.end(), m[2].str()) - kUnits.begin();
  double scale = std::pow(1024.0, static_cast<double>(unit));
  return Shown{fixed->value * scale, fixed->tolerance * scale};
}

// Whether a table cell shows `expected` (from the database) in its format.
::testing::AssertionResult shows(const std::optional<Shown>& shown, double expected,
                                 const std::string& cell) {
  if (!shown) return ::testing::AssertionFailure() << "'" << cell << "' is not in the expected format";
  // The slack covers the binary representation of a value printed exactly half-way.
  if (std::fabs(shown->value - expected) <= shown->tolerance * (1 + 1e-9))
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "'" << cell << "' does not show " << expected << " (to within " << shown->tolerance << ")";
}

// ---- the database, read on its own ---------------------------------------------

// Rows of a query as JSON arrays (integers, reals, text, null), with integer or
// text parameters; a read-only connection beside the daemon's.
class Db {
 public:
  explicit Db(const fs::path& path) {
    auto opened = tally::store::Store::open(path.string(), {.readOnly = true});
    if (opened) store_ = std::move(*opened);
  }
  bool ok() const { return store_ != nullptr; }

  json rows(const std::string& sql, const std::vector<json>& params = {}) {
    sqlite3* db = static_cast<tally::store::SqliteConnection&>(store_->connection()).raw();
    sqlite3_stmt* stmt = nullptr;
    json out = json::array();
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr) != SQLITE_OK) {
      ADD_FAILURE() << sqlite3_errmsg(db) << " in " << sql;
      return out;
    }
    for (size_t i = 0; i < params.size(); ++i) {
      int at = static_cast<int>(i) + 1;
      if (params[i].is_number_integer()) {
        sqlite3_bind_int64(stmt, at, params[i].get<int64_t>());
      } else {
        std::string text = params[i].get<std::string>();
        sqlite3_bind_text(stmt, at, text.c_str(), -1, SQLITE_TRANSIENT);
      }
    }
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      json row = json::array();
      for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
        switch (sqlite3_column_type(stmt, c)) {
          case SQLITE_INTEGER: row.push_back(sqlite3_column_int64(stmt, c)); break;
          case SQLITE_FLOAT: row.push_back(sqlite3_column_double(stmt, c)); break;
          case SQLITE_NULL: row.push_back(nullptr); break;
          default: row.push_back(reinterpret_cast<const char*>(sqlite3_column_text(stmt, c))); break;
        }
      }
      out.push_back(row);
    }
    sqlite3_finalize(stmt);
    return out;
  }
  json row(const std::string& sql, const std::vector<json>& params = {}) {
    json all = rows(sql, params);
    return all.empty() ? json() : all[0];
  }

 private:
  std::unique_ptr<tally::store::Store> store_;
};

// A run as the database has it: its columns and per-frame means over its samples.
struct DbRun {
  int64_t id = 0, capture = 0, samples = 0;
  std::string renderer, scene, device, host;
  int64_t width = 0, height = 0;
  double frameMs = 0, bytes = 0;  // means of samples.frame_ms and samples.bytes
  double frameMsMedian = 0;       // the median of every stored per-frame time of its samples
};

// The median of a run's frame times pooled over its samples, from the stored
// arrays (the median of the samples' frame_ms where one has none).
double dbFrameMedian(Db& db, int64_t run) {
  std::vector<double> frames, medians;
  bool everyFrame = true;
  for (const auto& r : db.rows("SELECT frame_ms, frame_ms_frames FROM samples WHERE run_id = ?1", {run})) {
    medians.push_back(r[0].get<double>());
    json times = r[1].is_string() ? json::parse(r[1].get<std::string>()) : json();
    everyFrame = everyFrame && times.is_array() && !times.empty();
    if (times.is_array())
      for (const auto& t : times) frames.push_back(t.get<double>());
  }
  std::vector<double>& v = everyFrame ? frames : medians;
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n == 0 ? 0 : n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

std::map<int64_t, DbRun> dbRuns(Db& db) {
  std::map<int64_t, DbRun> out;
  json rows = db.rows(
      "SELECT r.id, r.job_id, r.renderer, sc.name, d.name, r.width, r.height, COUNT(s.id), AVG(s.frame_ms), "
      "AVG(s.bytes), r.host FROM runs r JOIN scenes sc ON sc.id = r.scene_id JOIN devices d ON d.id = r.device_id "
      "LEFT JOIN samples s ON s.run_id = r.id GROUP BY r.id");
  for (const auto& r : rows) {
    DbRun run;
    run.id = r[0].get<int64_t>();
    run.capture = r[1].get<int64_t>();
    run.renderer = r[2].get<std::string>();
    run.scene = r[3].get<std::string>();
    run.device = r[4].get<std::string>();
    run.width = r[5].get<int64_t>();
    run.height = r[6].get<int64_t>();
    run.samples = r[7].get<int64_t>();
    run.frameMs = r[8].get<double>();
    run.bytes = r[9].get<double>();
    run.host = r[10].get<std::string>();
    run.frameMsMedian = dbFrameMedian(db, run.id);
    out[run.id] = run;
  }
  return out;
}

// Bytes per frame of a run's counters, summed over its samples, divided by the
// sample count: the "averaged over the run's samples" of compare and export.
double runCounterBytes(Db& db, int64_t run, const std::string& extraCondition = "",
                       const std::vector<json>& extra = {}) {
  std::vector<json> params = {run};
  params.insert(params.end(), extra.begin(), extra.end());
  json total = db.row(
      "SELECT TOTAL(c.bytes) / (SELECT COUNT(*) FROM samples WHERE run_id = ?1) FROM counters c "
      "JOIN passes p ON p.id = c.pass_id JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?1" +
          extraCondition,
      params);
  return total[0].get<double>();
}

// RFC 4180 rows: quoted cells may hold commas and doubled quotes; lines end in CRLF.
std::vector<std::vector<std::string>> parseCsv(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1);
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cell += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(std::move(cell));
      cell.clear();
    } else if (c == '\n') {
      rows.back().push_back(std::move(cell));
      cell.clear();
      rows.emplace_back();
    } else if (c != '\r') {
      cell += c;
    }
  }
  if (!cell.empty() || !rows.back().empty()) rows.back().push_back(std::move(cell));
  if (rows.back().empty()) rows.pop_back();
  return rows;
}

// ---- the fixture: a daemon per test ----------------------------------------------

// 2 renderers x 2 cameras at 64x36, 2 frames: two runs of two samples.
json flowSpec() {
  json spec = tinySpec();
  spec["cameras"] = {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}},
                     {{"eye", {0, 0.5, 0}}, {"target", {0, 0, -1}}}};
  return spec;
}
constexpr int kFlowSamples = 4;

using Runs = std::map<int64_t, DbRun>;

class CliFlow : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = makeTempDir(std::string("tally-cli-flow-") +
                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    daemon_ = std::make_unique<Daemon>(dir_, db());
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  void TearDown() override {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0);
    }
    daemon_.reset();
    fs::remove_all(dir_);
  }

  Outcome tally(std::vector<std::string> args) {
    args.insert(args.begin(), {"--server", daemon_->url()});
    Outcome r = runTally(dir_, args);
    if (r.rc < 0) ADD_FAILURE() << "tally did not exit by itself";
    return r;
  }
  json tallyJson(const std::vector<std::string>& args) {
    Outcome r = tally(args);
    EXPECT_EQ(r.rc, 0) << r.err;
    return json::parse(r.out, nullptr, false);
  }
  std::string writeSpec(const json& spec) {
    fs::path path = dir_ / "spec.json";
    std::ofstream(path) << spec.dump();
    return path.string();
  }
  fs::path db() const { return dir_ / "tally.db"; }

  // The views of the flow, one subcommand each.
  void captureWithProgress(int64_t& capture);
  void checkStatus(Db& db, int64_t capture);
  void checkRunsJson(Db& db, const Runs& runs);
  void checkRunsTable(const Runs& runs);
  void checkShow(Db& db, const DbRun& run);
  void checkCompare(Db& db, const DbRun& a, const DbRun& b);
  void checkExport(Db& db, const Runs& runs);
  void checkCancelRefused(Db& db, int64_t capture);

  fs::path dir_;
  std::unique_ptr<Daemon> daemon_;
};

// `tally capture` waits, draws progress on stderr (not a terminal: one line
// per change) and ends with the job done.
void CliFlow::captureWithProgress(int64_t& capture) {
  Outcome cap = tally({"capture", "--spec", writeSpec(flowSpec()), "--interval", "0.1"});
  ASSERT_EQ(cap.rc, 0) << cap.out << cap.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(cap.err, m, std::regex(R"(capture (\d+) queued)"))) << cap.err;
  capture = std::stoll(m[1]);
  EXPECT_NE(cap.out.find("capture " + std::to_string(capture) + " done"), std::string::npos) << cap.out;
  std::vector<std::string> progress;
  for (const auto& line : lines(cap.err))
    if (line.rfind("[", 0) == 0) progress.push_back(line);
  ASSERT_FALSE(progress.empty()) << cap.err;
  const std::string total = std::to_string(kFlowSamples);
  EXPECT_EQ(progress.back().rfind("[####################] " + total + "/" + total, 0), 0u) << progress.back();
}

// `tally status` (the list) and `tally status ID` show the job's row.
void CliFlow::checkStatus(Db& db, int64_t capture) {
  json job = db.row(
      "SELECT status, progress_done, progress_total, attempts, created_at, host, max_attempts FROM jobs WHERE id = ?1",
      {capture});
  ASSERT_TRUE(job.is_array()) << "capture " << capture << " is not in the database";
  EXPECT_EQ(job[0], "done");
  EXPECT_EQ(job[1], kFlowSamples);
  EXPECT_EQ(job[2], kFlowSamples);
  const std::string progress = job[1].dump() + "/" + job[2].dump();

  Outcome list = tally({"status"});
  ASSERT_EQ(list.rc, 0) << list.err;
  auto listed = rowsStartingWith(list.out, std::to_string(capture));
  ASSERT_EQ(listed.size(), 1u) << list.out;
  // ID STATUS HOST PROGRESS ATTEMPTS CREATED (ERROR empty): the daemon's worker is a host.
  ASSERT_EQ(listed[0].size(), 6u) << list.out;
  EXPECT_EQ(listed[0][1], job[0]);
  EXPECT_EQ(listed[0][2], job[5]);
  EXPECT_EQ(listed[0][3], progress);
  EXPECT_EQ(listed[0][4], job[3].dump() + "/" + job[6].dump());
  EXPECT_EQ(listed[0][5], job[4]);

  Outcome one = tally({"status", std::to_string(capture)});
  ASSERT_EQ(one.rc, 0) << one.err;
  std::map<std::string, std::string> fields;  // FIELD VALUE
  for (const auto& line : lines(one.out)) {
    auto c = cells(line);
    if (c.size() == 2) fields[c[0]] = c[1];
  }
  EXPECT_EQ(fields["status"], job[0]);
  EXPECT_EQ(fields["progress"], progress);
  EXPECT_EQ(fields["attempts"], job[3].dump() + "/" + job[6].dump());
  EXPECT_EQ(fields["host"], job[5]);
  EXPECT_EQ(fields["created"], job[4]);
}

// `tally runs --json`, with and without filters and pages.
void CliFlow::checkRunsJson(Db& db, const Runs& runs) {
  json listed = tallyJson({"runs", "--json"})["runs"];
  ASSERT_EQ(listed.size(), runs.size()) << listed.dump();
  for (const auto& r : listed) {
    SCOPED_TRACE("run " + r["id"].dump());
    ASSERT_TRUE(runs.count(r["id"].get<int64_t>()));
    const DbRun& want = runs.at(r["id"].get<int64_t>());
    EXPECT_EQ(r["capture"], want.capture);
    EXPECT_EQ(r["renderer"], want.renderer);
    EXPECT_EQ(r["scene"], want.scene);
    EXPECT_EQ(r["width"], want.width);
    EXPECT_EQ(r["height"], want.height);
    EXPECT_EQ(r["device"], want.device);
    EXPECT_EQ(r["sample_count"], want.samples);
    EXPECT_DOUBLE_EQ(r["mean_frame_ms"].get<double>(), want.frameMs);
    EXPECT_DOUBLE_EQ(r["frame_ms_median"].get<double>(), want.frameMsMedian);
    EXPECT_DOUBLE_EQ(r["mean_bytes"].get<double>(), want.bytes);
  }
  json deferred = tallyJson({"runs", "--renderer", "deferred", "--json"})["runs"];
  ASSERT_EQ(deferred.size(), 1u) << deferred.dump();
  EXPECT_EQ(deferred[0]["renderer"], "deferred");
  // --device takes the device's exact name or its id.
  json device = db.row("SELECT id, name FROM devices");
  for (const std::string& d : {device[0].dump(), device[1].get<std::string>()})
    EXPECT_EQ(tallyJson({"runs", "--device", d, "--json"})["runs"].size(), runs.size()) << d;
  // --limit gives one page and says there is more; --all follows the pages.
  Outcome firstPage = tally({"runs", "--limit", "1"});
  ASSERT_EQ(firstPage.rc, 0) << firstPage.err;
  EXPECT_EQ(lines(firstPage.out).size(), 2u) << firstPage.out;  // the titles and one run
  EXPECT_NE(firstPage.err.find("more runs"), std::string::npos) << firstPage.err;
  EXPECT_EQ(tallyJson({"runs", "--limit", "1", "--all", "--json"})["runs"].size(), runs.size());
}

// `tally runs`: one table row per run, its numbers within the formats' rounding.
void CliFlow::checkRunsTable(const Runs& runs) {
  Outcome table = tally({"runs"});
  ASSERT_EQ(table.rc, 0) << table.err;
  for (const auto& [id, want] : runs) {
    SCOPED_TRACE("runs table, run " + std::to_string(id));
    auto rows = rowsStartingWith(table.out, std::to_string(id));
    ASSERT_EQ(rows.size(), 1u) << table.out;
    const auto& c = rows[0];  // ID CAPTURE RENDERER SCENE SIZE DEVICE HOST SAMPLES FRAME-MS BYTES/FRAME
    ASSERT_EQ(c.size(), 10u) << table.out;
    EXPECT_EQ(c[1], std::to_string(want.capture));
    EXPECT_EQ(c[2], want.renderer);
    EXPECT_EQ(c[3], want.scene);
    EXPECT_EQ(c[4], std::to_string(want.width) + "x" + std::to_string(want.height));
    EXPECT_EQ(c[5], want.device);
    EXPECT_EQ(c[6], want.host);
    EXPECT_EQ(c[7], std::to_string(want.samples));
    EXPECT_TRUE(shows(parseFixed(c[8]), want.frameMsMedian, c[8]));  // the median, as every view
    EXPECT_TRUE(shows(parseBytes(c[9]), want.bytes, c[9]));
  }
}

// `tally show RUN` as JSON and as a table: the run and each of its samples.
void CliFlow::checkShow(Db& db, const DbRun& run) {
  SCOPED_TRACE("show " + std::to_string(run.id));
  const std::string id = std::to_string(run.id);
  json samples = db.rows(
      "SELECT s.id, s.frame_ms, s.bytes, s.sky_fraction, "
      "(SELECT TOTAL(c.bytes) FROM counters c JOIN passes p ON p.id = c.pass_id "
      " WHERE p.sample_id = s.id AND c.access = 'read'), "
      "(SELECT TOTAL(c.bytes) FROM counters c JOIN passes p ON p.id = c.pass_id "
      " WHERE p.sample_id = s.id AND c.access = 'write') "
      "FROM samples s WHERE s.run_id = ?1 ORDER BY s.camera_index",
      {run.id});
  ASSERT_EQ(samples.size(), static_cast<size_t>(run.samples));

  json shown = tallyJson({"show", id, "--json"});
  ASSERT_TRUE(shown.is_object());
  EXPECT_EQ(shown["run"]["sample_count"], run.samples);
  EXPECT_DOUBLE_EQ(shown["run"]["mean_frame_ms"].get<double>(), run.frameMs);
  EXPECT_DOUBLE_EQ(shown["run"]["mean_bytes"].get<double>(), run.bytes);
  json listed = shown["samples"]["samples"];
  ASSERT_EQ(listed.size(), samples.size());
  for (size_t i = 0; i < samples.size(); ++i) {
    EXPECT_EQ(listed[i]["id"], samples[i][0]);
    EXPECT_EQ(listed[i]["frame_ms"], samples[i][1]);
    EXPECT_EQ(listed[i]["bytes"], samples[i][2]);
  }

  Outcome table = tally({"show", id});
  ASSERT_EQ(table.rc, 0) << table.err;
  auto out = lines(table.out);
  ASSERT_GE(out.size(), 4u + samples.size()) << table.out;
  EXPECT_EQ(out[0], "run " + id + ": " + run.renderer + " on " + run.scene + " at " +
                        std::to_string(run.width) + "x" + std::to_string(run.height));
  EXPECT_EQ(out[1].rfind("device: " + run.device + "   host: " + run.host + "   capture: " + std::to_string(run.capture), 0), 0u)
      << out[1];
  // The build that made the run, as stored.
  json build = db.rows("SELECT tally_version, tally_commit FROM runs WHERE id = ?1", {run.id});
  ASSERT_EQ(build.size(), 1u);
  ASSERT_TRUE(build[0][1].is_string());
  EXPECT_NE(out[1].find("   built by: tally " + build[0][0].get<std::string>() + " (commit " +
                        build[0][1].get<std::string>() + ")"),
            std::string::npos)
      << out[1];
  // Then lines about the run (the device's ceilings where measured), a blank
  // line and the titles: CAMERA SKY FRAME-MS OVERHEAD IMAGE-ERROR READ/FRAME WRITTEN/FRAME
  size_t titles = 2;
  while (titles < out.size() && out[titles].rfind("CAMERA", 0) != 0) ++titles;
  ASSERT_GE(out.size(), titles + 1 + samples.size()) << table.out;
  EXPECT_TRUE(out[titles - 1].empty()) << table.out;
  for (size_t i = 0; i < samples.size(); ++i) {
    auto c = cells(out[titles + 1 + i]);
    ASSERT_EQ(c.size(), 7u) << out[titles + 1 + i];
    if (samples[i][3].is_null()) {
      EXPECT_EQ(c[1], "-");
    } else {
      EXPECT_TRUE(shows(parseFixed(c[1], "%"), samples[i][3].get<double>() * 100, c[1]));
    }
    EXPECT_TRUE(shows(parseFixed(c[2]), samples[i][1], c[2]));
    EXPECT_TRUE(shows(parseBytes(c[5]), samples[i][4], c[5]));
    EXPECT_TRUE(shows(parseBytes(c[6]), samples[i][5], c[6]));
  }
}

// The cells after PASS [RESOURCE] METRIC of a compare table row: #a #b delta#b
// ratio#b. An empty RESOURCE prints as nothing, so such rows have one cell less.
std::vector<std::string> comparedCells(const std::string& table, const std::string& pass,
                                       const std::string& resource, const std::string& metric) {
  for (const auto& c : rowsStartingWith(table, pass)) {
    if (resource.empty() && c.size() == 6 && c[1] == metric) return {c.begin() + 2, c.end()};
    if (!resource.empty() && c.size() == 7 && c[1] == resource && c[2] == metric)
      return {c.begin() + 3, c.end()};
  }
  return {};
}

// A compare row shows va, vb, their difference and their ratio (from the database).
::testing::AssertionResult comparesAs(const std::vector<std::string>& c, double va, double vb, bool bytes) {
  if (c.size() != 4) return ::testing::AssertionFailure() << "no such row";
  auto parse = [&](const std::string& cell) { return bytes ? parseBytes(cell) : parseFixed(cell); };
  for (auto check : {shows(parse(c[0]), va, c[0]), shows(parse(c[1]), vb, c[1]),
                     shows(parse(c[2]), vb - va, c[2]), shows(parseFixed(c[3], "x"), vb / va, c[3])})
    if (!check) return check;
  return ::testing::AssertionSuccess();
}

// `tally compare A B`: per frame, and per pass that both runs have.
void CliFlow::checkCompare(Db& db, const DbRun& a, const DbRun& b) {
  Outcome cmp = tally({"compare", std::to_string(a.id), std::to_string(b.id)});
  ASSERT_EQ(cmp.rc, 0) << cmp.err;
  EXPECT_TRUE(comparesAs(comparedCells(cmp.out, "(frame)", "", "ms"), a.frameMsMedian, b.frameMsMedian, false))
      << cmp.out;
  EXPECT_TRUE(comparesAs(comparedCells(cmp.out, "(frame)", "(all)", "bytes"), runCounterBytes(db, a.id),
                         runCounterBytes(db, b.id), true))
      << cmp.out;
  json shared = db.rows(
      "SELECT DISTINCT p.name FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?1 "
      "AND p.name IN (SELECT p2.name FROM passes p2 JOIN samples s2 ON s2.id = p2.sample_id "
      "WHERE s2.run_id = ?2)",
      {a.id, b.id});
  ASSERT_FALSE(shared.empty()) << "the two runs share no pass";
  for (const auto& p : shared) {
    std::string pass = p[0].get<std::string>();
    double va = runCounterBytes(db, a.id, " AND p.name = ?2", {pass});
    double vb = runCounterBytes(db, b.id, " AND p.name = ?2", {pass});
    if (va == 0) continue;  // no ratio to show
    EXPECT_TRUE(comparesAs(comparedCells(cmp.out, pass, "(all)", "bytes"), va, vb, true)) << pass;
  }
  // The significance rows: the frame's ratio is the ratio of the medians of
  // the per-frame times stored for each run, each camera's aligned on the
  // median of both runs' frames of that camera (docs/statistics.md).
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  auto framesOf = [&](int64_t run) {
    std::map<int64_t, std::vector<double>> byCamera;
    for (const auto& r : db.rows("SELECT camera_index, frame_ms_frames FROM samples WHERE run_id = ?1", {run})) {
      for (double t : json::parse(r[1].get<std::string>())) byCamera[r[0].get<int64_t>()].push_back(t);
    }
    return byCamera;
  };
  auto fa = framesOf(a.id), fb = framesOf(b.id);
  std::vector<double> all, alignedA, alignedB;
  for (const auto& [camera, times] : fa) {
    all.insert(all.end(), times.begin(), times.end());
    all.insert(all.end(), fb[camera].begin(), fb[camera].end());
  }
  double grand = median(all);
  for (const auto& [camera, times] : fa) {
    std::vector<double> both = times;
    both.insert(both.end(), fb[camera].begin(), fb[camera].end());
    double m = median(both);
    for (double t : times) alignedA.push_back(t * grand / m);
    for (double t : fb[camera]) alignedB.push_back(t * grand / m);
  }
  double ma = median(alignedA), mb = median(alignedB);
  ASSERT_GT(ma, 0);
  std::vector<std::vector<std::string>> frameRows;
  for (const auto& c : rowsStartingWith(cmp.out, "#" + std::to_string(b.id))) {
    if (c.size() > 2 && c[1] == "(frame)") frameRows.push_back(c);
  }
  ASSERT_EQ(frameRows.size(), 1u) << cmp.out;
  EXPECT_TRUE(shows(parseFixed(frameRows[0][2], "x"), mb / ma, frameRows[0][2])) << cmp.out;
  EXPECT_NE(cmp.out.find("#" + std::to_string(b.id) + ": counts "), std::string::npos) << cmp.out;
  // A bad level is refused by the client before any request.
  Outcome bad = tally({"compare", std::to_string(a.id), std::to_string(b.id), "--confidence", "1.5"});
  EXPECT_NE(bad.rc, 0);
  EXPECT_NE(bad.err.find("confidence"), std::string::npos) << bad.err;
}

// `tally export`: CSV to a file and JSON to stdout, row for row the database's
// counters per run x pass x resource x access, averaged over the run's samples.
void CliFlow::checkExport(Db& db, const Runs& runs) {
  using RowKey = std::tuple<int64_t, std::string, std::string, std::string>;  // run, pass, resource, access
  std::map<RowKey, double> want;                                              // bytes per frame
  double wantTotal = 0;
  for (const auto& [id, run] : runs) {
    json rows = db.rows(
        "SELECT p.name, c.resource, c.access, TOTAL(c.bytes) / ?2 FROM counters c "
        "JOIN passes p ON p.id = c.pass_id JOIN samples s ON s.id = p.sample_id WHERE s.run_id = ?1 "
        "GROUP BY p.name, c.resource, c.access",
        {id, run.samples});
    for (const auto& r : rows) {
      want[RowKey(id, r[0].get<std::string>(), r[1].get<std::string>(), r[2].get<std::string>())] =
          r[3].get<double>();
      wantTotal += r[3].get<double>();
    }
  }
  ASSERT_FALSE(want.empty());

  fs::path csvPath = dir_ / "export.csv";
  Outcome csv = tally({"export", "--format", "csv", "-o", csvPath.string()});
  ASSERT_EQ(csv.rc, 0) << csv.err;
  EXPECT_NE(csv.err.find("wrote " + csvPath.string()), std::string::npos) << csv.err;
  EXPECT_TRUE(csv.out.empty()) << csv.out;
  auto csvRows = parseCsv(slurp(csvPath));
  ASSERT_FALSE(csvRows.empty());
  const std::vector<std::string> header = {"run",  "renderer", "scene",  "width", "height", "device",
                                           "pass", "resource", "access", "count", "bytes"};
  EXPECT_EQ(csvRows[0], header);
  ASSERT_EQ(csvRows.size() - 1, want.size());
  double csvTotal = 0;
  for (size_t i = 1; i < csvRows.size(); ++i) {
    const auto& row = csvRows[i];
    ASSERT_EQ(row.size(), header.size());
    RowKey key(std::stoll(row[0]), row[6], row[7], row[8]);
    ASSERT_TRUE(want.count(key)) << "CSV row " << i << " is not in the database";
    EXPECT_EQ(row[5], runs.at(std::stoll(row[0])).device);
    EXPECT_DOUBLE_EQ(std::stod(row[10]), want[key]) << "CSV row " << i;
    csvTotal += std::stod(row[10]);
  }
  EXPECT_NEAR(csvTotal, wantTotal, 1e-9 * wantTotal);

  json rows = tallyJson({"export", "--format", "json"})["rows"];
  ASSERT_EQ(rows.size(), want.size());
  double jsonTotal = 0;
  for (const auto& r : rows) {
    RowKey key(r["run"].get<int64_t>(), r["pass"].get<std::string>(), r["resource"].get<std::string>(),
               r["access"].get<std::string>());
    ASSERT_TRUE(want.count(key)) << r.dump();
    EXPECT_DOUBLE_EQ(r["bytes"].get<double>(), want[key]);
    jsonTotal += r["bytes"].get<double>();
  }
  EXPECT_NEAR(jsonTotal, wantTotal, 1e-9 * wantTotal);

  // --runs narrows the export to those runs.
  const int64_t first = runs.begin()->first;
  json narrowed = tallyJson({"export", "--format", "json", "--runs", std::to_string(first)})["rows"];
  auto ofFirst =
      std::count_if(want.begin(), want.end(), [&](const auto& w) { return std::get<0>(w.first) == first; });
  EXPECT_EQ(narrowed.size(), static_cast<size_t>(ofFirst));
  for (const auto& r : narrowed) EXPECT_EQ(r["run"], first);
}

// `tally cancel` of a finished capture is refused, and the capture is kept with its runs.
void CliFlow::checkCancelRefused(Db& db, int64_t capture) {
  json runsBefore = db.row("SELECT COUNT(*) FROM runs WHERE job_id = ?1", {capture});
  Outcome cancel = tally({"cancel", std::to_string(capture)});
  EXPECT_EQ(cancel.rc, 1) << cancel.out;
  EXPECT_NE(cancel.err.find("409"), std::string::npos) << cancel.err;
  EXPECT_NE(cancel.err.find("already finished"), std::string::npos) << cancel.err;
  EXPECT_EQ(db.row("SELECT status FROM jobs WHERE id = ?1", {capture}), json::array({"done"}));
  EXPECT_EQ(db.row("SELECT COUNT(*) FROM runs WHERE job_id = ?1", {capture}), runsBefore);
  EXPECT_GT(runsBefore[0].get<int64_t>(), 0);
}

TEST_F(CliFlow, CaptureThenEveryViewMatchesTheDatabase) {
  int64_t capture = 0;
  ASSERT_NO_FATAL_FAILURE(captureWithProgress(capture));
  Db db(this->db());
  ASSERT_TRUE(db.ok());
  Runs runs = dbRuns(db);
  ASSERT_EQ(runs.size(), 2u);
  checkStatus(db, capture);
  checkRunsJson(db, runs);
  checkRunsTable(runs);
  for (const auto& [id, run] : runs) checkShow(db, run);
  const DbRun& forward =
      runs.begin()->second.renderer == "forward" ? runs.begin()->second : runs.rbegin()->second;
  const DbRun& deferred =
      runs.begin()->second.renderer == "forward" ? runs.rbegin()->second : runs.begin()->second;
  checkCompare(db, forward, deferred);
  checkExport(db, runs);
  checkCancelRefused(db, capture);
}

// A capture left running (--no-wait) is cancelled; nothing of it is stored.
TEST_F(CliFlow, CancelACaptureInFlight) {
  Outcome posted = tally({"capture", "--spec", writeSpec(longSpec()), "--no-wait"});
  ASSERT_EQ(posted.rc, 0) << posted.err;
  std::string id = posted.out.substr(0, posted.out.find('\n'));
  ASSERT_FALSE(id.empty());
  ASSERT_EQ(id.find_first_not_of("0123456789"), std::string::npos) << posted.out;

  Outcome cancel = tally({"cancel", id});
  EXPECT_EQ(cancel.rc, 0) << cancel.err;
  EXPECT_EQ(cancel.out, "capture " + id + " cancelled\n");
  EXPECT_EQ(daemon_->waitFinished(std::stoll(id)).value("status", ""), "cancelled");
  Db db(this->db());
  ASSERT_TRUE(db.ok());
  EXPECT_EQ(db.row("SELECT status FROM jobs WHERE id = ?1", {std::stoll(id)}), json::array({"cancelled"}));
  EXPECT_EQ(db.row("SELECT COUNT(*) FROM runs"), json::array({0}));

  Outcome status = tally({"status", id, "--json"});
  ASSERT_EQ(status.rc, 0) << status.err;
  EXPECT_EQ(json::parse(status.out, nullptr, false)["status"], "cancelled");
}

// Nothing listens on the port: every subcommand fails with the address and a
// reason, not a hang or a crash.
TEST(CliWithoutServer, EverySubcommandSaysTheServerIsDown) {
  fs::path dir = makeTempDir("tally-cli-down");
  // A socket bound but not listening holds the port: connecting is refused.
  int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(sock, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  socklen_t length = sizeof addr;
  ASSERT_EQ(::getsockname(sock, reinterpret_cast<sockaddr*>(&addr), &length), 0);
  const std::string server = "http://127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  fs::path spec = dir / "spec.json";
  std::ofstream(spec) << tinySpec().dump();

  const std::vector<std::vector<std::string>> commands = {{"capture", "--spec", spec.string()},
                                                          {"status"},
                                                          {"status", "1"},
                                                          {"cancel", "1"},
                                                          {"runs"},
                                                          {"show", "1"},
                                                          {"compare", "1", "2"},
                                                          {"crossover", "1"},
                                                          {"export", "--format", "json"}};
  for (auto args : commands) {
    SCOPED_TRACE(args[0]);
    args.insert(args.begin(), {"--server", server});
    Outcome r = runTally(dir, args, 30s);
    EXPECT_EQ(r.rc, 1);
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_NE(r.err.find("cannot reach tallyd at " + server), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("connection refused"), std::string::npos) << r.err;
  }
  ::close(sock);
  fs::remove_all(dir);
}

// Each subcommand's --help exits 0 and lists every option it takes.
TEST(CliHelp, EverySubcommandListsItsOptions) {
  fs::path dir = makeTempDir("tally-cli-help");
  const std::vector<std::string> filters = {"--renderer", "--scene",  "--width",
                                            "--height",   "--device", "--capture"};
  std::map<std::string, std::vector<std::string>> options = {
      {"capture", {"--spec", "--no-wait", "--idempotency-key", "--interval"}},
      {"status", {"ID"}},
      {"cancel", {"ID"}},
      {"runs", {"--limit", "--all"}},
      {"show", {"RUN"}},
      {"compare", {"RUN"}},
      {"crossover", {"CAPTURE", "--metric"}},
      {"heatmap", {"CAPTURE", "--renderer", "--versus", "--metric", "--yaw"}},
      {"hotspots", {"RUN", "--pass", "--by", "--top", "--sample"}},
      {"export", {"--format", "--runs", "--output"}},
  };
  for (const auto& f : filters) {
    options["runs"].push_back(f);
    options["export"].push_back(f);
  }
  for (const auto& [sub, names] : options) {
    SCOPED_TRACE(sub);
    Outcome r = runTally(dir, {sub, "--help"}, 30s);
    EXPECT_EQ(r.rc, 0) << r.err;
    for (const auto& name : names) EXPECT_NE(r.out.find(name), std::string::npos) << name << " in\n" << r.out;
    EXPECT_NE(r.out.find("Example:"), std::string::npos) << r.out;
  }
  // What cancel does to a finished capture (refuses it, see above), not what it does not.
  Outcome cancel = runTally(dir, {"cancel", "--help"}, 30s);
  EXPECT_NE(cancel.out.find("queued or running"), std::string::npos) << cancel.out;
  EXPECT_EQ(cancel.out.find("deleted"), std::string::npos) << cancel.out;
  fs::remove_all(dir);
}

// A sweep spec through `tally capture`; `tally sweeps` and `tally sweep` show
// what the database holds. Where it fails is recomputed here from the stored
// points (per group of points that differ only in the swept value, the
// smallest failing value), not read from the stored fails_at.
TEST_F(CliFlow, SweepThroughCaptureThenSweepsAndSweep) {
  const double threshold = 1e-3;  // between the 3 m and 300 m errors (tests/service/sweeps_test.cpp)
  json spec = {{"sweep", "depth-reconstruction"}, {"near", {0.01}}, {"far", {1000}}, {"distances", {3, 300}},
               {"resolution", {32, 18}}, {"threshold", {{"relative", threshold}}}};
  Outcome cap = tally({"capture", "--spec", writeSpec(spec), "--interval", "0.1"});
  ASSERT_EQ(cap.rc, 0) << cap.out << cap.err;
  Db db(this->db());
  ASSERT_TRUE(db.ok());
  json row = db.row(
      "SELECT s.id, s.job_id, s.name, s.created_at, d.name, s.point_count, s.result FROM sweeps s "
      "JOIN devices d ON d.id = s.device_id");
  ASSERT_TRUE(row.is_array()) << "no sweep stored: " << cap.err;
  const std::string id = row[0].dump(), job = row[1].dump();
  const json result = json::parse(row[6].get<std::string>());
  EXPECT_EQ(cap.out, "capture " + job + " done: sweep " + id + " (see `tally sweep " + id + "`)\n");

  // Per swept axis: the groups (the other two of near/far/distance fixed) and
  // the smallest value of the axis whose error reaches the threshold.
  std::map<std::string, std::map<std::string, std::optional<double>>> expected;  // axis -> group -> value
  for (const auto& [axis, others] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"distance", {"far", "near"}}, {"far_over_near", {"distance", "far"}}}) {
    for (const auto& p : result["points"]) {
      std::string group;
      for (const auto& o : others) {
        char value[32];
        std::snprintf(value, sizeof value, "%.6g", p[o].get<double>());  // as the client prints a value
        group += (group.empty() ? "" : " ") + o + "=" + value;
      }
      auto& value = expected[axis][group];
      double x = p[axis].get<double>();
      if (p["error"]["max_relative"].get<double>() >= threshold && (!value || x < *value)) value = x;
    }
  }
  ASSERT_EQ(expected["distance"].size(), 1u);
  ASSERT_EQ(expected["far_over_near"].size(), 2u);

  // The list: one row, its failing groups counted per axis.
  Outcome list = tally({"sweeps"});
  ASSERT_EQ(list.rc, 0) << list.err;
  auto listed = rowsStartingWith(list.out, id);
  ASSERT_EQ(listed.size(), 1u) << list.out;
  auto failing = [&](const std::string& axis) {
    int n = 0;
    for (const auto& [group, value] : expected[axis]) n += value ? 1 : 0;
    return axis + " " + std::to_string(n) + "/" + std::to_string(expected[axis].size());
  };
  EXPECT_EQ(listed[0], (std::vector<std::string>{id, job, row[2], row[3], row[4], row[5].dump(), "relative 0.001",
                                                 failing("distance") + ", " + failing("far_over_near")}))
      << list.out;
  EXPECT_EQ(rowsStartingWith(tally({"sweeps", "--name", "material-edges"}).out, id).size(), 0u);
  json listedJson = tallyJson({"sweeps", "--json"});
  ASSERT_EQ(listedJson["sweeps"].size(), 1u);
  EXPECT_EQ(listedJson["sweeps"][0]["id"].dump(), id);

  // One sweep: fails_at group by group, then the points.
  Outcome one = tally({"sweep", id});
  ASSERT_EQ(one.rc, 0) << one.err;
  for (const auto& [axis, groups] : expected) {
    auto shown = rowsStartingWith(one.out, axis);
    ASSERT_EQ(shown.size(), groups.size()) << one.out;
    for (const auto& cellsOfRow : shown) {
      ASSERT_EQ(cellsOfRow.size(), 3u) << one.out;
      ASSERT_TRUE(groups.count(cellsOfRow[1])) << cellsOfRow[1] << " in\n" << one.out;
      const auto& value = groups.at(cellsOfRow[1]);
      if (!value) {
        EXPECT_EQ(cellsOfRow[2], "holds over the range");
      } else {
        EXPECT_NEAR(std::stod(cellsOfRow[2]), *value, 1e-5 * *value) << one.out;  // "%.6g"
      }
    }
  }
  auto header = rowsStartingWith(one.out, "near");
  ASSERT_EQ(header.size(), 1u) << one.out;
  EXPECT_EQ(header[0], (std::vector<std::string>{"near", "far", "distance", "error.max_relative", "far_over_near"}));
  std::vector<std::vector<std::string>> points = rowsStartingWith(one.out, "0.01");
  ASSERT_EQ(points.size(), result["points"].size()) << one.out;
  for (size_t i = 0; i < points.size(); ++i) {
    const json& p = result["points"][i];
    std::vector<double> want = {p["near"].get<double>(), p["far"].get<double>(), p["distance"].get<double>(),
                                p["error"]["max_relative"].get<double>(), p["far_over_near"].get<double>()};
    ASSERT_EQ(points[i].size(), want.size());
    for (size_t k = 0; k < want.size(); ++k) EXPECT_NEAR(std::stod(points[i][k]), want[k], 1e-5 * want[k]);
  }
  json raw = tallyJson({"sweep", id, "--json"});
  EXPECT_EQ(raw["result"], result);
  EXPECT_EQ(raw["job_id"].dump(), job);

  Outcome missing = tally({"sweep", "987654"});
  EXPECT_EQ(missing.rc, 1);
  EXPECT_NE(missing.err.find("404"), std::string::npos) << missing.err;
  EXPECT_NE(missing.err.find("no sweep 987654"), std::string::npos) << missing.err;
}

}  // namespace
