// Validation follows the device: a module is held to the rules of the Vulkan
// version and block layouts its device enabled (spirv::ValidationTarget),
// for the input and for the instrumented output, and the layer reads that
// target from the application's VkDeviceCreateInfo.
#include <vulkan/vulkan.h>

#include "layer/shader_options.hpp"
#include "spirv/validate.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::assemble;

// A vertex shader reading element 1 of a uniform block's uint[4] laid out
// with a stride of 4 bytes, as zink lays out its uniform blocks: valid
// under uniform-buffer standard layout or scalar layout, not under the
// relaxed rules (an array in a uniform block needs a stride that is a
// multiple of 16 there). SPIR-V 1.0.
const char* kTightUniformArray = R"(
               OpCapability Shader
               OpMemoryModel Logical GLSL450
               OpEntryPoint Vertex %main "main" %position
               OpName %main "main"
               OpName %ubo "ubo"
               OpDecorate %position BuiltIn Position
               OpDecorate %array ArrayStride 4
               OpMemberDecorate %block 0 Offset 0
               OpDecorate %block Block
               OpDecorate %ubo DescriptorSet 0
               OpDecorate %ubo Binding 0
       %void = OpTypeVoid
     %fnvoid = OpTypeFunction %void
       %uint = OpTypeInt 32 0
      %float = OpTypeFloat 32
    %v4float = OpTypeVector %float 4
     %uint_0 = OpConstant %uint 0
     %uint_1 = OpConstant %uint 1
     %uint_4 = OpConstant %uint 4
    %float_1 = OpConstant %float 1
      %array = OpTypeArray %uint %uint_4
      %block = OpTypeStruct %array
  %ptr_block = OpTypePointer Uniform %block
   %ptr_uint = OpTypePointer Uniform %uint
  %ptr_out_v4 = OpTypePointer Output %v4float
        %ubo = OpVariable %ptr_block Uniform
   %position = OpVariable %ptr_out_v4 Output
       %main = OpFunction %void None %fnvoid
      %entry = OpLabel
    %element = OpAccessChain %ptr_uint %ubo %uint_0 %uint_1
       %bits = OpLoad %uint %element
          %x = OpConvertUToF %float %bits
        %pos = OpCompositeConstruct %v4float %x %float_1 %float_1 %float_1
               OpStore %position %pos
               OpReturn
               OpFunctionEnd
)";

InstrumentOptions withTarget(const ValidationTarget& target) {
  InstrumentOptions options;
  options.target = target;
  return options;
}

TEST(ValidationTarget, AUniformArrayOfStride4IsRefusedByDefaultAndUnderRelaxedRules) {
  auto words = assemble(kTightUniformArray, SPV_ENV_VULKAN_1_0);
  auto strict = instrument(words, {});
  ASSERT_FALSE(strict.ok());
  EXPECT_NE(strict.error().find("invalid SPIR-V: "), std::string::npos) << strict.error();
  EXPECT_NE(strict.error().find("uniform buffer layout rules"), std::string::npos) << strict.error();
  // Vulkan 1.1 relaxes block layout (offsets), not array strides.
  ValidationTarget relaxed{VK_API_VERSION_1_1, true};
  auto r = instrument(words, withTarget(relaxed));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("validated for Vulkan 1.1, relaxed block layout"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("relaxed uniform buffer layout rules"), std::string::npos) << r.error();
}

TEST(ValidationTarget, UniformBufferStandardLayoutAcceptsItAndItsOutputValidatesThere) {
  auto words = assemble(kTightUniformArray, SPV_ENV_VULKAN_1_0);
  ValidationTarget target{VK_API_VERSION_1_2, true};
  target.uniformBufferStandardLayout = true;
  auto r = instrument(words, withTarget(target));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(validate(r->words, target), std::nullopt);
  // The output keeps the application's layout: only the device's rules accept it.
  EXPECT_NE(validate(r->words), std::nullopt);
  EXPECT_EQ(test::sitesOf(*r, SiteKind::BufferRead).size(), 1u);  // ubo.arr[1]
}

TEST(ValidationTarget, ScalarBlockLayoutAcceptsItAndItsOutputValidatesThere) {
  auto words = assemble(kTightUniformArray, SPV_ENV_VULKAN_1_0);
  ValidationTarget target{VK_API_VERSION_1_3, true};
  target.scalarBlockLayout = true;
  auto r = instrument(words, withTarget(target));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(validate(r->words, target), std::nullopt);
  EXPECT_NE(validate(r->words), std::nullopt);
}

// A compute shader sized by LocalSizeId: SPIR-V 1.5 (Vulkan 1.2), where the
// mode needs maintenance4.
const char* kLocalSizeId = R"(
               OpCapability Shader
               OpMemoryModel Logical GLSL450
               OpEntryPoint GLCompute %main "main"
               OpExecutionModeId %main LocalSizeId %uint_8 %uint_1 %uint_1
       %void = OpTypeVoid
     %fnvoid = OpTypeFunction %void
       %uint = OpTypeInt 32 0
     %uint_8 = OpConstant %uint 8
     %uint_1 = OpConstant %uint 1
       %main = OpFunction %void None %fnvoid
      %entry = OpLabel
               OpReturn
               OpFunctionEnd
)";

TEST(ValidationTarget, LocalSizeIdNeedsMaintenance4OrVulkan13) {
  auto words = assemble(kLocalSizeId, SPV_ENV_VULKAN_1_2);
  EXPECT_NE(validate(words), std::nullopt);
  EXPECT_NE(validate(words, {VK_API_VERSION_1_2, true}), std::nullopt);
  ValidationTarget maintenance4{VK_API_VERSION_1_2, true};
  maintenance4.localSizeId = true;
  EXPECT_EQ(validate(words, maintenance4), std::nullopt);
  // A Vulkan 1.3 device's environment allows it: the later of the module's and the device's.
  EXPECT_EQ(validate(words, {VK_API_VERSION_1_3, true}), std::nullopt);
  // A device older than the module does not lower the module's own environment.
  EXPECT_NE(validate(words, {VK_API_VERSION_1_1, true}), std::nullopt);
  auto r = instrument(words, withTarget(maintenance4));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(validate(r->words, maintenance4), std::nullopt);
}

// ---------------------------------------------------------------- the layer's reading of the device

TEST(DeviceValidationTarget, TheLowerOfTheInstanceAndDeviceVersionsAndNoLayoutsUnlessEnabled) {
  VkDeviceCreateInfo info = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  auto t = layer::validationTarget(info, VK_API_VERSION_1_1, VK_MAKE_API_VERSION(0, 1, 3, 230));
  EXPECT_EQ(t.vulkanVersion, VK_API_VERSION_1_1);
  EXPECT_TRUE(t.relaxedBlockLayout);
  EXPECT_FALSE(t.scalarBlockLayout || t.uniformBufferStandardLayout || t.localSizeId || t.workgroupScalarBlockLayout);
  t = layer::validationTarget(info, VK_API_VERSION_1_3, VK_MAKE_API_VERSION(0, 1, 2, 199));
  EXPECT_EQ(t.vulkanVersion, VK_API_VERSION_1_2);  // the patch number dropped
  t = layer::validationTarget(info, VK_API_VERSION_1_0, VK_API_VERSION_1_3);
  EXPECT_FALSE(t.relaxedBlockLayout);
  const char* relaxed = VK_KHR_RELAXED_BLOCK_LAYOUT_EXTENSION_NAME;
  info.enabledExtensionCount = 1;
  info.ppEnabledExtensionNames = &relaxed;
  EXPECT_TRUE(layer::validationTarget(info, VK_API_VERSION_1_0, VK_API_VERSION_1_3).relaxedBlockLayout);
}

TEST(DeviceValidationTarget, FeaturesAreReadFromEveryStructureOfTheChain) {
  VkPhysicalDeviceVulkan12Features v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES, &v12};
  VkPhysicalDeviceFeatures2 features2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &v13};
  VkDeviceCreateInfo info = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features2};
  v12.scalarBlockLayout = VK_TRUE;
  v13.maintenance4 = VK_TRUE;
  auto t = layer::validationTarget(info, VK_API_VERSION_1_3, VK_API_VERSION_1_3);
  EXPECT_TRUE(t.scalarBlockLayout);
  EXPECT_FALSE(t.uniformBufferStandardLayout);
  EXPECT_TRUE(t.localSizeId);

  VkPhysicalDeviceUniformBufferStandardLayoutFeatures standard = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_UNIFORM_BUFFER_STANDARD_LAYOUT_FEATURES};
  standard.uniformBufferStandardLayout = VK_TRUE;
  VkPhysicalDeviceScalarBlockLayoutFeatures scalar = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SCALAR_BLOCK_LAYOUT_FEATURES,
                                                      &standard};
  VkPhysicalDeviceMaintenance4Features maintenance4 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_FEATURES,
                                                       &scalar};
  VkPhysicalDeviceWorkgroupMemoryExplicitLayoutFeaturesKHR workgroup = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_WORKGROUP_MEMORY_EXPLICIT_LAYOUT_FEATURES_KHR, &maintenance4};
  workgroup.workgroupMemoryExplicitLayoutScalarBlockLayout = VK_TRUE;
  info.pNext = &workgroup;
  t = layer::validationTarget(info, VK_API_VERSION_1_1, VK_API_VERSION_1_3);
  EXPECT_FALSE(t.scalarBlockLayout);  // present, not enabled
  EXPECT_TRUE(t.uniformBufferStandardLayout);
  EXPECT_FALSE(t.localSizeId);
  EXPECT_TRUE(t.workgroupScalarBlockLayout);
  maintenance4.maintenance4 = VK_TRUE;
  scalar.scalarBlockLayout = VK_TRUE;
  t = layer::validationTarget(info, VK_API_VERSION_1_1, VK_API_VERSION_1_3);
  EXPECT_TRUE(t.localSizeId && t.scalarBlockLayout);
}

}  // namespace
}  // namespace tally::spirv
