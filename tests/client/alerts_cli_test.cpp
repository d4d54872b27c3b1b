// tally baseline, tally alerts, and labels (capture --label, runs --label) as
// a subprocess against the fake tallyd: what is sent, what is printed, and
// the errors (a bad flag is a usage error, exit 2; the server's 404, exit 1).
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

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

class TallyAlertsCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally_alerts_cli_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  Outcome tally(const std::string& args) {
    std::string cmd = "env -u TALLY_SERVER -u TALLY_TOKEN '" + std::string(TALLY_BIN) + "' --server " +
                      fake_.url() + " " + args + " >'" + (dir_ / "out").string() + "' 2>'" +
                      (dir_ / "err").string() + "'";
    int status = std::system(cmd.c_str());
    Outcome r;
    r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = tally::test::readFile(dir_ / "out");
    r.err = tally::test::readFile(dir_ / "err");
    if (std::getenv("TALLY_TEST_PRINT")) std::cout << "$ tally " << args << "\n" << r.out << r.err;
    return r;
  }
  std::string param(const httplib::Params& params, const std::string& key) {
    auto it = params.find(key);
    return it == params.end() ? std::string("(absent)") : it->second;
  }
  FakeTallyd fake_;
  fs::path dir_;
};

TEST_F(TallyAlertsCli, BaselineSetSendsTheRunThresholdAndName) {
  Outcome r = tally("baseline set 12 --threshold 0.03 --name 'deferred atrium'");
  ASSERT_EQ(r.rc, 0) << r.err;
  EXPECT_EQ(fake_.lastAlertsBody(), json({{"run", 12}, {"threshold", 0.03}, {"name", "deferred atrium"}}));
  EXPECT_NE(r.out.find("deferred atrium 320x180 llvmpipe exact"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("commit=4f2a9c1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("0.030"), std::string::npos) << r.out;
  EXPECT_EQ(r.err, "replaced baseline 2 of the same configuration\n");
  // Without flags: only the run; the server's defaults apply.
  ASSERT_EQ(tally("baseline set 12").rc, 0);
  EXPECT_EQ(fake_.lastAlertsBody(), json({{"run", 12}}));
  Outcome printed = tally("baseline set 12 --json");
  ASSERT_EQ(printed.rc, 0);
  EXPECT_EQ(json::parse(printed.out)["id"], 3);
}

TEST_F(TallyAlertsCli, BaselineErrors) {
  Outcome notId = tally("baseline set twelve");
  EXPECT_EQ(notId.rc, 1);
  EXPECT_NE(notId.err.find("RUN: must be a run id"), std::string::npos) << notId.err;
  Outcome unknown = tally("baseline set 99");
  EXPECT_EQ(unknown.rc, 1);
  EXPECT_NE(unknown.err.find("error (404 not_found): no run 99"), std::string::npos) << unknown.err;
  EXPECT_EQ(tally("baseline set 12 --threshold -1").rc, 2);
  EXPECT_EQ(tally("baseline").rc, 2);  // a subcommand is required
  EXPECT_EQ(tally("baseline rm 99").rc, 1);
}

TEST_F(TallyAlertsCli, BaselineListAndRemove) {
  Outcome list = tally("baseline list");
  ASSERT_EQ(list.rc, 0) << list.err;
  EXPECT_EQ(param(fake_.lastAlertsQuery(), "all"), "(absent)");
  EXPECT_NE(list.out.find("ID  RUN  NAME"), std::string::npos) << list.out;
  EXPECT_EQ(std::count(list.out.begin(), list.out.end(), '\n'), 2) << list.out;  // header and one baseline
  Outcome all = tally("baseline list --all");
  ASSERT_EQ(all.rc, 0);
  EXPECT_EQ(param(fake_.lastAlertsQuery(), "all"), "true");
  EXPECT_NE(all.out.find("replaced"), std::string::npos) << all.out;
  Outcome rm = tally("baseline rm 3");
  ASSERT_EQ(rm.rc, 0) << rm.err;
  EXPECT_EQ(rm.out, "baseline 3 removed\n");
}

TEST_F(TallyAlertsCli, AlertsListAcknowledgeAndSet) {
  Outcome list = tally("alerts --status open --baseline 3 --limit 10");
  ASSERT_EQ(list.rc, 0) << list.err;
  auto q = fake_.lastAlertsQuery();
  EXPECT_EQ(param(q, "status"), "open");
  EXPECT_EQ(param(q, "baseline"), "3");
  EXPECT_EQ(param(q, "limit"), "10");
  // Newest first as the server gives them: the counts alert with its lines
  // and its total bytes, then the frame time with its interval and p.
  size_t counts = list.out.find("counts (3 lines)"), frame = list.out.find("frame ");
  ASSERT_NE(counts, std::string::npos) << list.out;
  ASSERT_NE(frame, std::string::npos) << list.out;
  EXPECT_LT(counts, frame);
  EXPECT_NE(list.out.find("3.00 MiB"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("[1.180, 1.310]"), std::string::npos) << list.out;
  EXPECT_NE(list.out.find("1.250"), std::string::npos) << list.out;
  EXPECT_EQ(list.err, "open: 2\n");

  Outcome ack = tally("alerts ack 5");
  ASSERT_EQ(ack.rc, 0) << ack.err;
  EXPECT_EQ(fake_.lastAlertsBody(), json({{"status", "acknowledged"}}));
  EXPECT_EQ(ack.out, "alert 5 acknowledged\n");
  Outcome set = tally("alerts set 5 invalid");
  ASSERT_EQ(set.rc, 0) << set.err;
  EXPECT_EQ(fake_.lastAlertsBody(), json({{"status", "invalid"}}));
  EXPECT_EQ(tally("alerts set 5 closed").rc, 2);
  EXPECT_EQ(tally("alerts --status closed").rc, 2);
  Outcome unknown = tally("alerts ack 99");
  EXPECT_EQ(unknown.rc, 1);
  EXPECT_NE(unknown.err.find("no alert 99"), std::string::npos) << unknown.err;
}

TEST_F(TallyAlertsCli, LabelsOnCapturesAndRuns) {
  auto spec = dir_ / "spec.json";
  std::ofstream(spec) << R"({"renderers":["forward"],"labels":{"branch":"dev"}})";
  Outcome r =
      tally("capture --no-wait --spec '" + spec.string() + "' --label commit=4f2a9c1 --label branch=main");
  ASSERT_EQ(r.rc, 0) << r.err;
  json sent = json::parse(fake_.lastSpec());
  EXPECT_EQ(sent["labels"], json({{"commit", "4f2a9c1"}, {"branch", "main"}}));  // the flag wins
  Outcome bad = tally("capture --no-wait --spec '" + spec.string() + "' --label commit");
  EXPECT_EQ(bad.rc, 1);
  EXPECT_NE(bad.err.find("--label: expected NAME=VALUE, got 'commit'"), std::string::npos) << bad.err;

  Outcome runs = tally("runs --label commit=4f2a9c1");
  ASSERT_EQ(runs.rc, 0) << runs.err;
  EXPECT_EQ(param(fake_.lastRunsQuery(), "label"), "commit=4f2a9c1");
  EXPECT_NE(runs.out.find("LABELS"), std::string::npos) << runs.out;
  EXPECT_NE(runs.out.find("branch=main,commit=4f2a9c1"), std::string::npos) << runs.out;
  // Runs without labels have no LABELS column.
  EXPECT_EQ(tally("runs").out.find("LABELS"), std::string::npos);
}

}  // namespace
}  // namespace tally::client
