// Visibility buffer ("fat", as in the founding study): pass 1 writes the
// triangle id + packed barycentrics (R32G32_UINT) and packed uv derivatives
// (R32G32_UINT) with D32_S8; the shading pass (full screen, stencil == 1)
// fetches the triangle, interpolates and samples all five maps of the
// pixel's material, so map reads are covered pixels x 5 whatever the
// overshading of pass 1. Barycentrics come from the rasteriser
// (VK_KHR_fragment_shader_barycentric) where the device has it, else from
// the triangle's vertices re-projected per fragment (visibility.frag).
#include "renderers/renderers.hpp"
#include "renderers/visbuffer_base.hpp"

namespace tally::renderers {
namespace {

constexpr VkFormat kIdFormat = VK_FORMAT_R32G32_UINT;          // id, packUnorm2x16 barycentrics
constexpr VkFormat kDerivativeFormat = VK_FORMAT_R32G32_UINT;  // packHalf2x16 dFdx(uv), dFdy(uv)

class VisbufferRenderer final : public VisbufferBase {
 public:
  std::string_view name() const override { return "visbuffer"; }
  nlohmann::json notes() const override {
    nlohmann::json n = VisbufferBase::notes();
    n["barycentrics"] = extension_ ? "extension" : "computed";
    return n;
  }

 protected:
  Result<bool> setupPasses() override {
    if (auto fits = checkIdCapacity(); !fits) return fits;
    addMapResources();
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    Target id{createTarget("visibility.id", kIdFormat, usage, ResourceKind::Attachment), "visibility.id"};
    Target uvd{createTarget("visibility.uv_derivatives", kDerivativeFormat, usage, ResourceKind::Attachment),
               "visibility.uv_derivatives"};
    extension_ = ctx_->fragmentBarycentric;
    auto ok = addVisibilityPass("visibility.vert.glsl",
                                extension_ ? "visibility_bary.frag.glsl" : "visibility.frag.glsl", {id, uvd});
    if (!ok) return ok;
    return addShadingPass("shading.frag.glsl", {id, uvd});
  }

 private:
  bool extension_ = false;
};

}  // namespace

std::unique_ptr<Renderer> makeVisbuffer() { return std::make_unique<VisbufferRenderer>(); }

}  // namespace tally::renderers
