// Visibility buffer ("fat", as in the founding study): pass 1 writes the
// triangle id + packed barycentrics (R32G32_UINT) and packed uv derivatives
// (R32G32_UINT) with D32_S8; the shading pass (full screen, stencil == 1)
// fetches the triangle, interpolates and samples all five maps of the
// pixel's material, so map reads are covered pixels x 5 whatever the
// overshading of pass 1. Barycentrics come from the rasteriser
// (VK_KHR_fragment_shader_barycentric) where the device has it, else from
// the triangle's vertices re-projected per fragment (visibility.frag).
// RendererOptions::visibility can store barycentrics and derivatives at other
// precisions (the precision sweep): the targets' formats follow, so bytes are
// counted from what is really stored (shaders/visibility_encoding.h).
#include "renderers/renderers.hpp"
#include "renderers/visbuffer_base.hpp"

namespace tally::renderers {
namespace {

constexpr VkFormat kIdFormat = VK_FORMAT_R32G32_UINT;          // id, packUnorm2x16 barycentrics
constexpr VkFormat kDerivativeFormat = VK_FORMAT_R32G32_UINT;  // packHalf2x16 dFdx(uv), dFdy(uv)
// Float32 encodings: id and two float barycentrics in three words (four where
// the device cannot render to R32G32B32_UINT), four floats of derivatives.
constexpr VkFormat kIdFloatFormat = VK_FORMAT_R32G32B32_UINT;
constexpr VkFormat kIdFloatFallbackFormat = VK_FORMAT_R32G32B32A32_UINT;
constexpr VkFormat kDerivativeFloatFormat = VK_FORMAT_R32G32B32A32_UINT;

// Whether `format` with optimal tiling can be everything a visibility target is.
bool supportsTarget(const gpu::Context& ctx, VkFormat format) {
  VkFormatProperties props = {};
  vkGetPhysicalDeviceFormatProperties(ctx.physicalDevice, format, &props);
  const VkFormatFeatureFlags needed = VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT |
                                      VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT;
  return (props.optimalTilingFeatures & needed) == needed;
}

// The shader defines of an encoding (none for the default).
std::vector<std::string> encodingDefines(const VisibilityEncoding& e) {
  std::vector<std::string> out;
  if (e.barycentrics == BarycentricEncoding::Float32) out.push_back("TALLY_BARYCENTRICS_FLOAT32");
  if (e.uvDerivatives == UvDerivativeEncoding::Unorm16Clamped) out.push_back("TALLY_UV_DERIVATIVES_UNORM16");
  if (e.uvDerivatives == UvDerivativeEncoding::Float32) out.push_back("TALLY_UV_DERIVATIVES_FLOAT32");
  return out;
}

class VisbufferRenderer final : public VisbufferBase {
 public:
  std::string_view name() const override { return "visbuffer"; }
  nlohmann::json notes() const override {
    nlohmann::json n = VisbufferBase::notes();
    n["barycentrics"] = extension_ ? "extension" : "computed";
    n["visibility_encoding"] = {{"barycentrics", toString(options_.visibility.barycentrics)},
                                {"uv_derivatives", toString(options_.visibility.uvDerivatives)}};
    return n;
  }

 protected:
  Result<bool> setupPasses() override {
    if (auto fits = checkIdCapacity(); !fits) return fits;
    addMapResources();
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    // The ids are readable (targetBytes) so they can be checked against the geometry;
    // multisampled ones (msaa > 1) are not (no copy from a multisampled image).
    const uint32_t n = targetSamples();
    const VkImageUsageFlags readable = n > 1 ? 0 : VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    if (auto ok = checkMsaa({{idFormat(), usage}, {derivativeFormat(), usage}}); !ok) return ok;
    Target id{createTarget("visibility.id", idFormat(), usage | readable, ResourceKind::Attachment, n),
              "visibility.id"};
    // The derivatives too: the precision sweep decodes them (mip level per pixel).
    Target uvd{createTarget("visibility.uv_derivatives", derivativeFormat(), usage | readable,
                            ResourceKind::Attachment, n),
               "visibility.uv_derivatives"};
    extension_ = ctx_->fragmentBarycentric;
    const std::vector<std::string> defines = encodingDefines(options_.visibility);
    auto ok = addVisibilityPass("visibility.vert.glsl",
                                extension_ ? "visibility_bary.frag.glsl" : "visibility.frag.glsl", {id, uvd},
                                defines);
    if (!ok) return ok;
    return addShadingPass("shading.frag.glsl", {id, uvd}, defines);
  }

 private:
  VkFormat idFormat() const {
    if (options_.visibility.barycentrics == BarycentricEncoding::Unorm16) return kIdFormat;
    return supportsTarget(*ctx_, kIdFloatFormat) ? kIdFloatFormat : kIdFloatFallbackFormat;
  }
  VkFormat derivativeFormat() const {
    return options_.visibility.uvDerivatives == UvDerivativeEncoding::Float32 ? kDerivativeFloatFormat
                                                                              : kDerivativeFormat;
  }

  bool extension_ = false;
};

}  // namespace

std::unique_ptr<Renderer> makeVisbuffer() { return std::make_unique<VisbufferRenderer>(); }

}  // namespace tally::renderers
