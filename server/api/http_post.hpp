// Posting JSON to another server (the alert webhook): cpp-httplib's client
// behind two functions, so the callers never see HTTP types.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "common/result.hpp"

namespace tally::api {

struct HttpTarget {
  std::string origin;  // "http://host:port"
  std::string path;    // "/hooks/tally", "/" when the URL has none
};

// http://HOST[:PORT][/PATH]. Errors say what is wrong with the URL. https is
// refused: this build's cpp-httplib has no TLS (put a local relay in front).
Result<HttpTarget> parseHttpUrl(const std::string& url);

struct PostReply {
  int status = 0;
  std::string body;  // at most the first 512 bytes, for error lines
};

// POSTs `body` as application/json with `headers`; an error when no reply
// came back (refused, unreachable, timed out), naming the reason.
Result<PostReply> postJson(const HttpTarget& target, const std::string& body,
                           const std::vector<std::pair<std::string, std::string>>& headers,
                           int timeoutSeconds);

}  // namespace tally::api
