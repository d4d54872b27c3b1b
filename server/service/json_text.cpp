#include "service/json_text.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace tally::service::detail {
using nlohmann::json;

JsonText::JsonText(std::string& out)
    : out_(out),
      serializer_(nlohmann::detail::output_adapter<char, std::string>(out), ' ', json::error_handler_t::replace) {}

void JsonText::separate() {
  if (afterKey_) {  // a member's value: its key wrote the separator
    afterKey_ = false;
    return;
  }
  if (levels_.empty()) return;
  Level& level = levels_.back();
  if (level.object) throw std::logic_error("JsonText: a value in an object without its key");
  if (!level.first) out_ += ',';
  level.first = false;
}

void JsonText::beginObject() {
  separate();
  out_ += '{';
  levels_.push_back({true, true, {}});
}

void JsonText::beginArray() {
  separate();
  out_ += '[';
  levels_.push_back({true, false, {}});
}

void JsonText::endObject() {
  if (levels_.empty() || !levels_.back().object || afterKey_) throw std::logic_error("JsonText: no object to end");
  levels_.pop_back();
  out_ += '}';
}

void JsonText::endArray() {
  if (levels_.empty() || levels_.back().object) throw std::logic_error("JsonText: no array to end");
  levels_.pop_back();
  out_ += ']';
}

void JsonText::key(std::string_view k) {
  if (levels_.empty() || !levels_.back().object || afterKey_) throw std::logic_error("JsonText: a key outside an object");
  Level& level = levels_.back();
  if (!level.first && !(level.lastKey < k)) {
    throw std::logic_error("JsonText: key \"" + std::string(k) + "\" after \"" + std::string(level.lastKey) +
                           "\" (nlohmann writes an object's keys in ascending order)");
  }
  if (!level.first) out_ += ',';
  level.first = false;
  level.lastKey = k;
  string(k);
  out_ += ':';
  afterKey_ = true;
}

void JsonText::null() {
  separate();
  out_ += "null";
}

void JsonText::value(bool b) {
  separate();
  out_ += b ? "true" : "false";
}

void JsonText::value(int64_t v) {
  separate();
  std::array<char, 24> buffer;
  auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  out_.append(buffer.data(), end);
}

void JsonText::value(double v) {
  separate();
  if (!std::isfinite(v)) {
    out_ += "null";
    return;
  }
  // nlohmann's serializer (dump_float) writes a double with this.
  std::array<char, 64> buffer;
  char* end = nlohmann::detail::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  out_.append(buffer.data(), end);
}

void JsonText::value(std::string_view s) {
  separate();
  string(s);
}

void JsonText::string(std::string_view s) {
  bool plain = true;  // printable ASCII that the serializer writes as it is
  for (char c : s) {
    auto b = static_cast<unsigned char>(c);
    if (b < 0x20 || b > 0x7E || b == '"' || b == '\\') {
      plain = false;
      break;
    }
  }
  if (plain) {
    out_ += '"';
    out_ += s;
    out_ += '"';
    return;
  }
  serializer_.dump(json(s), false, false, 0);  // escapes, UTF-8 checks and replacement as dump() does
}

void JsonText::value(const json& j) {
  separate();
  serializer_.dump(j, false, false, 0);
}

}  // namespace tally::service::detail
