// Timing GET requests against a server on 127.0.0.1: one client per thread,
// latencies from sending a request to having its whole body, summarised as
// percentiles and requests per second.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace httplib {
class Client;
}

namespace tally::bench {

class HttpClient {
 public:
  explicit HttpClient(int port);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  struct Answer {
    double ms = 0;     // from sending the request to having the whole body
    size_t bytes = 0;  // of the body
  };
  // GET `path`; anything but a 200 is an error. The body goes to `body` when given.
  Result<Answer> get(const std::string& path, std::string* body = nullptr);

 private:
  std::unique_ptr<httplib::Client> client_;
};

// What one unit of a workload measured: the latency of each request it made
// (one request, or every page of a walk), or the first failure.
struct UnitResult {
  std::vector<double> ms;
  size_t bytes = 0;   // of every body
  std::string error;  // empty: every request answered 200
};
using Workload = std::function<UnitResult(HttpClient& client, std::mt19937& random)>;

struct Summary {
  size_t count = 0;                           // requests timed
  double p50 = 0, p90 = 0, p99 = 0, max = 0;  // ms
  double perSecond = 0;                       // requests over the wall time of the whole measurement
  double meanBytes = 0;                       // response body
  size_t errors = 0;
  std::string firstError;
};

// Runs `units` units of `workload` spread over `clients` threads (each with
// its own connection state and random stream), starting no unit after
// `budget` has passed.
Summary measure(int port, int clients, size_t units, std::chrono::seconds budget, const Workload& workload);

}  // namespace tally::bench
