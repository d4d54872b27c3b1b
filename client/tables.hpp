// Plain-text tables with aligned columns, and the number formats tally prints.
#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "colour.hpp"

namespace tally::client {

class Table {
 public:
  enum class Align { Left, Right };
  struct Column {
    std::string title;
    Align align = Align::Left;
  };
  explicit Table(std::vector<Column> columns) : columns_(std::move(columns)) {}
  using Paints = std::vector<std::optional<Rgb>>;
  // Short rows are padded with empty cells; extra cells are dropped. paints[i]
  // is cell i's colour (a renderer's, worse or better), drawn only when the
  // table is printed with colour on.
  void addRow(std::vector<std::string> cells, Paints paints = {});
  size_t rows() const { return rows_.size(); }
  // Two spaces between columns; no trailing spaces. Columns are aligned on
  // the text, so colour changes no cell's place; with colour off the output
  // is the plain text.
  void print(std::ostream& out, const Colour& colour = {}) const;
  std::string str() const;

 private:
  std::vector<Column> columns_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<Paints> paints_;  // one per row, as long as columns_
};

inline constexpr const char* kMissing = "-";  // a value the server did not give

// 1023 -> "1023 B", 1536 -> "1.50 KiB", 1048576 -> "1.00 MiB" (binary units).
std::string humanBytes(double bytes);
std::string humanBytes(std::optional<double> bytes);
// Fixed decimals, e.g. fixed(1.834, 2) -> "1.83"; kMissing when empty.
std::string fixed(std::optional<double> value, int decimals);
// Six significant digits, "%.6g": 0.001 -> "0.001", 1e-05 -> "1e-05", 300 -> "300".
std::string fixedOrSci(double value);
// 0.31 -> "31.0%".
std::string percent(std::optional<double> fraction);
// 1.1 -> "1.10x".
std::string ratio(std::optional<double> value);
// Signed: +1.50 KiB / -0.20 ms style, with the given formatter.
std::string signedBytes(std::optional<double> delta);
std::string signedFixed(std::optional<double> delta, int decimals);
// Time since an event: "3 s ago" below 90 s, "12 min ago" below 90 min,
// "5 h ago" below 48 h, else "3 d ago"; negative (clocks apart) counts as 0.
std::string ago(std::optional<double> seconds);
// "[#####.....] 12/40 deferred atrium 320x180 camera 3" (width cells in the bar).
std::string progressLine(std::optional<double> fraction, std::optional<long long> done,
                         std::optional<long long> total, const std::string& current, int width = 20);

}  // namespace tally::client
