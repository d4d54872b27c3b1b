// Raw bytes into the HTTP request gate: api::requestExtent (how much of a
// request the gate waits for), then the checks the server makes on what
// the gate hands on: the target (api::checkTarget), Content-Length
// (api::parseContentLength), Content-Type, Host, Idempotency-Key and the
// JSON body (api::parseJsonBody).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "api/connection_gate.hpp"
#include "api/request_checks.hpp"

namespace {

using namespace tally::api;

void require(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "fuzz_http: %s\n", what);
    std::abort();
  }
}

bool startsWithNoCase(std::string_view line, std::string_view prefix) {
  if (line.size() < prefix.size()) return false;
  for (size_t i = 0; i < prefix.size(); ++i) {
    char a = line[i], b = prefix[i];
    if (a >= 'A' && a <= 'Z') a = static_cast<char>(a - 'A' + 'a');
    if (b >= 'A' && b <= 'Z') b = static_cast<char>(b - 'A' + 'a');
    if (a != b) return false;
  }
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  for (size_t maxBody : {size_t{0}, size_t{16}, size_t{1} << 20}) {
    RequestExtent extent = requestExtent(bytes, maxBody);
    require(extent.headerBytes <= size, "header extends past the bytes read");
    require(extent.bodyBytes <= maxBody, "body to wait for exceeds the limit");
    require(extent.headerComplete || (extent.bodyBytes == 0 && !extent.expectContinue),
            "a body waited for before the header is complete");
  }
  RequestExtent extent = requestExtent(bytes, size_t{1} << 20);
  if (!extent.headerComplete) return 0;
  std::string_view header = bytes.substr(0, extent.headerBytes);
  size_t lineEnd = header.find('\n');
  std::string_view requestLine = trim(header.substr(0, lineEnd));
  size_t sp1 = requestLine.find(' ');
  size_t sp2 = sp1 == std::string_view::npos ? sp1 : requestLine.find(' ', sp1 + 1);
  if (sp2 != std::string_view::npos) {
    std::string_view target = requestLine.substr(sp1 + 1, sp2 - sp1 - 1);
    (void)checkTarget(target, target.substr(0, target.find('?')));
  }
  while (lineEnd != std::string_view::npos && lineEnd + 1 < header.size()) {
    size_t next = header.find('\n', lineEnd + 1);
    std::string_view line =
        header.substr(lineEnd + 1, next == std::string_view::npos ? next : next - lineEnd - 1);
    lineEnd = next;
    size_t colon = line.find(':');
    if (colon == std::string_view::npos) continue;
    std::string_view value = trim(line.substr(colon + 1));
    if (startsWithNoCase(line, "content-length:")) (void)parseContentLength(value);
    if (startsWithNoCase(line, "content-type:")) (void)isJsonMediaType(value);
    if (startsWithNoCase(line, "host:")) (void)isLoopbackHost(value);
    if (startsWithNoCase(line, "idempotency-key:")) (void)isValidIdempotencyKey(value);
  }
  (void)parseJsonBody(bytes.substr(extent.headerBytes));
  return 0;
}
