// The daemon's metrics in the Prometheus text format (version 0.0.4), served
// at GET /metrics. Written here because Debian packages no C++ client; the
// format is small: # HELP / # TYPE lines, then one sample per line,
// name{label="value",...} number. Counters, gauges and histograms (cumulative
// _bucket{le=...}, _sum, _count). Thread-safe.
#pragma once

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tally::metrics {

// Label pairs in the order given; every sample of a family uses the same keys.
using Labels = std::vector<std::pair<std::string, std::string>>;

enum class Type { kCounter, kGauge, kHistogram };

// Upper bounds, in seconds, for request latencies (1 ms .. 10 s) and for
// captures (1 s .. 1 h, the default job deadline is 30 min).
extern const std::vector<double> kRequestSeconds;
extern const std::vector<double> kCaptureSeconds;

class Registry {
 public:
  // Declares a family; each family is declared once, before use. Buckets are
  // for histograms (ascending upper bounds; +Inf is implied).
  void declare(std::string name, Type type, std::string help, std::vector<double> buckets = {});

  void add(std::string_view name, const Labels& labels, double by = 1);  // counter
  void set(std::string_view name, const Labels& labels, double value);   // gauge
  void observe(std::string_view name, const Labels& labels, double value);  // histogram
  // Removes every sample of a gauge family (before setting a fresh set, e.g.
  // queue depth by state, so that a state with no jobs reads 0 or is gone).
  void clear(std::string_view name);

  // Run before each text(): fills gauges that are read at scrape time
  // (queue depth, store size).
  void onScrape(std::function<void(Registry&)> collect);

  // The exposition. Families in declaration order, samples in label order.
  std::string text();

  // A counter's or gauge's value; a histogram's count. 0 when absent (tests).
  double value(std::string_view name, const Labels& labels = {}) const;

 private:
  struct Series {
    double value = 0;               // counter, gauge
    std::vector<double> buckets;    // histogram: per-bucket counts (not cumulative)
    double sum = 0, count = 0;      // histogram
  };
  struct Family {
    std::string name, help;
    Type type = Type::kCounter;
    std::vector<double> bounds;
    std::map<Labels, Series> series;
  };
  Family& family(std::string_view name, Type expected);

  mutable std::mutex mutex_;
  std::vector<Family> families_;
  std::vector<std::function<void(Registry&)>> collectors_;
};

// A label value as the format writes it: \ " and newline escaped.
std::string escapeLabelValue(std::string_view value);

}  // namespace tally::metrics
