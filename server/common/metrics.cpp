#include "common/metrics.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace tally::metrics {

const std::vector<double> kRequestSeconds = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1,
                                             0.25,  0.5,    1,     2.5,  5,     10};
const std::vector<double> kCaptureSeconds = {1, 2.5, 5, 10, 30, 60, 120, 300, 600, 1800, 3600};

namespace {

// Numbers as the format reads them: integers without a fraction, else
// shortest round-trip, and +Inf / -Inf / NaN spelled as Prometheus does.
std::string number(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[40];
  if (v == std::floor(v) && std::fabs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%.17g", v);
    // Shortest form that reads back the same.
    for (int precision = 1; precision < 17; ++precision) {
      char shorter[40];
      std::snprintf(shorter, sizeof shorter, "%.*g", precision, v);
      if (std::strtod(shorter, nullptr) == v) {
        return shorter;
      }
    }
  }
  return buf;
}

void appendLabels(std::string& out, const Labels& labels, const char* extraKey = nullptr,
                  const std::string& extraValue = {}) {
  if (labels.empty() && extraKey == nullptr) return;
  out += '{';
  bool first = true;
  for (const auto& [k, v] : labels) {
    if (!first) out += ',';
    first = false;
    out += k + "=\"" + escapeLabelValue(v) + '"';
  }
  if (extraKey != nullptr) {
    if (!first) out += ',';
    out += std::string(extraKey) + "=\"" + extraValue + '"';
  }
  out += '}';
}

const char* typeName(Type t) {
  switch (t) {
    case Type::kCounter: return "counter";
    case Type::kGauge: return "gauge";
    case Type::kHistogram: return "histogram";
  }
  return "untyped";
}

}  // namespace

namespace {

// The format escapes \ and newline in HELP text, and " too in label values.
std::string escape(std::string_view value, bool quotes) {
  std::string out;
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"' && quotes) {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

std::string escapeHelp(std::string_view help) { return escape(help, false); }

}  // namespace

std::string escapeLabelValue(std::string_view value) { return escape(value, true); }

void Registry::declare(std::string name, Type type, std::string help, std::vector<double> buckets) {
  std::lock_guard lock(mutex_);
  for (const auto& f : families_) {
    if (f.name == name) throw std::logic_error("metric " + name + " declared twice");
  }
  Family f;
  f.name = std::move(name);
  f.type = type;
  f.help = std::move(help);
  f.bounds = std::move(buckets);
  families_.push_back(std::move(f));
}

Registry::Family& Registry::family(std::string_view name, Type expected) {
  for (auto& f : families_) {
    if (f.name == name) {
      if (f.type != expected) throw std::logic_error("metric " + f.name + " used as another type");
      return f;
    }
  }
  throw std::logic_error("metric " + std::string(name) + " was not declared");
}

void Registry::add(std::string_view name, const Labels& labels, double by) {
  std::lock_guard lock(mutex_);
  family(name, Type::kCounter).series[labels].value += by;
}

void Registry::set(std::string_view name, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  family(name, Type::kGauge).series[labels].value = value;
}

void Registry::observe(std::string_view name, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  Family& f = family(name, Type::kHistogram);
  Series& s = f.series[labels];
  if (s.buckets.empty()) s.buckets.assign(f.bounds.size(), 0);
  for (size_t i = 0; i < f.bounds.size(); ++i) {
    if (value <= f.bounds[i]) {
      s.buckets[i] += 1;
      break;
    }
  }
  s.sum += value;
  s.count += 1;
}

void Registry::clear(std::string_view name) {
  std::lock_guard lock(mutex_);
  family(name, Type::kGauge).series.clear();
}

void Registry::onScrape(std::function<void(Registry&)> collect) {
  std::lock_guard lock(mutex_);
  collectors_.push_back(std::move(collect));
}

std::string Registry::text() {
  std::vector<std::function<void(Registry&)>> collectors;
  {
    std::lock_guard lock(mutex_);
    collectors = collectors_;
  }
  for (auto& collect : collectors) collect(*this);

  std::lock_guard lock(mutex_);
  std::string out;
  for (const auto& f : families_) {
    out += "# HELP " + f.name + " " + escapeHelp(f.help) + "\n";
    out += "# TYPE " + f.name + " " + typeName(f.type) + "\n";
    for (const auto& [labels, s] : f.series) {
      if (f.type != Type::kHistogram) {
        out += f.name;
        appendLabels(out, labels);
        out += " " + number(s.value) + "\n";
        continue;
      }
      double cumulative = 0;
      for (size_t i = 0; i < f.bounds.size(); ++i) {
        cumulative += s.buckets.empty() ? 0 : s.buckets[i];
        out += f.name + "_bucket";
        appendLabels(out, labels, "le", number(f.bounds[i]));
        out += " " + number(cumulative) + "\n";
      }
      out += f.name + "_bucket";
      appendLabels(out, labels, "le", "+Inf");
      out += " " + number(s.count) + "\n";
      out += f.name + "_sum";
      appendLabels(out, labels);
      out += " " + number(s.sum) + "\n";
      out += f.name + "_count";
      appendLabels(out, labels);
      out += " " + number(s.count) + "\n";
    }
  }
  return out;
}

double Registry::value(std::string_view name, const Labels& labels) const {
  std::lock_guard lock(mutex_);
  for (const auto& f : families_) {
    if (f.name != name) continue;
    auto it = f.series.find(labels);
    if (it == f.series.end()) return 0;
    return f.type == Type::kHistogram ? it->second.count : it->second.value;
  }
  return 0;
}

}  // namespace tally::metrics
