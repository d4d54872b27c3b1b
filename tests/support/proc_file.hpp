// Reading /proc/PID/* of a process that may exit while it is read. read(2)
// then fails with ESRCH, which std::filebuf turns into a std::ios_failure
// (from a destructor, as in a harness's clean-up, that ends the test binary).
// Here the file simply reads as what was read so far, "" when it is gone.
#pragma once

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace tally::test {

inline std::string readProcFile(const std::filesystem::path& path) {
  std::string text;
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return text;
  char buf[4096];
  for (ssize_t n; (n = ::read(fd, buf, sizeof buf)) > 0;) text.append(buf, size_t(n));
  ::close(fd);
  return text;
}

}  // namespace tally::test
