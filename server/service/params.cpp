// Query and path parameters: each checker answers a bad value with a
// RequestError naming the parameter (errors.hpp).
#include "service/params.hpp"

#include <cctype>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/resolution.hpp"
#include "service/errors.hpp"

namespace tally::service::detail {
using api::Request;

std::optional<int64_t> queryInt(const Request& req, const std::string& key, int64_t low, int64_t high) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  int64_t n = 0;
  size_t used = 0;
  try {
    n = std::stoll(*v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (v->empty() || used != v->size() || !(std::isdigit(static_cast<unsigned char>((*v)[0])) || (*v)[0] == '-') ||
      n < low || n > high) {
    invalid(key, "must be an integer between " + std::to_string(low) + " and " + std::to_string(high));
  }
  return n;
}

std::optional<std::string> queryString(const Request& req, const std::string& key, size_t maxLength) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  if (v->empty() || v->size() > maxLength) {
    invalid(key, "must be 1 to " + std::to_string(maxLength) + " characters");
  }
  return *v;
}

// A number in [low, high] (exclusive ends where asked): "confidence=0.99".
std::optional<double> queryDouble(const Request& req, const std::string& key, double low, double high,
                                  bool openLow, bool openHigh) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  double n = 0;
  size_t used = 0;
  try {
    n = std::stod(*v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  bool inRange = std::isfinite(n) && (openLow ? n > low : n >= low) && (openHigh ? n < high : n <= high);
  if (v->empty() || used != v->size() || !inRange) {
    std::ostringstream range;
    range << (openLow ? "(" : "[") << low << ", " << high << (openHigh ? ")" : "]");
    invalid(key, "must be a number in " + range.str() + ", got '" + v->substr(0, 32) + "'");
  }
  return n;
}

std::optional<bool> queryBool(const Request& req, const std::string& key) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  if (*v == "true" || *v == "1") return true;
  if (*v == "false" || *v == "0") return false;
  invalid(key, "must be true or false");
}

int64_t pathId(const Request& req) {
  const std::string& v = req.param("id");
  int64_t n = 0;
  size_t used = 0;
  try {
    n = std::stoll(v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (v.empty() || used != v.size() || !std::isdigit(static_cast<unsigned char>(v[0])) || n < 1) {
    invalid("id", "must be a positive integer");
  }
  return n;
}

store::Page queryPage(const Request& req) {
  store::Page page;
  page.limit = static_cast<int>(queryInt(req, "limit", 1, 1000).value_or(100));
  if (auto c = queryString(req, "cursor", 64)) {
    if (!store::decodeCursor(*c)) invalid("cursor", "not a cursor from a previous page");
    page.cursor = *c;
  }
  return page;
}

void allowOnly(const Request& req, const std::set<std::string>& keys) {
  for (const auto& [key, value] : req.query) {
    if (!keys.count(key)) {
      std::string known;
      for (const auto& k : keys) known += (known.empty() ? "" : ", ") + k;
      invalid(key, "unknown query parameter (expected " + (known.empty() ? std::string("none") : known) + ")");
    }
  }
}

// A creation-time bound: a prefix of the stored UTC ISO-8601 form
// 2026-11-21T06:30:00.123Z at a field boundary (a date, minutes, seconds,
// milliseconds, or all of it), so that text comparison orders it correctly.
std::optional<std::string> queryTime(const Request& req, const std::string& key) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  static const std::string kPattern = "0000-00-00T00:00:00.000Z";  // '0': a digit
  bool boundary = v->size() == 10 || v->size() == 16 || v->size() == 19 || v->size() == 23 || v->size() == 24;
  bool matches = boundary;
  for (size_t i = 0; matches && i < v->size(); ++i) {
    char c = (*v)[i];
    matches = kPattern[i] == '0' ? std::isdigit(static_cast<unsigned char>(c)) != 0 : c == kPattern[i];
  }
  if (!matches) invalid(key, "must be a UTC date or time: 2026-11-21, 2026-11-21T06:30 or 2026-11-21T06:30:00.123Z");
  return *v;
}

store::RunFilter queryFilter(const Request& req) {
  store::RunFilter f;
  f.renderer = queryString(req, "renderer");
  f.variant = queryString(req, "variant");
  f.scene = queryString(req, "scene");
  if (auto w = queryInt(req, "width", 1, kMaxDimension)) f.width = static_cast<int>(*w);
  if (auto h = queryInt(req, "height", 1, kMaxDimension)) f.height = static_cast<int>(*h);
  if (const std::string* d = req.queryValue("device")) {
    // A device id, or its exact name.
    bool numeric = !d->empty() && d->find_first_not_of("0123456789") == std::string::npos;
    if (numeric) {
      f.deviceId = queryInt(req, "device", 1, INT64_MAX);
    } else {
      f.deviceName = queryString(req, "device");
    }
  }
  f.jobId = queryInt(req, "capture", 1, INT64_MAX);
  f.host = queryString(req, "host");
  if (auto label = queryString(req, "label", 512)) {
    // NAME=VALUE: the runs of captures that carry that label.
    size_t eq = label->find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == label->size()) {
      invalid("label", "must be NAME=VALUE (commit=4f2a9c1)");
    }
    f.labels.emplace_back(label->substr(0, eq), label->substr(eq + 1));
  }
  f.createdSince = queryTime(req, "since");
  f.createdUntil = queryTime(req, "until");
  return f;
}

// ?runs=a,b,...: distinct positive run ids, between `least` and `most` of them.
std::vector<int64_t> runIdList(const Request& req, size_t least, size_t most) {
  std::string expected = "must be " + std::to_string(least) + " to " + std::to_string(most) + " run ids, comma-separated";
  const std::string* list = req.queryValue("runs");
  if (!list) invalid("runs", "required: " + std::to_string(least) + " to " + std::to_string(most) + " run ids, comma-separated");
  std::vector<int64_t> ids;
  std::stringstream in(*list);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    int64_t n = 0;
    try {
      n = std::stoll(item, &used, 10);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || !std::isdigit(static_cast<unsigned char>(item[0])) || n < 1) {
      invalid("runs", expected);
    }
    for (int64_t seen : ids) {
      if (seen == n) invalid("runs", "run " + item + " is listed twice");
    }
    ids.push_back(n);
    if (ids.size() > most) break;
  }
  if (!list->empty() && list->back() == ',') invalid("runs", expected);
  if (ids.size() < least || ids.size() > most) invalid("runs", expected);
  return ids;
}

}  // namespace tally::service::detail
