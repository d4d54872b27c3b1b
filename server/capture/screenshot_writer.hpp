// Writing a capture's screenshots beside its rendering.
#pragma once

#include <cstdint>
#include <deque>
#include <filesystem>
#include <future>
#include <string>
#include <vector>

namespace tally::capture {

// Screenshots are encoded and written on other threads while the GPU renders
// the next samples: PNG encoding of a 1920x1080 image takes about 0.4 s, a
// quarter of the founding protocol's 187 s when done in line (H200,
// docs/accuracy.md). At most kInFlight at once; finish() waits for all and
// names the first file that could not be written.
class ScreenshotWriter {
 public:
  void write(std::filesystem::path path, std::vector<uint8_t> rgba, uint32_t width, uint32_t height);
  // "" when every screenshot was written.
  std::string finish() {
    while (!pending_.empty()) collect();
    return failed_;
  }
  ~ScreenshotWriter() { finish(); }

 private:
  static constexpr size_t kInFlight = 8;  // 8 images of 8 MiB at 1920x1080
  void collect() {
    std::string failed = pending_.front().get();
    if (failed_.empty()) failed_ = failed;
    pending_.pop_front();
  }
  std::deque<std::future<std::string>> pending_;
  std::string failed_;
};

}  // namespace tally::capture
