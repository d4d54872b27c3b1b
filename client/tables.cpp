#include "tables.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace tally::client {

void Table::addRow(std::vector<std::string> cells, Paints paints) {
  cells.resize(columns_.size());
  paints.resize(columns_.size());
  rows_.push_back(std::move(cells));
  paints_.push_back(std::move(paints));
}

void Table::print(std::ostream& out, const Colour& colour) const {
  std::vector<size_t> widths;
  for (const auto& c : columns_) widths.push_back(c.title.size());
  for (const auto& row : rows_)
    for (size_t i = 0; i < row.size(); ++i) widths[i] = std::max(widths[i], row[i].size());
  const Paints none(columns_.size());
  auto line = [&](const std::vector<std::string>& cells, const Paints& paints) {
    std::string text;
    for (size_t i = 0; i < cells.size(); ++i) {
      std::string pad(widths[i] - cells[i].size(), ' ');
      std::string shown = colour.paint(cells[i], paints[i]);
      if (i) text += "  ";
      text += columns_[i].align == Align::Right ? pad + shown : shown + pad;
    }
    while (!text.empty() && text.back() == ' ') text.pop_back();
    out << text << '\n';
  };
  std::vector<std::string> titles;
  for (const auto& c : columns_) titles.push_back(c.title);
  line(titles, none);
  for (size_t r = 0; r < rows_.size(); ++r) line(rows_[r], paints_[r]);
}

std::string Table::str() const {
  std::ostringstream s;
  print(s);
  return s.str();
}

namespace {
std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}
}  // namespace

std::string humanBytes(double bytes) {
  static const char* const kUnits[] = {"KiB", "MiB", "GiB", "TiB", "PiB"};
  double magnitude = std::fabs(bytes);
  if (magnitude < 1024) return format("%.0f B", bytes);
  int unit = -1;
  while (magnitude >= 1024 && unit < 4) {
    magnitude /= 1024;
    bytes /= 1024;
    ++unit;
  }
  return format("%.2f ", bytes) + kUnits[unit];
}

std::string humanBytes(std::optional<double> bytes) { return bytes ? humanBytes(*bytes) : kMissing; }

std::string fixed(std::optional<double> value, int decimals) {
  if (!value) return kMissing;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, *value);
  return buf;
}

std::string fixedOrSci(double value) { return format("%.6g", value); }

std::string percent(std::optional<double> fraction) {
  return fraction ? fixed(*fraction * 100, 1) + "%" : kMissing;
}

std::string ratio(std::optional<double> value) { return value ? fixed(*value, 2) + "x" : kMissing; }

std::string signedBytes(std::optional<double> delta) {
  if (!delta) return kMissing;
  return (*delta >= 0 ? "+" : "-") + humanBytes(std::fabs(*delta));
}

std::string signedFixed(std::optional<double> delta, int decimals) {
  if (!delta) return kMissing;
  return (*delta >= 0 ? "+" : "") + fixed(*delta, decimals);
}

std::string ago(std::optional<double> seconds) {
  if (!seconds) return kMissing;
  double s = std::max(0.0, *seconds);
  if (s < 90) return format("%.0f s ago", std::floor(s));
  if (s < 90 * 60) return format("%.0f min ago", std::floor(s / 60));
  if (s < 48 * 3600) return format("%.0f h ago", std::floor(s / 3600));
  return format("%.0f d ago", std::floor(s / 86400));
}

std::string progressLine(std::optional<double> fraction, std::optional<long long> done,
                         std::optional<long long> total, const std::string& current, int width) {
  double f = std::clamp(fraction.value_or(0.0), 0.0, 1.0);
  int filled = static_cast<int>(std::floor(f * width + 1e-9));
  std::string line = "[" + std::string(filled, '#') + std::string(width - filled, '.') + "]";
  if (done && total) {
    line += " " + std::to_string(*done) + "/" + std::to_string(*total);
  } else if (fraction) {
    line += " " + fixed(f * 100, 0) + "%";
  }
  if (!current.empty()) line += " " + current;
  return line;
}

}  // namespace tally::client
