// VK_CHECK: every Vulkan call is checked, in release builds too. A failure
// throws VulkanError naming the call, file, line and VkResult, so that a
// capture can be abandoned and the daemon lives on (niagara VK_CHECK_FORCE,
// RenderDoc CHECK_VKR).
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

#include <vulkan/vulkan.h>

namespace tally::gpu {

class VulkanError : public std::runtime_error {
 public:
  VulkanError(std::string message, VkResult result)
      : std::runtime_error(std::move(message)), result_(result) {}
  VkResult result() const { return result_; }

 private:
  VkResult result_;
};

// "VK_ERROR_DEVICE_LOST", or "VkResult(-1000012000)" for values this header does not name.
std::string_view resultName(VkResult result);

[[noreturn]] void throwVulkanError(VkResult result, const char* call, const char* file, int line);

}  // namespace tally::gpu

// Evaluates `call` once; throws tally::gpu::VulkanError unless it returned
// VK_SUCCESS. Non-error statuses other than VK_SUCCESS (VK_NOT_READY,
// VK_TIMEOUT, VK_INCOMPLETE) also throw: callers that expect them test the
// result themselves.
#define VK_CHECK(call)                                                           \
  do {                                                                           \
    VkResult vkCheckResult_ = (call);                                            \
    if (vkCheckResult_ != VK_SUCCESS) {                                          \
      ::tally::gpu::throwVulkanError(vkCheckResult_, #call, __FILE__, __LINE__); \
    }                                                                            \
  } while (false)
