#include "service/alert_evaluator.hpp"

#include <cmath>
#include <cstdio>
#include <memory>

#include "analysis/significance.hpp"
#include "reports/run_significance.hpp"

namespace tally::service {

using reports::FigureSignificance;
using reports::runSignificance;
using reports::SignificanceOptions;

using nlohmann::json;

namespace {

store::NewAlert timeAlert(const std::string& metric, const FigureSignificance& f) {
  const analysis::TimeComparison& t = f.time;
  store::NewAlert a;
  a.kind = "time";
  a.metric = metric;
  a.verdict = analysis::toString(t.verdict);
  a.ratio = t.ratio;
  if (t.interval.bounded) {
    a.ratioLower = t.interval.lower;
    a.ratioUpper = t.interval.upper;
  }
  a.pValue = t.test.pValue;
  a.cliffsDelta = t.effect.delta;
  // The runs' medians as the runs list and the trend show them; the ratio
  // and its interval stay the comparison's (per-camera aligned).
  a.valueA = f.runMedianA.value_or(t.medianA);
  a.valueB = f.runMedianB.value_or(t.medianB);
  a.details = analysis::toJson(t);
  if (f.acrossCapture) {
    a.details["across_capture"] = {{"runs", f.acrossCapture->runs},
                                   {"log_sd", f.acrossCapture->logSd},
                                   {"degrees_of_freedom", f.acrossCapture->degreesOfFreedom},
                                   {"cells", f.acrossCapture->cells},
                                   {"captures", f.acrossCapture->captures}};
  } else {
    a.details["across_capture"] = nullptr;
  }
  a.details["noise_note"] = f.noiseNote.empty() ? json(nullptr) : json(f.noiseNote);
  a.details["run_median_a"] = a.valueA ? json(*a.valueA) : json(nullptr);
  a.details["run_median_b"] = a.valueB ? json(*a.valueB) : json(nullptr);
  return a;
}

}  // namespace

Result<std::vector<store::NewAlert>> evaluateRun(store::Store& reader, const store::RunRow& run,
                                                 const store::Baseline& baseline) {
  SignificanceOptions options;
  options.compare.practicalThreshold = baseline.threshold;
  auto s = runSignificance(reader, baseline.runId, run.id, options);
  if (!s) return makeError(s.error());
  std::vector<store::NewAlert> out;
  if (!s->incomparable.empty()) return out;  // no camera in common: nothing to test
  if (s->frame && s->frame->time.verdict != analysis::Verdict::Same)
    out.push_back(timeAlert("frame", *s->frame));
  for (const auto& p : s->passes) {
    if (p.time.verdict != analysis::Verdict::Same) out.push_back(timeAlert("pass " + p.figure, p));
  }
  if (s->countsChanged()) {
    store::NewAlert a;
    a.kind = "counts";
    a.metric = "counts";
    a.verdict = "changed";
    json changes = json::array();
    for (const auto& c : s->countChanges) {
      changes.push_back({{"line", c.line}, {"a", c.a}, {"b", c.b}, {"delta", c.b - c.a}});
      if (c.line == "total") {
        a.valueA = c.a;
        a.valueB = c.b;
        if (c.a != 0) a.ratio = c.b / c.a;
      }
    }
    a.details = {
        {"lines", s->countLines}, {"changed", s->countChanges.size()}, {"changes", std::move(changes)}};
    out.push_back(std::move(a));
  }
  return out;
}

Result<store::Evaluated> evaluatePending(store::Store& writer, store::Store& reader, bool deliver,
                                         int batch) {
  return writer.alerts().evaluatePending(
      [&reader](const store::RunRow& run, const store::Baseline& baseline) {
        return evaluateRun(reader, run, baseline);
      },
      batch, deliver);
}

AlertEvaluator::AlertEvaluator(Options options) : options_(std::move(options)) {}

AlertEvaluator::~AlertEvaluator() { stop(); }

void AlertEvaluator::start() {
  thread_.start([this] { loop(); });
}

void AlertEvaluator::stop() { thread_.stop(); }

void AlertEvaluator::wake() { thread_.wake(); }

void AlertEvaluator::loop() {
  auto log = [this](const std::string& line) {
    if (options_.log) {
      options_.log(line);
    } else {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
  };
  std::unique_ptr<store::Store> writer, reader;
  std::string lastError;
  while (true) {
    bool busy = false;
    if (!writer || !reader) {
      auto w = store::Store::open(options_.location);
      auto r = w ? store::Store::open(options_.location, {.readOnly = true})
                 : Result<std::unique_ptr<store::Store>>(makeError(w.error()));
      if (w && r) {
        writer = std::move(w).value();
        reader = std::move(r).value();
      } else {
        std::string error = "alerts: cannot open the store: " + (w ? r.error() : w.error());
        if (error != lastError) log(error);
        lastError = error;
      }
    }
    if (writer && reader) {
      auto done = evaluatePending(*writer, *reader, options_.deliver);
      if (!done) {
        std::string error = "alerts: evaluation failed (retried): " + done.error();
        if (error != lastError) log(error);
        lastError = error;
        // A lost connection is opened again on the next pass.
        writer.reset();
        reader.reset();
      } else {
        lastError.clear();
        busy = done->runs > 0;
        if (busy && options_.onEvaluated) options_.onEvaluated(*done);
        if (!done->alertIds.empty()) {
          log("alerts: " + std::to_string(done->alertIds.size()) + " alert(s) raised over " +
              std::to_string(done->tested) + " run(s) tested against their baselines");
        }
      }
    }
    if (!thread_.next(busy, options_.idle)) return;
  }
}

}  // namespace tally::service
