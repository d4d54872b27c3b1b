// The daemon's policy on application and replay specs
// (capture/application_policy.hpp; docs/operating.md, "Security model"): the
// env allowlist and the variables no allowlist lets through, the operator's
// --application-env entries, and programs, replay files and driver manifests
// that must resolve inside the application roots, links followed. Each
// refusal names its field. No process is started here.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "capture/application_policy.hpp"

namespace tally::capture {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A root with an executable program and a replay file, and an outside folder
// with the same; links inside the root point out.
struct Fixture {
  fs::path dir, root, outside;
  Fixture() {
    std::string pattern = (fs::temp_directory_path() / "tally-apppolicy-XXXXXX").string();
    dir = mkdtemp(pattern.data());
    root = dir / "apps";
    outside = dir / "apps2";  // a sibling whose name starts like the root's
    for (const auto& d : {root, outside}) {
      fs::create_directories(d);
      std::ofstream(d / "app") << "#!/bin/sh\nexit 0\n";
      ::chmod((d / "app").c_str(), 0755);
      std::ofstream(d / "capture.gfxr") << "gfxr";
      std::ofstream(d / "icd.json") << "{}";
    }
    fs::create_symlink(outside / "app", root / "escape");
    fs::create_symlink(outside / "capture.gfxr", root / "escape.gfxr");
    fs::create_symlink("/etc/shadow", root / "shadow.gfxr");
    fs::create_symlink(root / "app", root / "alias");
  }
  ~Fixture() { fs::remove_all(dir); }
  ApplicationPolicy policy() const { return {{root}, {"MY_APP_*", "QUALITY"}}; }
};

json app(const std::string& program, json env = json::object()) {
  return {{"application", {{"command", {program, "--c", "100"}}, {"env", env}}}};
}

std::string fieldOf(const Result<ApplicationSpec>& r) {
  if (r.ok()) return "(accepted)";
  return r.error().substr(0, r.error().find(": "));
}

TEST(ApplicationPolicy, LoaderVariablesAreAlwaysRefused) {
  for (const char* name :
       {"LD_PRELOAD", "LD_LIBRARY_PATH", "LD_AUDIT", "PATH", "VK_INSTANCE_LAYERS", "VK_LOADER_LAYERS_ENABLE",
        "VK_ADD_LAYER_PATH", "VK_LAYER_PATH", "VK_IMPLICIT_LAYER_PATH", "TALLY_LAYER_OUTPUT"}) {
    EXPECT_TRUE(alwaysRefusedEnv(name)) << name;
    // Not even when the operator lists it, or a prefix of it.
    EXPECT_FALSE(applicationEnvAllowed({{}, {name, "L*", "V*", "P*"}}, name)) << name;
    EXPECT_FALSE(checkApplicationEnvPattern(name).ok()) << name;
  }
  EXPECT_FALSE(checkApplicationEnvPattern("LD_*").ok());
  EXPECT_FALSE(checkApplicationEnvPattern("*").ok());
  EXPECT_FALSE(checkApplicationEnvPattern("BAD-NAME").ok());
  EXPECT_TRUE(checkApplicationEnvPattern("MY_APP_*").ok());
  EXPECT_TRUE(checkApplicationEnvPattern("QUALITY").ok());
}

TEST(ApplicationPolicy, EnvAllowlistAndOperatorNames) {
  ApplicationPolicy none;
  for (const char* name : {"DISPLAY", "WAYLAND_DISPLAY", "VK_DRIVER_FILES", "VK_LOADER_DRIVERS_SELECT",
                           "MESA_VK_WSI_PRESENT_MODE", "LIBGL_ALWAYS_SOFTWARE", "LP_NUM_THREADS"}) {
    EXPECT_TRUE(applicationEnvAllowed(none, name)) << name;
  }
  for (const char* name : {"MY_APP_QUALITY", "QUALITY", "HOME", "SHELL", "PYTHONPATH", "GCONV_PATH"}) {
    EXPECT_FALSE(applicationEnvAllowed(none, name)) << name;
  }
  ApplicationPolicy extended{{}, {"MY_APP_*", "QUALITY"}};
  EXPECT_TRUE(applicationEnvAllowed(extended, "MY_APP_QUALITY"));
  EXPECT_TRUE(applicationEnvAllowed(extended, "QUALITY"));
  EXPECT_FALSE(applicationEnvAllowed(extended, "QUALITY2"));
}

TEST(ApplicationPolicy, EnvRefusalsNameTheVariable) {
  Fixture f;
  const std::string program = (f.root / "app").string();
  struct Case {
    json env;
    std::string field;
  };
  for (const auto& c : std::vector<Case>{
           {{{"LD_PRELOAD", "/tmp/evil.so"}}, "application.env.LD_PRELOAD"},
           {{{"PATH", "/tmp"}}, "application.env.PATH"},
           {{{"VK_INSTANCE_LAYERS", "VK_LAYER_evil"}}, "application.env.VK_INSTANCE_LAYERS"},
           {{{"SHELL", "/bin/sh"}}, "application.env.SHELL"},
           {{{"VK_DRIVER_FILES", (f.outside / "icd.json").string()}}, "application.env.VK_DRIVER_FILES"},
           {{{"VK_ICD_FILENAMES", (f.root / "icd.json").string() + ":" + (f.outside / "icd.json").string()}},
            "application.env.VK_ICD_FILENAMES"},
       }) {
    auto r = parseConfinedApplicationSpec(app(program, c.env), f.policy());
    EXPECT_EQ(fieldOf(r), c.field) << c.env.dump() << ": " << (r.ok() ? "" : r.error());
  }
  // A replay's env is at the top level.
  json replay = {{"replay", (f.root / "capture.gfxr").string()}, {"env", {{"LD_PRELOAD", "x"}}}};
  EXPECT_EQ(fieldOf(parseConfinedApplicationSpec(replay, f.policy())), "env.LD_PRELOAD");
  // What the allowlist and the operator let through.
  auto ok = parseConfinedApplicationSpec(app(program, {{"DISPLAY", ":3"},
                                                       {"MY_APP_QUALITY", "high"},
                                                       {"VK_DRIVER_FILES", (f.root / "icd.json").string()}}),
                                         f.policy());
  EXPECT_TRUE(ok.ok()) << ok.error();
}

TEST(ApplicationPolicy, ProgramMustResolveInsideARoot) {
  Fixture f;
  struct Case {
    std::string program;
    std::string field;
  };
  for (const auto& c : std::vector<Case>{
           {"/bin/sh", "application.command[0]"},
           {"sh", "application.command[0]"},  // found on $PATH, outside the roots
           {(f.outside / "app").string(), "application.command[0]"},
           {(f.root / "escape").string(), "application.command[0]"},  // a link out
           {(f.root / ".." / "apps2" / "app").string(), "application.command[0]"},
           {(f.root / "missing").string(), "application.command[0]"},
           {"./app", "application.command[0]"},
       }) {
    auto r = parseConfinedApplicationSpec(app(c.program), f.policy());
    EXPECT_EQ(fieldOf(r), c.field) << c.program << ": " << (r.ok() ? "" : r.error());
  }
  // Missing and outside read alike: the refusal does not tell whether a file exists.
  auto missing = parseConfinedApplicationSpec(app((f.dir / "missing").string()), f.policy());
  auto present = parseConfinedApplicationSpec(app((f.outside / "app").string()), f.policy());
  ASSERT_FALSE(missing.ok());
  ASSERT_FALSE(present.ok());
  EXPECT_NE(missing.error().find("must resolve"), std::string::npos) << missing.error();
  EXPECT_NE(present.error().find("must resolve"), std::string::npos) << present.error();

  // Inside, through a link that stays inside: what runs is the resolved program.
  auto alias = parseConfinedApplicationSpec(app((f.root / "alias").string()), f.policy());
  ASSERT_TRUE(alias.ok()) << alias.error();
  EXPECT_EQ(alias->program, fs::canonical(f.root / "app").string());
  EXPECT_EQ(alias->command[0], (f.root / "alias").string());
}

TEST(ApplicationPolicy, ReplayMustResolveInsideARoot) {
  Fixture f;
  for (const std::string& file : {std::string("/etc/shadow"), std::string("/etc/passwd"),
                                  (f.root / "shadow.gfxr").string(), (f.root / "escape.gfxr").string(),
                                  (f.outside / "capture.gfxr").string(), std::string("relative.gfxr")}) {
    auto r = parseConfinedApplicationSpec({{"replay", file}}, f.policy());
    EXPECT_EQ(fieldOf(r), "replay") << file << ": " << (r.ok() ? "" : r.error());
  }
  auto ok = parseConfinedApplicationSpec({{"replay", (f.root / "capture.gfxr").string()}}, f.policy());
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->replayFile, fs::canonical(f.root / "capture.gfxr").string());
}

TEST(ApplicationPolicy, NoRootsNoApplications) {
  Fixture f;
  auto r = parseConfinedApplicationSpec(app((f.root / "app").string()), {});
  EXPECT_EQ(fieldOf(r), "application");
  EXPECT_EQ(fieldOf(parseConfinedApplicationSpec({{"replay", (f.root / "capture.gfxr").string()}}, {})),
            "replay");
  // Roots are folders, absolute, and not the whole file system.
  EXPECT_FALSE(checkApplicationRoots({"relative"}).ok());
  EXPECT_FALSE(checkApplicationRoots({"/"}).ok());
  EXPECT_FALSE(checkApplicationRoots({(f.root / "app").string()}).ok());
  EXPECT_FALSE(checkApplicationRoots({(f.dir / "missing").string()}).ok());
  auto roots = checkApplicationRoots({f.root.string()});
  ASSERT_TRUE(roots.ok()) << roots.error();
  EXPECT_EQ(roots->at(0), fs::canonical(f.root));
}

}  // namespace
}  // namespace tally::capture
