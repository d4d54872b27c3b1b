#include "api/static_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <iterator>
#include <map>

namespace tally::api {

Result<StaticFiles> StaticFiles::open(const std::filesystem::path& root) {
  std::error_code ec;
  auto canon = std::filesystem::canonical(root, ec);
  if (ec) return makeError("web root " + root.string() + ": " + ec.message());
  if (!std::filesystem::is_directory(canon, ec))
    return makeError("web root " + root.string() + ": not a directory");
  StaticFiles files;
  files.root_ = canon;
  return files;
}

bool isWithin(const std::filesystem::path& root, const std::filesystem::path& p) {
  auto [r, q] = std::mismatch(root.begin(), root.end(), p.begin(), p.end());
  // A trailing empty component in root ("/web/") matches anything below.
  return r == root.end() || (std::next(r) == root.end() && r->empty());
}

std::optional<StaticFile> StaticFiles::lookup(std::string_view urlPath) const {
  if (urlPath.empty() || urlPath.front() != '/') return std::nullopt;
  std::string rel = urlPath == "/" ? std::string("index.html") : std::string(urlPath.substr(1));
  // Every segment non-empty and not hidden (no ".", "..", ".git", ...).
  size_t start = 0;
  while (start <= rel.size()) {
    size_t end = rel.find('/', start);
    if (end == std::string::npos) end = rel.size();
    if (end == start || rel[start] == '.') return std::nullopt;
    start = end + 1;
  }
  if (rel.find('\0') != std::string::npos || rel.find('\\') != std::string::npos) return std::nullopt;

  std::error_code ec;
  auto canon = std::filesystem::canonical(root_ / rel, ec);
  if (ec || !isWithin(root_, canon)) return std::nullopt;

  // The type first, without opening: open() on a FIFO blocks until a writer
  // comes (for ever), and on a device it may do anything. Only regular files.
  struct stat st {};
  if (::lstat(canon.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return std::nullopt;
  // O_NONBLOCK: a FIFO swapped in since the lstat does not block the open
  // either; O_NOFOLLOW: nor does a symlink. fstat then checks what was opened.
  int fd = ::open(canon.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return std::nullopt;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) ||
      static_cast<std::uintmax_t>(st.st_size) > kMaxStaticFileBytes) {
    ::close(fd);
    return std::nullopt;
  }
  StaticFile file;
  file.bytes.resize(static_cast<size_t>(st.st_size));
  size_t done = 0;
  while (done < file.bytes.size()) {
    ssize_t n = ::read(fd, file.bytes.data() + done, file.bytes.size() - done);
    if (n <= 0) break;
    done += static_cast<size_t>(n);
  }
  ::close(fd);
  file.bytes.resize(done);
  file.contentType = contentTypeFor(canon);
  return file;
}

std::string contentTypeFor(const std::filesystem::path& file) {
  static const std::map<std::string, std::string> kTypes = {
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".gif", "image/gif"},
      {".webp", "image/webp"},
      {".ico", "image/x-icon"},
      {".txt", "text/plain; charset=utf-8"},
      {".csv", "text/csv; charset=utf-8"},
      {".woff", "font/woff"},
      {".woff2", "font/woff2"},
      {".wasm", "application/wasm"},
  };
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  auto it = kTypes.find(ext);
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

}  // namespace tally::api
