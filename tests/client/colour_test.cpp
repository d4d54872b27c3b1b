// tally's colour: when it is on (--color, NO_COLOR, CLICOLOR_FORCE, TERM,
// a terminal), that piped output stays plain, and that the colours are the
// dashboard's: each checked against web/palette.json parsed here, and the
// fallback for an unpinned label against web/palette.js run by node.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colour.hpp"
#include "fake_tallyd.hpp"
#include "read_file.hpp"
#include "strict.hpp"
#include "tables.hpp"

namespace tally::client {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::FakeTallyd;

// The palette as the dashboard reads it, parsed without the client's code.
json webPalette() {
  return json::parse(tally::test::readFile(fs::path(TALLY_SOURCE_DIR) / "web/palette.json"));
}

// "#rrggbb" -> the 24-bit foreground escape, written out by hand.
std::string truecolorEscapeOf(const std::string& hex) {
  int r = std::stoi(hex.substr(1, 2), nullptr, 16), g = std::stoi(hex.substr(3, 2), nullptr, 16),
      b = std::stoi(hex.substr(5, 2), nullptr, 16);
  return "\x1b[38;2;" + std::to_string(r) + ";" + std::to_string(g) + ";" + std::to_string(b) + "m";
}

std::string stripEscapes(const std::string& text) {
  return std::regex_replace(text, std::regex("\x1b\\[[0-9;]*m"), "");
}

Colour decide(ColourMode mode, bool terminal, std::map<std::string, std::string> env) {
  return decideColour(mode, terminal, [&env](const char* name) -> const char* {
    auto it = env.find(name);
    return it == env.end() ? nullptr : it->second.c_str();
  });
}

TEST(Colour, AutoIsOnOnlyOnATerminalWithoutNoColor) {
  const std::map<std::string, std::string> term = {{"TERM", "xterm-256color"}};
  EXPECT_TRUE(decide(ColourMode::Auto, true, term).enabled);
  EXPECT_FALSE(decide(ColourMode::Auto, false, term).enabled) << "piped";
  EXPECT_FALSE(decide(ColourMode::Auto, true, {{"TERM", "xterm"}, {"NO_COLOR", "1"}}).enabled);
  // NO_COLOR counts only when set to something (no-color.org).
  EXPECT_TRUE(decide(ColourMode::Auto, true, {{"TERM", "xterm"}, {"NO_COLOR", ""}}).enabled);
  EXPECT_FALSE(decide(ColourMode::Auto, true, {{"TERM", "dumb"}}).enabled);
  EXPECT_FALSE(decide(ColourMode::Auto, true, {}).enabled) << "no TERM";
}

TEST(Colour, ForceAndFlagsWin) {
  EXPECT_TRUE(decide(ColourMode::Auto, false, {{"CLICOLOR_FORCE", "1"}}).enabled);
  EXPECT_TRUE(decide(ColourMode::Auto, false, {{"CLICOLOR_FORCE", "1"}, {"TERM", "dumb"}}).enabled);
  EXPECT_FALSE(decide(ColourMode::Auto, false, {{"CLICOLOR_FORCE", "0"}}).enabled);
  EXPECT_FALSE(decide(ColourMode::Auto, false, {{"CLICOLOR_FORCE", "1"}, {"NO_COLOR", "1"}}).enabled);
  EXPECT_TRUE(decide(ColourMode::Always, false, {{"NO_COLOR", "1"}, {"TERM", "dumb"}}).enabled);
  EXPECT_FALSE(decide(ColourMode::Never, true, {{"TERM", "xterm"}, {"CLICOLOR_FORCE", "1"}}).enabled);
  EXPECT_EQ(parseColourMode("always"), ColourMode::Always);
  EXPECT_EQ(parseColourMode("sometimes"), std::nullopt);
}

TEST(Colour, TruecolorOnlyWhereTheTerminalSaysSo) {
  EXPECT_TRUE(decide(ColourMode::Always, false, {{"COLORTERM", "truecolor"}}).truecolor);
  EXPECT_TRUE(decide(ColourMode::Always, false, {{"COLORTERM", "24bit"}}).truecolor);
  EXPECT_FALSE(decide(ColourMode::Always, false, {{"COLORTERM", "yes"}}).truecolor);
  EXPECT_FALSE(decide(ColourMode::Always, false, {}).truecolor);
}

TEST(Colour, PinnedRenderersTakeThePalettesColour) {
  const json palette = webPalette();
  ASSERT_FALSE(palette.at("pinned").empty());
  for (const auto& [label, hex] : palette.at("pinned").items())
    EXPECT_EQ(foregroundEscape(labelColour(label), true), truecolorEscapeOf(hex.get<std::string>())) << label;
  EXPECT_EQ(foregroundEscape(worseColour(), true), truecolorEscapeOf(palette.at("worse")));
  EXPECT_EQ(foregroundEscape(betterColour(), true), truecolorEscapeOf(palette.at("better")));
  EXPECT_EQ(foregroundEscape(readColour(), true), truecolorEscapeOf(palette.at("read")));
  EXPECT_EQ(foregroundEscape(writtenColour(), true), truecolorEscapeOf(palette.at("written")));
}

TEST(Colour, RedForWorseGreenForBetter) {
  EXPECT_EQ(changeColour(0.5), worseColour()) << "more time or bytes";
  EXPECT_EQ(changeColour(-0.5), betterColour());
  EXPECT_EQ(changeColour(0.5, true), betterColour()) << "more reuse";
  EXPECT_EQ(changeColour(0.0), std::nullopt);
  EXPECT_EQ(changeColour(std::nullopt), std::nullopt);
  EXPECT_EQ(verdictColour("slower"), worseColour());
  EXPECT_EQ(verdictColour("faster"), betterColour());
  EXPECT_EQ(verdictColour("same"), std::nullopt);
  EXPECT_NE(worseColour(), betterColour());
}

// Every palette colour's 256-colour stand-in is the nearest of xterm's 240
// (cube and greys), found here by trying each; the RGB of an index from
// xterm's definition: cube levels 0, 95, 135, ..., 255; greys 8 + 10 i.
TEST(Colour, NearestXtermColourIsTheClosestOfAll) {
  auto rgbOf = [](int i) {
    if (i >= 232) return std::vector<int>(3, 8 + 10 * (i - 232));
    int c = i - 16;
    auto level = [](int v) { return v == 0 ? 0 : 55 + 40 * v; };
    return std::vector<int>{level(c / 36), level(c / 6 % 6), level(c % 6)};
  };
  std::vector<std::string> hexes;
  const json palette = webPalette();
  for (const auto& [label, hex] : palette.at("pinned").items()) hexes.push_back(hex);
  for (const auto& hex : palette.at("series")) hexes.push_back(hex);
  for (const char* key : {"read", "written", "better", "worse", "same"}) hexes.push_back(palette.at(key));
  hexes.insert(hexes.end(), {"#000000", "#ffffff", "#808080", "#737373", "#5f87af"});
  for (const auto& hex : hexes) {
    Rgb rgb = *parseHex(hex);
    int best = 16;
    long bestDistance = -1;
    for (int i = 16; i < 256; ++i) {
      auto c = rgbOf(i);
      long d =
          (c[0] - rgb.r) * (c[0] - rgb.r) + (c[1] - rgb.g) * (c[1] - rgb.g) + (c[2] - rgb.b) * (c[2] - rgb.b);
      if (bestDistance < 0 || d < bestDistance) {
        best = i;
        bestDistance = d;
      }
    }
    EXPECT_EQ(nearestXterm256(rgb), best) << hex;
    EXPECT_EQ(foregroundEscape(rgb, false), "\x1b[38;5;" + std::to_string(best) + "m") << hex;
  }
}

// A label the palette does not pin gets the colour the dashboard gives it:
// web/palette.js's labelColor, run by node, for pinned, unpinned and non-ASCII labels.
TEST(Colour, UnpinnedLabelsMatchTheDashboard) {
  if (std::system("command -v node >/dev/null 2>&1") != 0) TALLY_SKIP_UNLESS_STRICT("node is not installed");
  const std::vector<std::string> labels = {"forward",
                                           "visbuffer-lean",
                                           "visbuffer barycentrics=float32 material_selection=uniform",
                                           "deferred light_culling=tiled",
                                           "vkcube",
                                           "sampled:4",
                                           "Ünïcödé 変種",
                                           ""};
  // palette.js as the browser loads it, but for its JSON import: node
  // before 18.20 (Debian's 18.19) cannot parse `with { type: 'json' }`, so
  // the palette is inlined in its place.
  const fs::path webDir = fs::path(TALLY_SOURCE_DIR) / "web";
  std::string module = tally::test::readFile(webDir / "palette.js");
  std::smatch jsonImport;
  ASSERT_TRUE(
      std::regex_search(module, jsonImport, std::regex(R"(import palette from '\./palette\.json'[^;\n]*;)")))
      << "web/palette.js no longer imports ./palette.json";
  module.replace(jsonImport.position(0), jsonImport.length(0),
                 "const palette = " + tally::test::readFile(webDir / "palette.json") + ";");
  fs::path dir = fs::temp_directory_path() / ("tally_colour_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "colours.mjs") << module << "\nconsole.log(JSON.stringify(" << json(labels).dump()
                                     << ".map((l) => labelColor(l))));\n";
  std::string cmd = "node '" + (dir / "colours.mjs").string() + "' >'" + (dir / "out").string() + "' 2>'" +
                    (dir / "err").string() + "'";
  int rc = std::system(cmd.c_str());
  std::string out = tally::test::readFile(dir / "out"), err = tally::test::readFile(dir / "err");
  fs::remove_all(dir);
  ASSERT_EQ(rc, 0) << err;
  json web = json::parse(out);
  ASSERT_EQ(web.size(), labels.size());
  bool unpinned = false;
  for (size_t i = 0; i < labels.size(); ++i) {
    EXPECT_EQ(labelColour(labels[i]), parseHex(web[i].get<std::string>())) << "'" << labels[i] << "'";
    unpinned = unpinned || !webPalette().at("pinned").contains(labels[i]);
  }
  EXPECT_TRUE(unpinned);
}

TEST(Colour, PaintingKeepsColumnsAligned) {
  Table t({{"RENDERER"}, {"DELTA", Table::Align::Right}, {"NOTE"}});
  t.addRow({"forward", "-1.00", "x"}, {labelColour("forward"), changeColour(-1.0)});
  t.addRow({"visbuffer barycentrics=float32", "+12.50", ""}, {labelColour("visbuffer"), changeColour(12.5)});
  std::ostringstream plain, coloured;
  t.print(plain);
  t.print(coloured, Colour{true, true});
  EXPECT_EQ(plain.str(), t.str());
  EXPECT_EQ(plain.str().find('\x1b'), std::string::npos);
  EXPECT_NE(coloured.str().find(foregroundEscape(worseColour(), true) + "+12.50" + kResetEscape),
            std::string::npos);
  EXPECT_EQ(stripEscapes(coloured.str()), plain.str());
}

// The binary: piped output is plain unless forced, and forced output is the
// plain output with colour added.
struct Output {
  int rc = -1;
  std::string out;
};

Output tallyWith(const std::string& env, const std::string& args) {
  fs::path out = fs::temp_directory_path() / ("tally_colour_cli_" + std::to_string(::getpid()));
  std::string cmd =
      "env -u TALLY_SERVER -u TALLY_TOKEN -u NO_COLOR -u CLICOLOR_FORCE -u COLORTERM TERM=xterm-256color " +
      env + " '" + std::string(TALLY_BIN) + "' " + args + " >'" + out.string() + "' 2>/dev/null";
  Output r;
  int status = std::system(cmd.c_str());
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = tally::test::readFile(out);
  fs::remove(out);
  return r;
}

TEST(ColourCli, PipedOutputIsPlainUnlessAsked) {
  FakeTallyd fake;
  const std::string server = "--server " + fake.url() + " ";
  for (const char* cmd : {"runs", "compare 12 15", "alerts", "show 18", "crossover 7",
                          "heatmap 7 --renderer deferred --versus visbuffer"}) {
    Output piped = tallyWith("", server + cmd);
    ASSERT_EQ(piped.rc, 0) << cmd;
    EXPECT_EQ(piped.out.find('\x1b'), std::string::npos) << cmd;
    EXPECT_EQ(tallyWith("", server + "--color never " + cmd).out, piped.out) << cmd;
    EXPECT_EQ(tallyWith("NO_COLOR=1 CLICOLOR_FORCE=1", server + cmd).out, piped.out) << cmd;
    Output always = tallyWith("", server + "--color always " + cmd);
    EXPECT_NE(always.out.find('\x1b'), std::string::npos) << cmd;
    EXPECT_EQ(stripEscapes(always.out), piped.out) << cmd;
    EXPECT_EQ(tallyWith("CLICOLOR_FORCE=1", server + cmd).out, always.out) << cmd;
  }
  // The flag also after the subcommand, as --json.
  EXPECT_NE(tallyWith("", server + "runs --color always").out.find('\x1b'), std::string::npos);
  EXPECT_EQ(tallyWith("", server + "--color sometimes runs").rc, 2);
}

TEST(ColourCli, RenderersInTheirColourChangesRedAndGreen) {
  FakeTallyd fake;
  const std::string server = "--server " + fake.url() + " --color always ";
  const json palette = webPalette();
  const std::string reset = kResetEscape;
  auto painted = [&](const std::string& hex, const std::string& text) {
    return truecolorEscapeOf(hex) + text + reset;
  };

  Output runs = tallyWith("COLORTERM=truecolor", server + "runs");
  EXPECT_NE(runs.out.find(painted(palette["pinned"]["deferred"], "deferred")), std::string::npos) << runs.out;
  // Without truecolor, the nearest 256-colour.
  Output runs256 = tallyWith("", server + "runs");
  const std::string deferred256 =
      foregroundEscape(*parseHex(palette["pinned"]["deferred"].get<std::string>()), false);
  EXPECT_NE(runs256.out.find(deferred256 + "deferred" + reset), std::string::npos) << runs256.out;

  // Compare 12 -> 15: 2.0 ms -> 1.5 ms and half the bytes, both better (green).
  Output compare = tallyWith("COLORTERM=truecolor", server + "compare 12 15");
  EXPECT_NE(compare.out.find(painted(palette["better"], "-0.500")), std::string::npos) << compare.out;
  EXPECT_NE(compare.out.find(painted(palette["better"], "-2.00 MiB")), std::string::npos) << compare.out;
  EXPECT_NE(compare.out.find(painted(palette["pinned"]["visbuffer"], "visbuffer")), std::string::npos)
      << compare.out;
  EXPECT_NE(compare.out.find(painted(palette["written"], "gbuffer.normal (write)")), std::string::npos)
      << compare.out;
  EXPECT_EQ(compare.out.find(truecolorEscapeOf(palette["worse"])), std::string::npos) << compare.out;

  // Alerts: a slower frame time and doubled bytes, both worse (red).
  Output alerts = tallyWith("COLORTERM=truecolor", server + "alerts");
  EXPECT_NE(alerts.out.find(painted(palette["worse"], "slower")), std::string::npos) << alerts.out;
  EXPECT_NE(alerts.out.find(painted(palette["worse"], "changed")), std::string::npos) << alerts.out;
  EXPECT_EQ(alerts.out.find(truecolorEscapeOf(palette["better"])), std::string::npos) << alerts.out;

  // A heatmap's significant cells: visbuffer lower (better) green, higher red;
  // the cell that does not differ significantly uncoloured.
  Output heatmap =
      tallyWith("COLORTERM=truecolor", server + "heatmap 7 --renderer deferred --versus visbuffer");
  EXPECT_NE(heatmap.out.find(painted(palette["better"], "0.80*")), std::string::npos) << heatmap.out;
  EXPECT_NE(heatmap.out.find(painted(palette["worse"], "1.25*")), std::string::npos) << heatmap.out;
  EXPECT_NE(heatmap.out.find("   1.01"), std::string::npos) << heatmap.out;

  // A run's read and written bytes in the neutral colours.
  Output show = tallyWith("COLORTERM=truecolor", server + "show 12");
  EXPECT_NE(show.out.find(truecolorEscapeOf(palette["read"])), std::string::npos) << show.out;
  EXPECT_NE(show.out.find(truecolorEscapeOf(palette["written"])), std::string::npos) << show.out;
}

}  // namespace
}  // namespace tally::client
