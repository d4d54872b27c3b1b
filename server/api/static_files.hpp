// The dashboard's static files, from one directory only: "/" is index.html;
// hidden files, directories, and anything whose real path (symlinks
// resolved) leaves the root are not served. Only regular files are: a FIFO,
// socket or device answers "not found" without being opened (an open of a
// FIFO would wait for a writer for ever).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "common/result.hpp"

namespace tally::api {

// 16 MiB: far above any dashboard asset; larger files are not served.
inline constexpr std::uintmax_t kMaxStaticFileBytes = 16u << 20;

struct StaticFile {
  std::string bytes;
  std::string contentType;
};

class StaticFiles {
 public:
  static Result<StaticFiles> open(const std::filesystem::path& root);

  // urlPath is the decoded request path (already through checkTarget).
  std::optional<StaticFile> lookup(std::string_view urlPath) const;
  const std::filesystem::path& root() const { return root_; }

 private:
  std::filesystem::path root_;  // canonical
};

// By extension; application/octet-stream when unknown.
std::string contentTypeFor(const std::filesystem::path& file);

// Whether canonical path `p` is `root` or below it (by components, not by string prefix).
bool isWithin(const std::filesystem::path& root, const std::filesystem::path& p);

}  // namespace tally::api
