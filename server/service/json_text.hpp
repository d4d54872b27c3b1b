// JSON text written straight into a string, byte for byte what
// nlohmann::json::dump() (compact, error_handler_t::replace, as the HTTP
// transport dumps) writes for the same value: objects' keys must come in
// the order of nlohmann's std::map (ascending bytes; checked, a key out of
// order throws std::logic_error), numbers are written by nlohmann's own
// formatter, and strings escaped by its serializer unless they are plain
// printable ASCII. For large pages of rows, without a json value per row.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::service::detail {

class JsonText {
 public:
  explicit JsonText(std::string& out);

  void beginObject();
  void endObject();
  void beginArray();
  void endArray();
  // An object's key; the keys of one object in ascending order. The key
  // must outlive the object (the routes' keys are literals).
  void key(std::string_view k);

  void null();
  void value(bool b);
  void value(int64_t v);
  void value(int v) { value(static_cast<int64_t>(v)); }
  void value(double v);  // NaN and infinities: null, as nlohmann
  void value(std::string_view s);
  void value(const std::string& s) { value(std::string_view(s)); }
  void value(const char* s) { value(std::string_view(s)); }
  void value(const nlohmann::json& j);
  template <class T>
  void value(const std::optional<T>& v) {
    if (v) {
      value(*v);
    } else {
      null();
    }
  }

 private:
  void separate();  // the comma before an array element, or checks that a key came first
  void string(std::string_view s);  // a key or a string value, escaped

  struct Level {
    bool first = true;
    bool object = false;
    std::string_view lastKey;
  };
  std::string& out_;
  std::vector<Level> levels_;
  bool afterKey_ = false;
  nlohmann::detail::serializer<nlohmann::json> serializer_;
};

}  // namespace tally::service::detail
