// tally profile: the application capture spec built from its flags (docs/layer.md).
#include <gtest/gtest.h>

#include "commands.hpp"

namespace tally::client {
namespace {

TEST(ProfileSpec, ApplicationWithEveryFlag) {
  ProfileArgs args;
  args.command = {"vkcube", "--c", "100"};
  args.frames = 5;
  args.skipFrames = 20;
  args.xvfb = true;
  args.name = "cube";
  args.env = {"MESA_VK_WSI_PRESENT_MODE=immediate", "EMPTY="};
  args.timeoutS = 60;
  args.counting = "exact";
  auto spec = profileSpec(args);
  ASSERT_TRUE(spec.ok()) << spec.error();
  const nlohmann::json expected = {
      {"application",
       {{"command", {"vkcube", "--c", "100"}},
        {"frames", 5},
        {"skip_frames", 20},
        {"display", "xvfb"},
        {"name", "cube"},
        {"env", {{"MESA_VK_WSI_PRESENT_MODE", "immediate"}, {"EMPTY", ""}}},
        {"timeout_s", 60}}},
      {"counting", "exact"}};
  EXPECT_EQ(*spec, expected);
}

TEST(ProfileSpec, ComputeApplicationCountsFramesBySubmission) {
  ProfileArgs args;
  args.command = {"./compute"};
  args.frameSubmits = 2;
  auto spec = profileSpec(args);
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ((*spec)["application"]["frame_submits"], 2);
  EXPECT_EQ((*spec)["application"]["display"], "none");
  EXPECT_FALSE(spec->contains("counting"));
}

TEST(ProfileSpec, Replay) {
  ProfileArgs args;
  args.replay = "/srv/traces/scene.gfxr";
  args.frames = 3;
  auto spec = profileSpec(args);
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(*spec, (nlohmann::json{{"replay", "/srv/traces/scene.gfxr"}, {"frames", 3}, {"skip_frames", 0},
                                   {"display", "none"}}));
}

TEST(ProfileSpec, ErrorsNameTheFlag) {
  ProfileArgs none;
  EXPECT_NE(profileSpec(none).error().find("give the application after --"), std::string::npos);
  ProfileArgs both;
  both.command = {"vkcube"};
  both.replay = "x.gfxr";
  EXPECT_NE(profileSpec(both).error().find("not both"), std::string::npos);
  ProfileArgs env;
  env.command = {"vkcube"};
  env.env = {"NOEQUALS"};
  EXPECT_NE(profileSpec(env).error().find("--env: expected KEY=VALUE, got 'NOEQUALS'"), std::string::npos);
  ProfileArgs frames;
  frames.command = {"vkcube"};
  frames.frames = 0;
  EXPECT_NE(profileSpec(frames).error().find("--frames"), std::string::npos);
}

}  // namespace
}  // namespace tally::client
