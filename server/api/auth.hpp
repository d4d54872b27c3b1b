// Bearer tokens: one for reading, one for capturing (which may also read),
// and optionally one for running applications (which may also capture).
// Loopback without a token file: no checks. Any bind with a token file:
// every /api request needs a token. A non-loopback bind needs a token file.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "api/messages.hpp"
#include "common/result.hpp"

namespace tally::api {

// 32 characters or more (e.g. `openssl rand -hex 32`), from [A-Za-z0-9._~+/=-],
// with at least 8 distinct characters.
inline constexpr size_t kMinTokenLength = 32;
inline constexpr size_t kMaxTokenLength = 512;

struct Tokens {
  std::string read;
  std::string capture;
  std::string application;  // "" when the file has no application= line
};

// Lines "read=<token>", "capture=<token>" and, optionally,
// "application=<token>"; blank lines and '#' comments are skipped. Read and
// capture are required; every token given is strong and unlike the others.
Result<Tokens> parseTokens(std::string_view text);
// Reads and parses a token file; refuses one that other users can read.
Result<Tokens> loadTokenFile(const std::filesystem::path& path);

// 127.0.0.0/8, ::1, ::ffff:127.x.x.x and "localhost". Anything else (names included) is not.
bool isLoopbackAddress(std::string_view address);

// Time depends only on the length of `expected`, not on where the inputs differ.
bool constantTimeEquals(std::string_view given, std::string_view expected);

class Auth {
 public:
  static Auth open() { return Auth(); }
  static Auth withTokens(Tokens tokens);
  // The rule, checked before anything binds: non-loopback needs a token file;
  // a token file, if given, is always enforced.
  static Result<Auth> forBind(std::string_view bindAddress, const std::filesystem::path& tokenFile);

  bool required() const { return tokens_.has_value(); }
  // Whether some token may run applications (tallyd serve --allow-applications needs one).
  bool hasApplicationToken() const { return tokens_ && !tokens_->application.empty(); }
  // The principal for an Authorization header value ("Bearer <token>"), or
  // nullopt when it names no known token. Without tokens: kCapture, never kApplication.
  std::optional<Principal> authenticate(std::string_view authorization) const;

 private:
  std::optional<Tokens> tokens_;
};

}  // namespace tally::api
