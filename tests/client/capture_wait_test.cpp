// `tally capture` keeps waiting while tallyd restarts: the job is stored, so
// polls that cannot connect are retried for a while.
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "commands.hpp"
#include "fake_tallyd.hpp"

namespace tally::client {
namespace {

TEST(CaptureWait, SurvivesADaemonRestart) {
  auto first = std::make_unique<test::FakeTallyd>();
  int port = first->port();
  ApiClient api({.server = first->url(), .connectTimeoutS = 1});
  std::string spec = (std::filesystem::temp_directory_path() / "tally_capture_wait_spec.json").string();
  std::ofstream(spec) << R"({"renderers":["deferred"],"resolutions":[[320,180]]})";

  std::ostringstream out, err;
  Io io{out, err};
  CaptureArgs args{.spec = spec, .intervalS = 0.05};
  int rc = -1;
  std::thread client([&] { rc = runCapture(api, args, io); });
  for (int i = 0; i < 400 && first->polls(7) == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  first.reset();  // the daemon goes away after storing the job (and answering a poll)
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  test::FakeTallyd second(port);  // and comes back on the same port
  client.join();
  std::filesystem::remove(spec);
  EXPECT_EQ(rc, 0) << err.str();
  EXPECT_NE(out.str().find("capture 7 done"), std::string::npos);
}

TEST(CaptureWait, GivesUpWhenTheDaemonStaysAway) {
  auto fake = std::make_unique<test::FakeTallyd>();
  ApiClient api({.server = fake->url(), .connectTimeoutS = 1});
  std::string spec = (std::filesystem::temp_directory_path() / "tally_capture_gone_spec.json").string();
  std::ofstream(spec) << R"({"renderers":["deferred"]})";
  std::ostringstream out, err;
  Io io{out, err};
  CaptureArgs args{.spec = spec, .intervalS = 0.01};
  std::thread stopper([&] {
    for (int i = 0; i < 400 && fake->polls(7) == 0; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    fake.reset();
  });
  int rc = runCapture(api, args, io);
  stopper.join();
  std::filesystem::remove(spec);
  EXPECT_EQ(rc, 1);
  EXPECT_NE(err.str().find("cannot reach tallyd"), std::string::npos) << err.str();
}

}  // namespace
}  // namespace tally::client
