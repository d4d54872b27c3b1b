#include "api/auth.hpp"

#include <arpa/inet.h>
#include <sys/stat.h>

#include <fstream>
#include <set>
#include <sstream>

namespace tally::api {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool tokenChar(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
         c == '~' || c == '+' || c == '/' || c == '=' || c == '-';
}

std::optional<std::string> tokenWeakness(std::string_view token) {
  if (token.empty()) return "is empty";
  if (token.size() < kMinTokenLength)
    return "is too short (" + std::to_string(token.size()) + " characters; at least " +
           std::to_string(kMinTokenLength) + ", e.g. from `openssl rand -hex 32`)";
  if (token.size() > kMaxTokenLength) return "is too long (at most " + std::to_string(kMaxTokenLength) + ")";
  for (char c : token)
    if (!tokenChar(c)) return "has a character outside [A-Za-z0-9._~+/=-]";
  if (std::set<char>(token.begin(), token.end()).size() < 8)
    return "is too repetitive (fewer than 8 distinct characters)";
  return std::nullopt;
}

}  // namespace

Result<Tokens> parseTokens(std::string_view text) {
  std::optional<std::string> read, capture, application;
  size_t lineNo = 0;
  while (!text.empty()) {
    size_t end = text.find('\n');
    std::string_view line = trim(text.substr(0, end));
    text = end == std::string_view::npos ? std::string_view() : text.substr(end + 1);
    ++lineNo;
    if (line.empty() || line.front() == '#') continue;
    size_t eq = line.find('=');
    if (eq == std::string_view::npos)
      return makeError("token file line " + std::to_string(lineNo) +
                       ": expected read=<token>, capture=<token> or application=<token>");
    std::string_view key = trim(line.substr(0, eq));
    std::string value(trim(line.substr(eq + 1)));
    std::optional<std::string>* slot = key == "read"          ? &read
                                       : key == "capture"     ? &capture
                                       : key == "application" ? &application
                                                              : nullptr;
    if (!slot)
      return makeError("token file line " + std::to_string(lineNo) + ": unknown key '" + std::string(key) +
                       "' (expected read, capture or application)");
    if (slot->has_value()) return makeError("token file: '" + std::string(key) + "' given twice");
    if (auto weak = tokenWeakness(value))
      return makeError("token file: the " + std::string(key) + " token " + *weak);
    *slot = std::move(value);
  }
  if (!read) return makeError("token file: no read=<token> line");
  if (!capture) return makeError("token file: no capture=<token> line");
  if (*read == *capture) return makeError("token file: the read and capture tokens must differ");
  if (application && (*application == *read || *application == *capture))
    return makeError("token file: the application token must differ from the read and capture tokens");
  return Tokens{std::move(*read), std::move(*capture), application.value_or("")};
}

Result<Tokens> loadTokenFile(const std::filesystem::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return makeError("token file " + path.string() + ": cannot be read");
  if (!S_ISREG(st.st_mode)) return makeError("token file " + path.string() + ": not a regular file");
  if (st.st_mode & (S_IRWXG | S_IRWXO))
    return makeError("token file " + path.string() + ": readable by other users; chmod 600 it");
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError("token file " + path.string() + ": cannot be read");
  std::ostringstream ss;
  ss << in.rdbuf();
  auto tokens = parseTokens(ss.str());
  if (!tokens) return makeError(path.string() + ": " + tokens.error());
  return tokens;
}

bool isLoopbackAddress(std::string_view address) {
  std::string a(address);
  if (a == "localhost") return true;
  if (a.size() > 2 && a.front() == '[' && a.back() == ']') a = a.substr(1, a.size() - 2);
  in_addr v4{};
  if (inet_pton(AF_INET, a.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, a.c_str(), &v6) == 1) {
    if (IN6_IS_ADDR_LOOPBACK(&v6)) return true;
    if (IN6_IS_ADDR_V4MAPPED(&v6)) return v6.s6_addr[12] == 127;
  }
  return false;
}

bool constantTimeEquals(std::string_view given, std::string_view expected) {
  volatile unsigned char diff = given.size() == expected.size() ? 0 : 1;
  for (size_t i = 0; i < expected.size(); ++i) {
    unsigned char g = i < given.size() ? static_cast<unsigned char>(given[i]) : 0;
    diff = diff | static_cast<unsigned char>(g ^ static_cast<unsigned char>(expected[i]));
  }
  return diff == 0;
}

Auth Auth::withTokens(Tokens tokens) {
  Auth a;
  a.tokens_ = std::move(tokens);
  return a;
}

Result<Auth> Auth::forBind(std::string_view bindAddress, const std::filesystem::path& tokenFile) {
  if (tokenFile.empty()) {
    if (!isLoopbackAddress(bindAddress))
      return makeError("refusing to bind " + std::string(bindAddress) +
                       " without tokens: a non-loopback address needs --token-file with read=<token> and "
                       "capture=<token> lines");
    return Auth::open();
  }
  auto tokens = loadTokenFile(tokenFile);
  if (!tokens) return makeError(tokens.error());
  return Auth::withTokens(std::move(*tokens));
}

std::optional<Principal> Auth::authenticate(std::string_view authorization) const {
  if (!tokens_) return Principal::kCapture;
  constexpr std::string_view kScheme = "bearer ";
  if (authorization.size() <= kScheme.size()) return std::nullopt;
  for (size_t i = 0; i < kScheme.size(); ++i) {
    char c = authorization[i];
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    if (c != kScheme[i]) return std::nullopt;
  }
  std::string_view token = authorization.substr(kScheme.size());
  // Every comparison runs, so timing does not tell which token matched. An
  // absent application token matches nothing (a token is never empty here).
  bool isApplication = !tokens_->application.empty() && constantTimeEquals(token, tokens_->application);
  bool isCapture = constantTimeEquals(token, tokens_->capture);
  bool isRead = constantTimeEquals(token, tokens_->read);
  if (isApplication) return Principal::kApplication;
  if (isCapture) return Principal::kCapture;
  if (isRead) return Principal::kRead;
  return std::nullopt;
}

}  // namespace tally::api
