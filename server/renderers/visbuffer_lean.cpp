// Lean visibility buffer (Burns & Hunt 2013): pass 1 writes one 32-bit id
// (R32_UINT) and D32_S8 depth; the shading pass recomputes barycentrics and
// uv derivatives analytically from the triangle's re-projected vertices.
#include "renderers/renderers.hpp"
#include "renderers/visbuffer_base.hpp"

namespace tally::renderers {
namespace {

constexpr VkFormat kIdFormat = VK_FORMAT_R32_UINT;

class LeanVisbufferRenderer final : public VisbufferBase {
 public:
  std::string_view name() const override { return "visbuffer-lean"; }

 protected:
  Result<bool> setupPasses() override {
    if (auto fits = checkIdCapacity(); !fits) return fits;
    addMapResources();
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    // The ids are readable (targetBytes) so they can be checked against the geometry;
    // multisampled ones (msaa > 1) are not (no copy from a multisampled image).
    const uint32_t n = targetSamples();
    const VkImageUsageFlags readable = n > 1 ? 0 : VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if (auto ok = checkMsaa({{kIdFormat, usage}}); !ok) return ok;
    Target id{createTarget("visibility.id", kIdFormat, usage | readable, ResourceKind::Attachment, n),
              "visibility.id"};
    auto ok = addVisibilityPass("zprepass.vert.glsl", "visibility_lean.frag.glsl", {id});
    if (!ok) return ok;
    return addShadingPass("shading_lean.frag.glsl", {id});
  }
};

}  // namespace

std::unique_ptr<Renderer> makeLeanVisbuffer() { return std::make_unique<LeanVisbufferRenderer>(); }

}  // namespace tally::renderers
