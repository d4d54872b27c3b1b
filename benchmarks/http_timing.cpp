#include "http_timing.hpp"

#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <thread>

namespace tally::bench {

using Clock = std::chrono::steady_clock;

HttpClient::HttpClient(int port) : client_(std::make_unique<httplib::Client>("127.0.0.1", port)) {
  // Generous: a slow answer must show up as a figure, not as a failure.
  client_->set_connection_timeout(std::chrono::seconds(10));
  client_->set_read_timeout(std::chrono::seconds(60));
}

HttpClient::~HttpClient() = default;

Result<HttpClient::Answer> HttpClient::get(const std::string& path, std::string* body) {
  auto start = Clock::now();
  auto response = client_->Get(path);
  double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  if (!response) return makeError("GET " + path + ": " + httplib::to_string(response.error()));
  if (response->status != 200) {
    return makeError("GET " + path + ": status " + std::to_string(response->status) + ": " +
                     response->body.substr(0, 200));
  }
  Answer answer{ms, response->body.size()};
  if (body) *body = std::move(response->body);
  return answer;
}

namespace {

// Nearest rank: the smallest latency with at least `p` of all at or below it.
double percentile(const std::vector<double>& sorted, double p) {
  size_t rank = static_cast<size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

}  // namespace

Summary measure(int port, int clients, size_t units, std::chrono::seconds budget, const Workload& workload) {
  std::atomic<size_t> claimed{0};
  std::mutex mutex;  // guards `all` and `summary`'s error fields
  std::vector<double> all;
  size_t bytes = 0;
  Summary summary;
  const auto start = Clock::now();
  const auto deadline = start + budget;
  auto client = [&](int index) {
    HttpClient http(port);
    std::mt19937 random(static_cast<uint32_t>(1000 + index));
    std::vector<double> mine;
    size_t myBytes = 0;
    while (Clock::now() < deadline && claimed.fetch_add(1) < units) {
      UnitResult unit = workload(http, random);
      mine.insert(mine.end(), unit.ms.begin(), unit.ms.end());
      myBytes += unit.bytes;
      if (!unit.error.empty()) {
        std::lock_guard lock(mutex);
        if (summary.errors++ == 0) summary.firstError = unit.error;
      }
    }
    std::lock_guard lock(mutex);
    all.insert(all.end(), mine.begin(), mine.end());
    bytes += myBytes;
  };
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) threads.emplace_back(client, i);
  for (auto& t : threads) t.join();
  double wall = std::chrono::duration<double>(Clock::now() - start).count();

  summary.count = all.size();
  if (all.empty()) return summary;
  std::sort(all.begin(), all.end());
  summary.p50 = percentile(all, 0.50);
  summary.p90 = percentile(all, 0.90);
  summary.p99 = percentile(all, 0.99);
  summary.max = all.back();
  summary.perSecond = static_cast<double>(all.size()) / wall;
  summary.meanBytes = static_cast<double>(bytes) / static_cast<double>(all.size());
  return summary;
}

}  // namespace tally::bench
