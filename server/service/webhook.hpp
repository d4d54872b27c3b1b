// The alert webhook (tallyd serve --alert-webhook URL): one POST per alert,
// from the outbox the alerts table keeps (delivery, attempts, next attempt,
// last error). A thread of the API daemons delivers; workers and requests
// never wait on it. Each attempt is claimed in the store first (SKIP LOCKED
// on PostgreSQL), so two daemons never post one alert at once, and a
// delivered alert is never posted again. Failures are retried with
// exponential backoff until the attempts are used up (delivery "failed").
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "api/http_post.hpp"
#include "common/result.hpp"
#include "service/loop_thread.hpp"
#include "store/store.hpp"

namespace tally::service {

struct WebhookOptions {
  std::string url;              // http://host[:port]/path
  std::string dashboardUrl;     // the dashboard's base for links ("http://tally.example.org/"); may be empty
  int maxAttempts = 8;          // posts before an alert's delivery fails for good
  int64_t firstRetryMs = 1000;  // the wait after the first failure; doubled after each further one
  int64_t maxRetryMs = 300000;  // the longest wait between attempts (5 min)
  int timeoutSeconds = 10;      // connect, send and read, each
  std::chrono::milliseconds idle{1000};  // between looks at the outbox when nothing is due
};

// The wait before attempt `attempts` + 1, after `attempts` failed ones:
// firstRetryMs * 2^(attempts - 1), at most maxRetryMs.
int64_t retryDelayMs(const WebhookOptions& options, int attempts);

// The JSON body posted for an alert: {"event": "tally.alert", "alert",
// "baseline", "run", "labels", "figures", "link"} (docs/api.md, "Webhook").
nlohmann::json webhookBody(const store::Alert& alert, const std::optional<store::Baseline>& baseline,
                           const std::optional<store::RunRow>& run, const std::string& dashboardUrl);

// One pass over the due deliveries: each is claimed, posted and recorded.
// Returns how many were claimed.
Result<int> deliverDue(store::Store& store, const api::HttpTarget& target, const WebhookOptions& options,
                       const std::function<void(std::string_view)>& log);

class WebhookSender {
 public:
  // The URL must already be checked (api::parseHttpUrl).
  WebhookSender(std::string location, WebhookOptions options, std::function<void(std::string_view)> log);
  ~WebhookSender();
  WebhookSender(const WebhookSender&) = delete;
  WebhookSender& operator=(const WebhookSender&) = delete;
  void start();
  void stop();
  void wake();

 private:
  void loop();
  std::string location_;
  WebhookOptions options_;
  api::HttpTarget target_;
  std::function<void(std::string_view)> log_;
  LoopThread thread_;
};

// The JSON of an alert and of a baseline, as the API gives them.
nlohmann::json alertJson(const store::Alert& alert);
nlohmann::json baselineJson(const store::Baseline& baseline);

}  // namespace tally::service
