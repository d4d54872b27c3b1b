// The images the materials use: decoded once each by stb_image on several
// threads, checked against Tally's size limits, and halved down to
// GltfOptions::maxTextureSize.
#include "scenes/gltf_loader.hpp"

#include <algorithm>
#include <atomic>
#include <thread>

#include <stb_image.h>

#include "scenes/gltf_check.hpp"

namespace tally::scenes::detail {
namespace {

// Halves with a 2x2 box filter until neither side exceeds maxSize.
void downsize(Texture& t, uint32_t maxSize) {
  while (t.width > maxSize || t.height > maxSize) {
    uint32_t w = std::max(1u, t.width / 2), h = std::max(1u, t.height / 2);
    std::vector<uint8_t> out(size_t(w) * h * 4);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        uint32_t x0 = std::min(2 * x, t.width - 1), x1 = std::min(2 * x + 1, t.width - 1);
        uint32_t y0 = std::min(2 * y, t.height - 1), y1 = std::min(2 * y + 1, t.height - 1);
        for (int c = 0; c < 4; ++c) {
          auto at = [&](uint32_t xx, uint32_t yy) {
            return uint32_t(t.rgba8[(size_t(yy) * t.width + xx) * 4 + size_t(c)]);
          };
          out[(size_t(y) * w + x) * 4 + size_t(c)] =
              uint8_t((at(x0, y0) + at(x1, y0) + at(x0, y1) + at(x1, y1) + 2) / 4);
        }
      }
    t.width = w;
    t.height = h;
    t.rgba8 = std::move(out);
  }
}

}  // namespace

std::string Loader::imageName(int image) const {
  const tinygltf::Image& im = model.images[size_t(image)];
  if (!im.name.empty()) return im.name;
  if (!im.uri.empty()) return im.uri;
  return "image " + std::to_string(image);
}

Result<bool> Loader::decodeTextures() {
  std::vector<int> images;
  for (const ImageUse& u : uses)
    if (std::find(images.begin(), images.end(), u.image) == images.end()) images.push_back(u.image);
  std::vector<Texture> decoded(images.size());
  std::vector<std::string> errors(images.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t k = next++; k < images.size(); k = next++) {
      const tinygltf::Image& im = model.images[size_t(images[k])];
      if (im.image.empty()) {
        errors[k] = "image " + std::to_string(images[k]) + " (" + imageName(images[k]) +
                    "): no data (file missing or unreadable)";
        continue;
      }
      int w = 0, h = 0, comp = 0;
      // The header's size first: a decoded image is w x h x 4 bytes.
      if (stbi_info_from_memory(im.image.data(), int(im.image.size()), &w, &h, &comp) &&
          (uint32_t(w) > kMaxImageSide || uint32_t(h) > kMaxImageSide ||
           uint64_t(w) * uint64_t(h) > kMaxImageTexels)) {
        errors[k] = "image " + std::to_string(images[k]) + " (" + imageName(images[k]) + "): " + std::to_string(w) +
                    "x" + std::to_string(h) + " texels, over Tally's limit of " + std::to_string(kMaxImageSide) +
                    " per side";
        continue;
      }
      stbi_uc* px = stbi_load_from_memory(im.image.data(), int(im.image.size()), &w, &h, &comp, 4);
      if (!px) {
        errors[k] =
            "image " + std::to_string(images[k]) + " (" + imageName(images[k]) +
            "): cannot decode: " + (stbi_failure_reason() ? stbi_failure_reason() : "unknown format");
        continue;
      }
      Texture& t = decoded[k];
      t.width = uint32_t(w);
      t.height = uint32_t(h);
      t.rgba8.assign(px, px + size_t(w) * size_t(h) * 4);
      stbi_image_free(px);
      if (options.maxTextureSize > 0) downsize(t, options.maxTextureSize);
    }
  };
  unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
  threads = unsigned(std::min<size_t>(threads, images.size()));
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const std::string& e : errors)
    if (!e.empty()) return makeError(e);

  for (const ImageUse& u : uses) {
    size_t k = size_t(std::find(images.begin(), images.end(), u.image) - images.begin());
    Texture t;
    t.name = imageName(u.image);
    t.width = decoded[k].width;
    t.height = decoded[k].height;
    t.srgb = u.srgb;
    t.sampler = u.sampler;
    t.rgba8 = decoded[k].rgba8;  // copies only when an image is used in both colour spaces
    scene.textures.push_back(std::move(t));
  }
  return true;
}

}  // namespace tally::scenes::detail
