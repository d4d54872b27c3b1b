// `tallyd instrument` as a user runs it: exit codes, one-line errors, JSON out.
#include <algorithm>
#include <cstdio>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "spirv_test_util.hpp"
#include "read_file.hpp"

namespace tally {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int status;
  std::string out;
  std::string err;
};

class InstrumentCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-instrument-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  CommandResult run(const std::string& args) {
    std::string cmd = std::string(TALLYD_PATH) + " instrument " + args + " >" + (dir_ / "out").string() + " 2>" +
                      (dir_ / "err").string();
    int status = std::system(cmd.c_str());
    return {WEXITSTATUS(status), test::readFile(dir_ / "out"), test::readFile(dir_ / "err")};
  }

  fs::path write(const std::string& name, const std::vector<uint32_t>& words) {
    fs::path p = dir_ / name;
    std::ofstream out(p, std::ios::binary);
    out.write(reinterpret_cast<const char*>(words.data()), static_cast<std::streamsize>(words.size() * 4));
    return p;
  }

  fs::path dir_;
};

TEST_F(InstrumentCommand, WritesTheModuleAndPrintsTheSiteTable) {
  auto words = test::compileGlsl(R"(#version 450
layout(set = 0, binding = 1) uniform sampler2D tex;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, vec2(0.5)); }
)", spirv::Stage::Fragment);
  auto in = write("in.spv", words);
  for (const char* mode : {"accumulate", "accumulate:lane", "exact", "subgroup", "sampled:16"}) {
    CommandResult r = run(in.string() + " -o " + (dir_ / "out.spv").string() + " --mode " + mode + " --set 3 --binding 2");
    ASSERT_EQ(r.status, 0) << r.err;
    auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["mode"], mode);
    bool found = false;
    for (const auto& s : j["sites"]) {
      if (s["kind"] == "texture_read") {
        found = true;
        EXPECT_EQ(s["set"], 0);
        EXPECT_EQ(s["binding"], 1);
        EXPECT_EQ(s["stage"], "fragment");
      }
    }
    EXPECT_TRUE(found);
    auto outBytes = test::readFile(dir_ / "out.spv");
    EXPECT_GT(outBytes.size(), words.size() * 4);
    EXPECT_FALSE(fs::exists(dir_ / "out.spv.tmp"));
  }
}

TEST_F(InstrumentCommand, DefaultsToAccumulateAndReportsStripedComputeCounters) {
  auto words = test::compileGlsl(R"(#version 450
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) buffer Data { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] += 1u; }
)", spirv::Stage::Compute);
  auto in = write("in.spv", words);
  CommandResult r = run(in.string() + " -o " + (dir_ / "out.spv").string());
  ASSERT_EQ(r.status, 0) << r.err;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["mode"], "accumulate");
  const uint32_t slots = j["slot_count"], stride = j["copy_stride"];
  EXPECT_EQ(j["copies"], 16);
  EXPECT_EQ(stride, (slots + 15) / 16 * 16);  // whole 128-byte lines
  EXPECT_EQ(j["reserved_slots"], stride * 16);
  r = run(in.string() + " -o " + (dir_ / "out.spv").string() + " --compute-copies 1");
  ASSERT_EQ(r.status, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["copies"], 1);
  EXPECT_EQ(j["reserved_slots"], j["slot_count"]);
}

TEST_F(InstrumentCommand, BadInputExitsNonZeroWithOneLine) {
  std::vector<uint32_t> junk = {0x12345678, 1, 2, 3, 4, 5};
  auto in = write("junk.spv", junk);
  struct Case {
    std::string args;
    std::string expect;
  } cases[] = {
      {in.string() + " -o " + (dir_ / "o.spv").string(), "wrong magic"},
      {(dir_ / "missing.spv").string() + " -o " + (dir_ / "o.spv").string(), "cannot open"},
      {in.string() + " -o " + (dir_ / "o.spv").string() + " --mode fast", "unknown mode"},
      {in.string() + " -o " + (dir_ / "o.spv").string() + " --width 16", "unknown counter width"},
      {in.string(), "output path is required"},
      {in.string() + " -o " + (dir_ / "o.spv").string() + " --compute-copies 12", "power of two"},
  };
  for (const auto& c : cases) {
    CommandResult r = run(c.args);
    EXPECT_NE(r.status, 0) << c.args;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_TRUE(r.out.empty());
  }
  EXPECT_FALSE(fs::exists(dir_ / "o.spv"));  // nothing half-written
}

}  // namespace
}  // namespace tally
