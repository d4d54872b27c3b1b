#include "colour.hpp"

#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "palette_json.hpp"

namespace tally::client {
namespace {

bool setAndNotEmpty(const char* value) { return value != nullptr && *value != '\0'; }

// The palette, parsed once from the compiled-in web/palette.json. A palette
// that does not parse is a build defect, not a user's mistake: it throws with
// the field, and the client's tests parse it on every build.
struct Palette {
  std::map<std::string, Rgb, std::less<>> pinned;
  std::vector<Rgb> series;
  Rgb read, written, better, worse;
};

Rgb colourAt(const std::string& field, const nlohmann::json& value) {
  auto rgb = value.is_string() ? parseHex(value.get<std::string>()) : std::nullopt;
  if (!rgb) throw std::logic_error("web/palette.json: " + field + ": not a #rrggbb colour: " + value.dump());
  return *rgb;
}

const Palette& palette() {
  static const Palette p = [] {
    Palette out;
    const auto j = nlohmann::json::parse(kPaletteJson);
    for (const auto& [label, hex] : j.at("pinned").items())
      out.pinned[label] = colourAt("pinned." + label, hex);
    for (size_t i = 0; i < j.at("series").size(); ++i)
      out.series.push_back(colourAt("series[" + std::to_string(i) + "]", j["series"][i]));
    if (out.series.empty()) throw std::logic_error("web/palette.json: series: empty");
    out.read = colourAt("read", j.at("read"));
    out.written = colourAt("written", j.at("written"));
    out.better = colourAt("better", j.at("better"));
    out.worse = colourAt("worse", j.at("worse"));
    return out;
  }();
  return p;
}

// xterm's cube levels for 0-5.
constexpr int kCubeLevels[6] = {0, 95, 135, 175, 215, 255};

int distance2(Rgb a, Rgb b) {
  int dr = a.r - b.r, dg = a.g - b.g, db = a.b - b.b;
  return dr * dr + dg * dg + db * db;
}

}  // namespace

std::optional<Rgb> parseHex(std::string_view hex) {
  if (hex.size() != 7 || hex[0] != '#') return std::nullopt;
  unsigned value = 0;
  for (char c : hex.substr(1)) {
    int digit = c >= '0' && c <= '9'   ? c - '0'
                : c >= 'a' && c <= 'f' ? c - 'a' + 10
                : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                       : -1;
    if (digit < 0) return std::nullopt;
    value = value * 16 + static_cast<unsigned>(digit);
  }
  return Rgb{static_cast<uint8_t>(value >> 16), static_cast<uint8_t>(value >> 8),
             static_cast<uint8_t>(value)};
}

std::optional<ColourMode> parseColourMode(std::string_view text) {
  if (text == "auto") return ColourMode::Auto;
  if (text == "always") return ColourMode::Always;
  if (text == "never") return ColourMode::Never;
  return std::nullopt;
}

std::string Colour::paint(const std::string& text, std::optional<Rgb> rgb) const {
  if (!enabled || !rgb || text.empty()) return text;
  return foregroundEscape(*rgb, truecolor) + text + kResetEscape;
}

Colour decideColour(ColourMode mode, bool stdoutIsTerminal, const Getenv& env) {
  Colour c;
  const char* colorterm = env("COLORTERM");
  c.truecolor = colorterm != nullptr &&
                (std::string_view(colorterm) == "truecolor" || std::string_view(colorterm) == "24bit");
  if (mode != ColourMode::Auto) {
    c.enabled = mode == ColourMode::Always;
    return c;
  }
  if (setAndNotEmpty(env("NO_COLOR"))) return c;
  const char* force = env("CLICOLOR_FORCE");
  if (setAndNotEmpty(force) && std::string_view(force) != "0") {
    c.enabled = true;
    return c;
  }
  const char* term = env("TERM");
  c.enabled = stdoutIsTerminal && setAndNotEmpty(term) && std::string_view(term) != "dumb";
  return c;
}

std::string foregroundEscape(Rgb rgb, bool truecolor) {
  char buf[32];
  if (truecolor) {
    std::snprintf(buf, sizeof buf, "\033[38;2;%d;%d;%dm", rgb.r, rgb.g, rgb.b);
  } else {
    std::snprintf(buf, sizeof buf, "\033[38;5;%dm", nearestXterm256(rgb));
  }
  return buf;
}

Rgb xterm256(int index) {
  if (index >= 232) {
    auto grey = static_cast<uint8_t>(8 + 10 * (index - 232));
    return {grey, grey, grey};
  }
  int i = index - 16;
  return {static_cast<uint8_t>(kCubeLevels[i / 36]), static_cast<uint8_t>(kCubeLevels[i / 6 % 6]),
          static_cast<uint8_t>(kCubeLevels[i % 6])};
}

int nearestXterm256(Rgb rgb) {
  // The cube is separable: per channel, the nearest level. Then the nearest
  // grey; the cube wins a tie, as the lower index.
  auto level = [](int v) {
    int best = 0;
    for (int i = 1; i < 6; ++i)
      if (std::abs(kCubeLevels[i] - v) < std::abs(kCubeLevels[best] - v)) best = i;
    return best;
  };
  int cube = 16 + 36 * level(rgb.r) + 6 * level(rgb.g) + level(rgb.b);
  int grey = 232;
  for (int i = 233; i < 256; ++i)
    if (distance2(xterm256(i), rgb) < distance2(xterm256(grey), rgb)) grey = i;
  return distance2(xterm256(grey), rgb) < distance2(xterm256(cube), rgb) ? grey : cube;
}

uint32_t fnv1a(std::string_view text) {
  uint32_t hash = 0x811c9dc5u;
  for (unsigned char byte : text) {
    hash ^= byte;
    hash *= 0x01000193u;
  }
  return hash;
}

Rgb labelColour(std::string_view label) {
  const Palette& p = palette();
  if (auto it = p.pinned.find(label); it != p.pinned.end()) return it->second;
  return p.series[fnv1a(label) % p.series.size()];
}

Rgb worseColour() { return palette().worse; }
Rgb betterColour() { return palette().better; }
Rgb readColour() { return palette().read; }
Rgb writtenColour() { return palette().written; }

std::optional<Rgb> accessColour(std::string_view access) {
  if (access == "read") return readColour();
  if (access == "write") return writtenColour();
  return std::nullopt;
}

std::optional<Rgb> changeColour(std::optional<double> delta, bool higherIsBetter) {
  if (!delta || *delta == 0 || *delta != *delta) return std::nullopt;
  return (*delta > 0) == higherIsBetter ? betterColour() : worseColour();
}

std::optional<Rgb> verdictColour(std::string_view verdict) {
  if (verdict == "slower" || verdict == "regression" || verdict == "worse") return worseColour();
  if (verdict == "faster" || verdict == "improvement" || verdict == "better") return betterColour();
  return std::nullopt;
}

}  // namespace tally::client
