// Query and path parameters of the service's routes. Each checker throws a
// RequestError (errors.hpp) naming the parameter and what it must be.
// Internal to service/.
#pragma once

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "api/messages.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

std::optional<int64_t> queryInt(const api::Request& req, const std::string& key, int64_t low, int64_t high);
std::optional<std::string> queryString(const api::Request& req, const std::string& key,
                                       size_t maxLength = 256);
// A number in [low, high] (exclusive ends where asked): "confidence=0.99".
std::optional<double> queryDouble(const api::Request& req, const std::string& key, double low, double high,
                                  bool openLow, bool openHigh);
std::optional<bool> queryBool(const api::Request& req, const std::string& key);
// A UTC date or time prefix (since, until).
std::optional<std::string> queryTime(const api::Request& req, const std::string& key);
int64_t pathId(const api::Request& req);
store::Page queryPage(const api::Request& req);
void allowOnly(const api::Request& req, const std::set<std::string>& keys);
// The run filters shared by /api/runs, /api/export, /api/accuracy, ...
store::RunFilter queryFilter(const api::Request& req);
// ?runs=a,b,...: distinct positive run ids, between `least` and `most` of them.
std::vector<int64_t> runIdList(const api::Request& req, size_t least, size_t most);

}  // namespace tally::service::detail
