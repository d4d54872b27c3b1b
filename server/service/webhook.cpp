#include "service/webhook.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

namespace tally::service {

using nlohmann::json;

namespace {

template <class T>
json opt(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}

}  // namespace

json alertJson(const store::Alert& a) {
  const store::NewAlert& f = a.figures;
  return {{"id", a.id},
          {"baseline", a.baselineId},
          {"run", a.runId},
          {"baseline_run", a.baselineRunId},
          {"kind", f.kind},
          {"metric", f.metric},
          {"verdict", f.verdict},
          {"ratio", opt(f.ratio)},
          {"interval",
           f.ratioLower && f.ratioUpper ? json::array({*f.ratioLower, *f.ratioUpper}) : json(nullptr)},
          {"p_value", opt(f.pValue)},
          {"cliffs_delta", opt(f.cliffsDelta)},
          {"value_a", opt(f.valueA)},
          {"value_b", opt(f.valueB)},
          {"details", f.details},
          {"status", a.status},
          {"created_at", a.createdAt},
          {"updated_at", opt(a.updatedAt)},
          {"delivery",
           {{"state", a.delivery},
            {"attempts", a.deliveryAttempts},
            {"next_attempt_at", a.nextAttemptMs && a.delivery == "pending"
                                    ? json(store::isoTimeFromMs(*a.nextAttemptMs))
                                    : json(nullptr)},
            {"last_error", opt(a.deliveryError)},
            {"delivered_at", opt(a.deliveredAt)}}}};
}

json baselineJson(const store::Baseline& b) {
  return {{"id", b.id},
          {"name", opt(b.name)},
          {"run", b.runId},
          {"threshold", b.threshold},
          {"status", b.status},
          {"configuration",
           {{"renderer", b.renderer},
            {"variant", b.variant},
            {"options", b.options},
            {"scene", b.scene},
            {"scene_params", b.sceneParams},
            {"width", b.width},
            {"height", b.height},
            {"device_id", b.deviceId},
            {"device", b.deviceName},
            {"counting", b.counting}}},
          {"labels", b.labels},
          {"open_alerts", b.openAlerts},
          {"created_at", b.createdAt},
          {"ended_at", opt(b.endedAt)},
          {"replaced_by", opt(b.replacedBy)}};
}

int64_t retryDelayMs(const WebhookOptions& options, int attempts) {
  double delay = static_cast<double>(options.firstRetryMs) * std::pow(2.0, std::max(0, attempts - 1));
  return static_cast<int64_t>(std::min(delay, static_cast<double>(options.maxRetryMs)));
}

json webhookBody(const store::Alert& alert, const std::optional<store::Baseline>& baseline,
                 const std::optional<store::RunRow>& run, const std::string& dashboardUrl) {
  json runJson = nullptr, labels = json::object();
  if (run) {
    labels = run->labels;
    runJson = {{"id", run->id},
               {"capture", run->jobId},
               {"variant", run->variant},
               {"scene", run->scene},
               {"width", run->width},
               {"height", run->height},
               {"device", run->deviceName},
               {"counting", run->counting},
               {"lights", run->lights},
               {"host", opt(run->host)},
               {"created_at", run->createdAt},
               {"labels", run->labels}};
  }
  json link = nullptr;
  if (!dashboardUrl.empty()) {
    std::string base = dashboardUrl;
    if (base.back() != '/') base += '/';
    link = base + "#/alerts/" + std::to_string(alert.id);
  }
  json figures = {{"kind", alert.figures.kind},
                  {"metric", alert.figures.metric},
                  {"verdict", alert.figures.verdict},
                  {"ratio", opt(alert.figures.ratio)},
                  {"interval", alert.figures.ratioLower && alert.figures.ratioUpper
                                   ? json::array({*alert.figures.ratioLower, *alert.figures.ratioUpper})
                                   : json(nullptr)},
                  {"p_value", opt(alert.figures.pValue)},
                  {"cliffs_delta", opt(alert.figures.cliffsDelta)},
                  {"value_a", opt(alert.figures.valueA)},
                  {"value_b", opt(alert.figures.valueB)}};
  json a = alertJson(alert);
  a.erase("delivery");
  return {{"event", "tally.alert"},
          {"alert", a},
          {"baseline", baseline ? baselineJson(*baseline) : json(nullptr)},
          {"run", runJson},
          {"labels", labels},
          {"figures", figures},
          {"link", link}};
}

Result<int> deliverDue(store::Store& store, const api::HttpTarget& target, const WebhookOptions& options,
                       const std::function<void(std::string_view)>& log) {
  // Claimed for longer than one post can take, so no other daemon posts the
  // same alert meanwhile.
  const int64_t claimMs = 3 * int64_t{options.timeoutSeconds} * 1000 + 5000;
  auto claimed = store.alerts().claimDeliveries(8, claimMs);
  if (!claimed) return makeError(claimed.error());
  for (const auto& alert : *claimed) {
    auto baseline = store.alerts().getBaseline(alert.baselineId);
    auto run = store.runs().get(alert.runId);
    if (!baseline || !run) return makeError(!baseline ? baseline.error() : run.error());
    std::optional<store::RunRow> row;
    if (*run) row = (*run)->row;
    json body = webhookBody(alert, *baseline, row, options.dashboardUrl);
    auto reply = api::postJson(
        target, body.dump(),
        {{"X-Tally-Event", "alert"},
         {"X-Tally-Delivery", std::to_string(alert.id) + "." + std::to_string(alert.deliveryAttempts)}},
        options.timeoutSeconds);
    std::string error;
    if (!reply) {
      error = reply.error();
    } else if (reply->status < 200 || reply->status >= 300) {
      error = "HTTP " + std::to_string(reply->status) +
              (reply->body.empty() ? "" : ": " + reply->body.substr(0, 200));
    }
    std::optional<int64_t> retry;
    if (!error.empty() && alert.deliveryAttempts < options.maxAttempts) {
      retry = retryDelayMs(options, alert.deliveryAttempts);
    }
    auto recorded = store.alerts().finishDelivery(alert.id, error.empty(), error, retry);
    if (!recorded) return makeError(recorded.error());
    if (!error.empty() && log) {
      log("alerts: webhook for alert " + std::to_string(alert.id) + " attempt " +
          std::to_string(alert.deliveryAttempts) + " failed: " + error +
          (retry ? " (retried in " + std::to_string(*retry) + " ms)" : " (no attempts left)"));
    }
  }
  return static_cast<int>(claimed->size());
}

WebhookSender::WebhookSender(std::string location, WebhookOptions options,
                             std::function<void(std::string_view)> log)
    : location_(std::move(location)), options_(std::move(options)), log_(std::move(log)) {
  auto target = api::parseHttpUrl(options_.url);
  if (target) target_ = *target;
}

WebhookSender::~WebhookSender() { stop(); }

void WebhookSender::start() {
  thread_.start([this] { loop(); });
}

void WebhookSender::stop() { thread_.stop(); }

void WebhookSender::wake() { thread_.wake(); }

void WebhookSender::loop() {
  auto log = [this](std::string_view line) {
    if (log_) {
      log_(line);
    } else {
      std::fprintf(stderr, "%.*s\n", static_cast<int>(line.size()), line.data());
    }
  };
  std::unique_ptr<store::Store> store;
  std::string lastError;
  while (true) {
    bool busy = false;
    if (!store) {
      auto opened = store::Store::open(location_);
      if (opened) {
        store = std::move(opened).value();
      } else if (opened.error() != lastError) {
        lastError = opened.error();
        log("alerts: webhook cannot open the store: " + lastError);
      }
    }
    if (store) {
      auto done = deliverDue(*store, target_, options_, log);
      if (!done) {
        if (done.error() != lastError) log("alerts: webhook outbox: " + done.error());
        lastError = done.error();
        store.reset();
      } else {
        busy = *done > 0;
      }
    }
    if (!thread_.next(busy, options_.idle)) return;
  }
}

}  // namespace tally::service
