#include "capture/screenshot_writer.hpp"

#include <fstream>

#include "analysis/image.hpp"

namespace tally::capture {

void ScreenshotWriter::write(std::filesystem::path path, std::vector<uint8_t> rgba, uint32_t width,
                             uint32_t height) {
  while (pending_.size() >= kInFlight) collect();
  pending_.push_back(
      std::async(std::launch::async, [path = std::move(path), rgba = std::move(rgba), width, height] {
        auto png = analysis::encodePng(rgba, width, height);
        std::ofstream out(path, std::ios::binary);
        out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
        out.close();
        return out ? std::string() : path.string();
      }));
}

}  // namespace tally::capture
