// The tally binary as a subprocess against the fake tallyd: tables, --json,
// errors and exit codes, capture waiting, export files.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <gtest/gtest.h>

#include "fake_tallyd.hpp"
#include "read_file.hpp"

namespace tally::client {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::FakeTallyd;

struct Outcome {
  int rc = -1;
  std::string out, err;
};

class TallyCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally_cli_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs tally with args (already shell-quoted where needed); TALLY_* from the
  // test environment are cleared so only the flags count.
  Outcome tally(const std::string& args, const std::string& stdinFile = "") {
    std::string cmd = "env -u TALLY_SERVER -u TALLY_TOKEN '" + std::string(TALLY_BIN) + "' " + args + " >'" +
                      (dir_ / "out").string() + "' 2>'" + (dir_ / "err").string() + "'";
    if (!stdinFile.empty()) cmd += " <'" + stdinFile + "'";
    int status = std::system(cmd.c_str());
    Outcome r;
    r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = tally::test::readFile(dir_ / "out");
    r.err = tally::test::readFile(dir_ / "err");
    if (std::getenv("TALLY_TEST_PRINT")) std::cout << "$ tally " << args << "\n" << r.out << r.err;
    return r;
  }
  std::string writeSpec(const std::string& text) {
    auto p = dir_ / "spec.json";
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path dir_;
};

TEST_F(TallyCli, VersionAndHelp) {
  Outcome v = tally("--version");
  EXPECT_EQ(v.rc, 0);
  EXPECT_NE(v.out.find("API v1"), std::string::npos);
  for (const char* sub : {"capture", "status", "runs", "show", "compare", "crossover", "export", "cancel", "hosts"}) {
    Outcome h = tally(std::string(sub) + " --help");
    EXPECT_EQ(h.rc, 0) << sub;
    EXPECT_NE(h.out.find("Example:"), std::string::npos) << sub;
  }
}

TEST_F(TallyCli, RunsTableShowsValues) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " runs --renderer deferred");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("RENDERER"), std::string::npos);
  EXPECT_NE(r.out.find("visbuffer"), std::string::npos);
  EXPECT_NE(r.out.find("320x180"), std::string::npos);
  EXPECT_NE(r.out.find("1.834"), std::string::npos);
  EXPECT_NE(r.out.find("3.00 MiB"), std::string::npos);
  EXPECT_EQ(r.out.find("forward"), std::string::npos);  // second page not fetched
  EXPECT_NE(r.err.find("--all"), std::string::npos);
  EXPECT_EQ(fake.lastRunsQuery().find("renderer")->second, "deferred");

  Outcome all = tally("runs --all --server " + fake.url());
  ASSERT_EQ(all.rc, 0) << all.err;
  EXPECT_NE(all.out.find("forward"), std::string::npos);
  EXPECT_NE(all.out.find("640x180"), std::string::npos);
}

TEST_F(TallyCli, JsonPrintsServerJson) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " --json runs --all");
  ASSERT_EQ(r.rc, 0) << r.err;
  json j = json::parse(r.out);
  ASSERT_EQ(j["runs"].size(), 3u);
  EXPECT_EQ(j["runs"][0]["extra_field"], json({1, 2}));

  Outcome s = tally("status 8 --json --server " + fake.url());
  ASSERT_EQ(s.rc, 0) << s.err;
  EXPECT_EQ(json::parse(s.out)["id"], 8);
}

TEST_F(TallyCli, StatusOneAndList) {
  FakeTallyd fake;
  Outcome list = tally("--server " + fake.url() + " status");
  ASSERT_EQ(list.rc, 0) << list.err;
  EXPECT_NE(list.out.find("out of memory"), std::string::npos);
  EXPECT_NE(list.out.find("12/40"), std::string::npos);
  Outcome one = tally("--server " + fake.url() + " status 7");
  ASSERT_EQ(one.rc, 0) << one.err;
  EXPECT_NE(one.out.find("queued"), std::string::npos);
  EXPECT_NE(one.out.find("0/40"), std::string::npos);
}

// A fleet: `tally hosts` prints one row per host of GET /api/hosts (the fake's
// three: gpu-b's device name overridden, gpu-c stale and not probed), and
// says on stderr how many are stale.
TEST_F(TallyCli, HostsTable) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " hosts");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.out,
            "NAME   ROLE    DEVICE                 DRIVER     VERSION          HEARTBEAT  STATE  DONE  "
            "FAILED  JOB\n"
            "gpu-a  worker  NVIDIA H100 80GB HBM3  550.54.15  0.1.0 (abc1234)    3 s ago  alive     4       "
            "1   12\n"
            "gpu-b  all     FakeGPU-A (override)   560.35.03  0.1.0 (abc1234)    0 s ago  alive     0       "
            "0    -\n"
            "gpu-c  worker  (not probed)           -          0.1.0 (def5678)  2 min ago  stale     7       "
            "2    -\n");
  EXPECT_EQ(r.err, "1 host is stale: no heartbeat in the last 30 s\n");

  Outcome j = tally("--server " + fake.url() + " hosts --json");
  ASSERT_EQ(j.rc, 0) << j.err;
  EXPECT_EQ(json::parse(j.out), test::hostsJson());
}

// A job of the fleet: the host that holds it, attempts of the most it gets,
// why each earlier attempt ended, and why a queued one waits.
TEST_F(TallyCli, StatusShowsHostAttemptsAndWhyItWaits) {
  FakeTallyd fake;
  Outcome queued = tally("--server " + fake.url() + " status 9");
  ASSERT_EQ(queued.rc, 0) << queued.err;
  EXPECT_NE(queued.out.find(std::string("waiting        ") + test::kWaitingReason + "\n"), std::string::npos)
      << queued.out;
  EXPECT_NE(queued.out.find("attempts       1/3\n"), std::string::npos) << queued.out;
  EXPECT_NE(queued.out.find(std::string("attempt error  ") + test::kLostAttempt + "\n"), std::string::npos)
      << queued.out;
  EXPECT_EQ(queued.out.find("host"), std::string::npos) << queued.out;  // nobody holds it

  Outcome running = tally("--server " + fake.url() + " status 10");
  ASSERT_EQ(running.rc, 0) << running.err;
  EXPECT_NE(running.out.find("host           gpu-a\n"), std::string::npos) << running.out;
  EXPECT_NE(running.out.find("attempts       2/3\n"), std::string::npos) << running.out;
  EXPECT_EQ(running.out.find("waiting"), std::string::npos) << running.out;

  // The list: a HOST column, attempts of the most, the waiting reason in place of an error.
  Outcome list = tally("--server " + fake.url() + " status");
  ASSERT_EQ(list.rc, 0) << list.err;
  EXPECT_EQ(list.out.rfind("ID  STATUS   HOST   PROGRESS  ATTEMPTS  CREATED               ERROR\n", 0), 0u)
      << list.out;
  EXPECT_NE(
      list.out.find(std::string(" 9  queued   -           0/4       1/3  2026-11-21T06:32:00Z  waiting: ") +
                    test::kWaitingReason + "\n"),
      std::string::npos)
      << list.out;
  EXPECT_NE(list.out.find(" 8  failed   gpu-b       1/4         2  "), std::string::npos) << list.out;
  EXPECT_NE(list.out.find(" 7  running  gpu-a     12/40       1/3  "), std::string::npos) << list.out;

  // `tally capture` says why its job waits while it is queued.
  Outcome waits = tally("--server " + fake.url() + " capture --interval 0.02 --spec '" +
                        writeSpec(R"({"renderers":["deferred"],"waits":true})") + "'");
  ASSERT_EQ(waits.rc, 0) << waits.err;
  EXPECT_NE(waits.err.find(std::string("(queued: ") + test::kWaitingReason + ")"), std::string::npos)
      << waits.err;
  EXPECT_NE(waits.out.find("capture 11 done: runs 21"), std::string::npos) << waits.out;
}

// --host goes to /api/runs as ?host=; a page with hosts gets a HOST column
// ("-" for a run stored before hosts), a page without keeps its table.
TEST_F(TallyCli, RunsByHost) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " runs --host gpu-a");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(fake.lastRunsQuery().find("host")->second, "gpu-a");
  EXPECT_NE(r.out.find("DEVICE                            HOST   SAMPLES"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("llvmpipe (LLVM 15.0.6, 256 bits)  gpu-a        2"), std::string::npos) << r.out;

  Outcome mixed = tally("--server " + fake.url() + " runs --capture 21");
  ASSERT_EQ(mixed.rc, 0) << mixed.err;
  EXPECT_EQ(fake.lastRunsQuery().count("host"), 0u);
  EXPECT_NE(mixed.out.find(
                "21        7  deferred  atrium  320x180  llvmpipe (LLVM 15.0.6, 256 bits)  gpu-a        2"),
            std::string::npos)
      << mixed.out;
  EXPECT_NE(mixed.out.find(
                "12        7  deferred  atrium  320x180  llvmpipe (LLVM 15.0.6, 256 bits)  -            2"),
            std::string::npos)
      << mixed.out;

  Outcome plain = tally("--server " + fake.url() + " runs");
  ASSERT_EQ(plain.rc, 0) << plain.err;
  EXPECT_EQ(plain.out.find("HOST"), std::string::npos) << plain.out;

  Outcome show = tally("--server " + fake.url() + " show 21");
  ASSERT_EQ(show.rc, 0) << show.err;
  EXPECT_NE(show.out.find("device: llvmpipe (LLVM 15.0.6, 256 bits)   host: gpu-a   capture: 7"),
            std::string::npos)
      << show.out;
  Outcome old = tally("--server " + fake.url() + " show 12");
  EXPECT_EQ(old.out.find("host:"), std::string::npos) << old.out;
}

TEST_F(TallyCli, ShowRunAndSamples) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " show 12");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("run 12: deferred on atrium at 320x180"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("31.0%"), std::string::npos);
  EXPECT_NE(r.out.find("1.830"), std::string::npos);
  EXPECT_NE(r.out.find("1.10x"), std::string::npos);
  EXPECT_NE(r.out.find("41.2 dB vs forward"), std::string::npos);
  EXPECT_NE(r.out.find("identical"), std::string::npos);
  EXPECT_NE(r.out.find("1 half sky"), std::string::npos);
  EXPECT_NE(r.out.find("1.00 MiB"), std::string::npos);  // read: 2 KiB + 1 MiB
  EXPECT_NE(r.out.find("1.00 KiB"), std::string::npos);  // written
}

TEST_F(TallyCli, ShowPrintsTheScenesAndTheRenderersNotes) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " show 17");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("scene note: KHR_materials_clearcoat: used but not implemented; clearcoat is not drawn\n"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("note: zprepass_fragment_shader = counting_only\n"), std::string::npos) << r.out;
  // A run without notes prints none.
  Outcome plain = tally("--server " + fake.url() + " show 12");
  EXPECT_EQ(plain.out.find("note:"), std::string::npos) << plain.out;
}

// The device's ceilings measured by the run's capture (the roofline's), in
// SI units; none where the run has none.
TEST_F(TallyCli, ShowPrintsTheCeilings) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " show 19");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("ceilings: bandwidth 5.3 GB/s   arithmetic 123.4 Gop/s   (copy of 64.00 MiB)\n"),
            std::string::npos) << r.out;
  Outcome plain = tally("--server " + fake.url() + " show 12");
  EXPECT_EQ(plain.out.find("ceilings:"), std::string::npos) << plain.out;
}

// Variants: the runs table's renderer column and `show` carry the variant
// label; `show` lists the options and each sample's error against the
// reference variant; --variant is passed through as the filter.
TEST_F(TallyCli, VariantsAreLabelled) {
  FakeTallyd fake;
  const std::string label = "visbuffer barycentrics=float32 material_selection=uniform";
  Outcome list = tally("--server " + fake.url() + " runs --variant '" + label + "'");
  ASSERT_EQ(list.rc, 0) << list.err;
  EXPECT_EQ(fake.lastRunsQuery().find("variant")->second, label);
  EXPECT_NE(list.out.find(label), std::string::npos) << list.out;

  Outcome show = tally("--server " + fake.url() + " show 16");
  ASSERT_EQ(show.rc, 0) << show.err;
  EXPECT_NE(show.out.find("run 16: " + label + " on atrium at 320x180"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("options: barycentrics=float32 material_selection=uniform"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("VARIANT ERROR"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("37.5 dB vs visbuffer barycentrics=float32"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("identical vs visbuffer barycentrics=float32"), std::string::npos) << show.out;

  // A run without options: no options line, no variant column.
  Outcome plain = tally("--server " + fake.url() + " show 12");
  ASSERT_EQ(plain.rc, 0) << plain.err;
  EXPECT_EQ(plain.out.find("options:"), std::string::npos) << plain.out;
  EXPECT_EQ(plain.out.find("VARIANT ERROR"), std::string::npos) << plain.out;
}

TEST_F(TallyCli, CrossoverTables) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " crossover 7");
  ASSERT_EQ(r.rc, 0) << r.err;
  for (const char* text : {"bytes per frame", "FITS", "RESIDUALS", "CROSSINGS", "A 95% CI", "deferred",
                           "1.00 MiB",      // a of deferred
                           "38.15 MiB/Mpx",  // b of deferred: 40 B per pixel
                           "0.9991", "POOR (not linear)", "none: a fit needs at least 3 resolutions, got 2",
                           "1280x720", "#31", "crosses", "800000", "760000 .. 840000", "1193x671",
                           "1162x654 .. 1222x687", "deferred below, visbuffer above", "parallel within error",
                           "deferred throughout"}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << " in\n" << r.out;
  }
  Outcome ms = tally("--server " + fake.url() + " crossover 7 --metric frame_ms");
  ASSERT_EQ(ms.rc, 0) << ms.err;
  EXPECT_NE(ms.out.find("frame time (ms)"), std::string::npos) << ms.out;
  Outcome j = tally("--server " + fake.url() + " --json crossover 7");
  ASSERT_EQ(j.rc, 0) << j.err;
  json body = json::parse(j.out);
  EXPECT_EQ(body["crossings"][0]["kind"], "crosses");
  Outcome missing = tally("--server " + fake.url() + " crossover 8");
  EXPECT_EQ(missing.rc, 1);
  EXPECT_NE(missing.err.find("no capture 8"), std::string::npos) << missing.err;
  Outcome badMetric = tally("--server " + fake.url() + " crossover 7 --metric watts");
  EXPECT_EQ(badMetric.rc, 2);
  Outcome noId = tally("--server " + fake.url() + " crossover");
  EXPECT_EQ(noId.rc, 2);
}

TEST_F(TallyCli, CompareTable) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " compare 12 15");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("#12"), std::string::npos);
  EXPECT_NE(r.out.find("ratio#15"), std::string::npos);
  EXPECT_NE(r.out.find("gbuffer"), std::string::npos);
  EXPECT_NE(r.out.find("0.75x"), std::string::npos);
  EXPECT_NE(r.out.find("-2.00 MiB"), std::string::npos);
  EXPECT_NE(r.out.find("gbuffer.normal (write)"), std::string::npos);

  Outcome one = tally("--server " + fake.url() + " compare 12");
  EXPECT_EQ(one.rc, 2);  // usage error
  Outcome five = tally("--server " + fake.url() + " compare 1 2 3 4 5");
  EXPECT_EQ(five.rc, 2);
}

// Footprint: a run counted with it shows its block size, requested bytes
// beside footprint and reuse per camera and per line, headed "REQUESTED" and
// "FOOTPRINT"; a run without keeps its table as it was.
TEST_F(TallyCli, ShowHasFootprintColumnsWhenTheRunHasFootprint) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " show 18");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.out.find("footprint: 64-byte blocks"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("REQUESTED READ/FRAME"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("REQUESTED WRITTEN/FRAME"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("FOOTPRINT/FRAME"), std::string::npos) << r.out;
  // Camera 0: 1.00 KiB of footprint, reuse 2.50x; camera 1: 512 B, 4.00x.
  EXPECT_NE(r.out.find("1.00 KiB  2.50x\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("512 B  4.00x\n"), std::string::npos) << r.out;
  // The line table: 2 MiB requested of 512 KiB touched, 4x; the depth line has no footprint.
  EXPECT_NE(r.out.find("gbuffer  material_maps.diffuse  read   "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2.00 MiB       512.00 KiB  4.00x\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("4.00 KiB                -      -\n"), std::string::npos) << r.out;

  Outcome plain = tally("--server " + fake.url() + " show 12");
  ASSERT_EQ(plain.rc, 0) << plain.err;
  EXPECT_EQ(plain.out.find("FOOTPRINT"), std::string::npos) << plain.out;
  EXPECT_EQ(plain.out.find("REQUESTED"), std::string::npos) << plain.out;
  EXPECT_NE(plain.out.find("READ/FRAME"), std::string::npos) << plain.out;
}

TEST_F(TallyCli, RunsAndCompareShowFootprintBesideRequestedBytes) {
  FakeTallyd fake;
  Outcome runs = tally("--server " + fake.url() + " runs --capture 18");
  ASSERT_EQ(runs.rc, 0) << runs.err;
  EXPECT_NE(runs.out.find("REQUESTED/FRAME"), std::string::npos) << runs.out;
  EXPECT_NE(runs.out.find("FOOTPRINT/FRAME"), std::string::npos) << runs.out;
  EXPECT_NE(runs.out.find("3.00 MiB         1.00 MiB  3.00x\n"), std::string::npos) << runs.out;  // run 18
  EXPECT_NE(runs.out.find("3.00 MiB                -      -\n"), std::string::npos) << runs.out;  // run 12: none

  Outcome cmp = tally("--server " + fake.url() + " compare 18 12");
  ASSERT_EQ(cmp.rc, 0) << cmp.err;
  // Each quantity names its bytes; footprint rows for the run that has one, "-" for the other.
  EXPECT_NE(cmp.out.find("(frame)       (all)                         requested      4.00 MiB  2.00 MiB  -2.00 MiB     0.50x\n"), std::string::npos) << cmp.out;
  EXPECT_NE(cmp.out.find("(frame)       (all)                         footprint      1.00 MiB         -          -         -\n"), std::string::npos) << cmp.out;
  EXPECT_NE(cmp.out.find("(all passes)  material_maps.diffuse (read)  reuse             8.00x         -"), std::string::npos) << cmp.out;
  EXPECT_NE(cmp.out.find("gbuffer       (all)                         footprint    512.00 KiB"), std::string::npos) << cmp.out;
  EXPECT_EQ(cmp.out.find(" bytes "), std::string::npos) << cmp.out;  // every bytes row says which

  // Runs without footprint anywhere: no footprint rows, the bytes rows as they were.
  Outcome plain = tally("--server " + fake.url() + " compare 12 15");
  ASSERT_EQ(plain.rc, 0) << plain.err;
  EXPECT_EQ(plain.out.find("footprint"), std::string::npos) << plain.out;
  EXPECT_EQ(plain.out.find("requested"), std::string::npos) << plain.out;
  EXPECT_NE(plain.out.find("(frame)       (all)                   bytes          4.00 MiB"), std::string::npos) << plain.out;
}

TEST_F(TallyCli, ServerErrorGivesMessageAndExit1) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " compare 12 99");
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.err, "tally: error (400 invalid_field, field runs[1]): run 99 not found\n");
  EXPECT_EQ(r.out, "");
  Outcome missing = tally("--server " + fake.url() + " show 404");
  EXPECT_EQ(missing.rc, 1);
  EXPECT_EQ(missing.err, "tally: error (404 not_found): run 404 not found\n");
}

TEST_F(TallyCli, RefusedConnection) {
  std::string url = "http://127.0.0.1:" + std::to_string(test::deadPort());
  Outcome r = tally("--server " + url + " runs");
  EXPECT_EQ(r.rc, 1);
  EXPECT_EQ(r.err,
            "tally: cannot reach tallyd at " + url + ": connection refused (is `tallyd serve` running?)\n");
}

TEST_F(TallyCli, ServerFromEnvironment) {
  FakeTallyd fake;
  std::string cmd =
      "TALLY_SERVER=" + fake.url() + " '" + std::string(TALLY_BIN) + "' status 8 >/dev/null 2>&1";
  int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST_F(TallyCli, TokenFromEnvironment) {
  FakeTallyd fake;
  std::string cmd = "TALLY_TOKEN=t0ken '" + std::string(TALLY_BIN) + "' --server " + fake.url() +
                    " capture --no-wait --spec '" + writeSpec(R"({"renderers":["forward"]})") +
                    "' >/dev/null 2>&1";
  int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(fake.lastAuthorization(), "Bearer t0ken");
}

TEST_F(TallyCli, ExportWritesFile) {
  FakeTallyd fake;
  auto out = dir_ / "runs.csv";
  Outcome r = tally("--server " + fake.url() + " export --format csv --capture 7 -o '" + out.string() + "'");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(tally::test::readFile(out), "run_id,renderer,bytes\n12,deferred,3145728\n");
  EXPECT_EQ(r.out, "");
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir_))
    files += e.path().filename().string().find(".tmp.") != std::string::npos;
  EXPECT_EQ(files, 0);  // no temporary left behind

  Outcome stdoutJson = tally("--server " + fake.url() + " export --format json");
  ASSERT_EQ(stdoutJson.rc, 0) << stdoutJson.err;
  EXPECT_EQ(stdoutJson.out, R"({"rows":[{"run_id":12,"renderer":"deferred"}]})");
}

// export --trace: one sample's trace, verbatim, to a file or stdout; a run
// filter or --format beside it is a usage error; an unknown sample fails.
TEST_F(TallyCli, ExportTraceWritesTheSamplesTrace) {
  FakeTallyd fake;
  auto out = dir_ / "sample.trace.json";
  Outcome r = tally("--server " + fake.url() + " export --trace 42 -o '" + out.string() + "'");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.out, "");
  json trace = json::parse(tally::test::readFile(out));
  EXPECT_EQ(trace["metadata"]["sample"], 42);
  ASSERT_TRUE(trace["traceEvents"].is_array());
  EXPECT_EQ(trace["traceEvents"][0]["ph"], "X");

  Outcome toStdout = tally("--server " + fake.url() + " export --trace 42");
  ASSERT_EQ(toStdout.rc, 0) << toStdout.err;
  EXPECT_EQ(json::parse(toStdout.out)["displayTimeUnit"], "ms");

  EXPECT_EQ(tally("--server " + fake.url() + " export --trace 42 --scene atrium").rc, 2);
  EXPECT_EQ(tally("--server " + fake.url() + " export --trace 42 --format json").rc, 2);
  Outcome missing = tally("--server " + fake.url() + " export --trace 404");
  EXPECT_EQ(missing.rc, 1);
  EXPECT_NE(missing.err.find("no sample 404"), std::string::npos) << missing.err;
}

TEST_F(TallyCli, CaptureWaitsUntilDone) {
  FakeTallyd fake;
  std::string spec = writeSpec(R"({"renderers":["deferred"],"resolutions":[[320,180]]})");
  Outcome r =
      tally("--server " + fake.url() + " capture --spec '" + spec + "' --interval 0.02 --idempotency-key k1");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_NE(r.err.find("] 12/40 deferred atrium 320x180 camera 3"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[####################] 40/40"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("capture 7 done: runs 12 15"), std::string::npos) << r.out;
  EXPECT_EQ(fake.lastIdempotencyKey(), "k1");
}

TEST_F(TallyCli, CaptureFromStdinFails) {
  FakeTallyd fake;
  std::string spec = writeSpec(R"({"renderers":["deferred"],"resolutions":[[320,180]],"fail":true})");
  Outcome r = tally("--server " + fake.url() + " capture --spec - --interval 0.02", spec);
  EXPECT_EQ(r.rc, 1);
  EXPECT_NE(r.err.find("tally: capture 8 failed: device lost during deferred atrium 320x180 camera 1"),
            std::string::npos)
      << r.err;
}

TEST_F(TallyCli, CaptureNoWaitAndBadSpec) {
  FakeTallyd fake;
  Outcome r = tally("--server " + fake.url() + " capture --no-wait --spec '" +
                    writeSpec(R"({"renderers":["forward"]})") + "'");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(r.out, "7\n");

  Outcome invalid = tally("--server " + fake.url() + " capture --spec '" +
                          writeSpec(R"({"renderers":["forward"],"resolutions":[[0,180]]})") + "'");
  EXPECT_EQ(invalid.rc, 1);
  EXPECT_NE(invalid.err.find("error (400 invalid_field, field resolutions[0][0])"), std::string::npos);

  Outcome notJson = tally("--server " + fake.url() + " capture --spec '" + writeSpec("{oops") + "'");
  EXPECT_EQ(notJson.rc, 1);
  EXPECT_NE(notJson.err.find("not valid JSON"), std::string::npos);
}

}  // namespace
}  // namespace tally::client
