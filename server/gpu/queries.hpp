// Per-pass timestamps and pipeline statistics (shader invocations).
//
// lavapipe (Mesa 22.3.6) crashes when a pipeline-statistics query brackets a
// whole render pass: begin and end statistics queries INSIDE the render pass
// (after vkCmdBeginRenderPass, before vkCmdEndRenderPass). Resets, like every
// vkCmdResetQueryPool, must be recorded outside render passes.
#pragma once

#include <cstdint>
#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.hpp"

namespace tally::gpu {

// Two timestamps per pass: pass i uses queries 2i (begin) and 2i+1 (end).
struct TimestampQueries {
  VkQueryPool pool = VK_NULL_HANDLE;
  uint32_t passCount = 0;
};

// Throws VulkanError(VK_ERROR_FEATURE_NOT_PRESENT) when ctx.timestamps is false.
TimestampQueries createTimestampQueries(const Context& ctx, uint32_t passCount);
void destroyTimestampQueries(const Context& ctx, TimestampQueries& queries);
void resetTimestamps(VkCommandBuffer cmd, const TimestampQueries& queries);  // outside render passes
void writePassBegin(VkCommandBuffer cmd, const TimestampQueries& queries, uint32_t pass);
void writePassEnd(VkCommandBuffer cmd, const TimestampQueries& queries, uint32_t pass);
// Milliseconds per pass (end - begin, masked to timestampValidBits, times
// timestampPeriod). Waits for the results; call after the submission's fence.
std::vector<double> readPassTimesMs(const Context& ctx, const TimestampQueries& queries);

// The counters Vulkan defines; fields not asked for stay 0.
struct PipelineStatistics {
  uint64_t inputAssemblyVertices = 0;
  uint64_t inputAssemblyPrimitives = 0;
  uint64_t vertexShaderInvocations = 0;
  uint64_t geometryShaderInvocations = 0;
  uint64_t geometryShaderPrimitives = 0;
  uint64_t clippingInvocations = 0;
  uint64_t clippingPrimitives = 0;
  uint64_t fragmentShaderInvocations = 0;
  uint64_t tessControlPatches = 0;
  uint64_t tessEvaluationInvocations = 0;
  uint64_t computeShaderInvocations = 0;
};

constexpr VkQueryPipelineStatisticFlags kDefaultStatistics =
    VK_QUERY_PIPELINE_STATISTIC_VERTEX_SHADER_INVOCATIONS_BIT |
    VK_QUERY_PIPELINE_STATISTIC_CLIPPING_PRIMITIVES_BIT |
    VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT |
    VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT;

// One query per pass. Throws VulkanError(VK_ERROR_FEATURE_NOT_PRESENT) when
// ctx.pipelineStatistics is false.
struct StatisticsQueries {
  VkQueryPool pool = VK_NULL_HANDLE;
  uint32_t passCount = 0;
  VkQueryPipelineStatisticFlags flags = 0;
};

StatisticsQueries createStatisticsQueries(const Context& ctx, uint32_t passCount,
                                          VkQueryPipelineStatisticFlags flags = kDefaultStatistics);
void destroyStatisticsQueries(const Context& ctx, StatisticsQueries& queries);
void resetStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries);  // outside render passes
// Graphics passes: call inside the render pass (see the note at the top).
void beginStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries, uint32_t pass);
void endStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries, uint32_t pass);
// Waits for the results; call after the submission's fence.
std::vector<PipelineStatistics> readStatistics(const Context& ctx, const StatisticsQueries& queries);

}  // namespace tally::gpu
