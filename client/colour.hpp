// Colour in tally's tables, the way git, ripgrep and cargo do it: --color
// auto|always|never, NO_COLOR, CLICOLOR_FORCE, TERM=dumb; and the dashboard's
// palette (web/palette.json, compiled in): one colour per renderer or variant
// label, red and green for worse and better only, neutral read and written.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

namespace tally::client {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

// "#rrggbb"; nullopt for anything else (the palette's rgba() bands are not text colours).
std::optional<Rgb> parseHex(std::string_view hex);

enum class ColourMode { Auto, Always, Never };
// "auto", "always", "never"; nullopt for anything else.
std::optional<ColourMode> parseColourMode(std::string_view text);

// Whether and how output is coloured. Off by default, so that a table printed
// without one is plain text.
struct Colour {
  bool enabled = false;
  bool truecolor = false;  // 24-bit escapes; else the nearest of xterm's 256 colours
  // text between the colour's escape and a reset; text itself when off or empty.
  std::string paint(const std::string& text, std::optional<Rgb> rgb) const;
};

// The decision for stdout. `always` and `never` win over the environment (a
// flag is the more specific wish); with `auto`, in this order: NO_COLOR set
// and not empty: off; CLICOLOR_FORCE set, not empty and not "0": on; stdout
// not a terminal: off; TERM unset or "dumb": off; else on. Truecolor when
// COLORTERM is "truecolor" or "24bit". env returns nullptr for an unset name.
using Getenv = std::function<const char*(const char* name)>;
Colour decideColour(ColourMode mode, bool stdoutIsTerminal, const Getenv& env);

// The SGR escape that sets the foreground: "\033[38;2;R;G;Bm", or "\033[38;5;Nm".
std::string foregroundEscape(Rgb rgb, bool truecolor);
inline constexpr const char* kResetEscape = "\033[0m";
// The xterm-256 colour nearest to rgb (squared distance in RGB) among the
// 6x6x6 cube (16-231) and the grey ramp (232-255); the first 16 are left out
// because terminals redefine them.
int nearestXterm256(Rgb rgb);
// The RGB that xterm gives colour index 16-255.
Rgb xterm256(int index);

// FNV-1a, 32 bits, over the label's bytes (UTF-8): web/palette.js's fnv1a.
uint32_t fnv1a(std::string_view text);
// A label's colour: its pinned colour, else series[fnv1a(label) % series size],
// as web/palette.js's labelColor.
Rgb labelColour(std::string_view label);
// The palette's colours for worse, better, read and written.
Rgb worseColour();
Rgb betterColour();
Rgb readColour();
Rgb writtenColour();
// "read" and "write" in their neutral colours; none for anything else.
std::optional<Rgb> accessColour(std::string_view access);
// Worse (red) or better (green) for a change whose sign says which, or none:
// higherIsBetter for reuse and the like, else lower is better (time, bytes).
std::optional<Rgb> changeColour(std::optional<double> delta, bool higherIsBetter = false);
// A verdict's colour: "slower", "regression", "worse" red; "faster",
// "improvement", "better" green; anything else none.
std::optional<Rgb> verdictColour(std::string_view verdict);

}  // namespace tally::client
