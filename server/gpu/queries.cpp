#include "gpu/queries.hpp"

#include <bit>

#include "gpu/vk_check.hpp"

namespace tally::gpu {

TimestampQueries createTimestampQueries(const Context& ctx, uint32_t passCount) {
  if (!ctx.timestamps) {
    throwVulkanError(VK_ERROR_FEATURE_NOT_PRESENT, "createTimestampQueries (the queue writes no timestamps)",
                     __FILE__, __LINE__);
  }
  TimestampQueries queries;
  queries.passCount = passCount;
  VkQueryPoolCreateInfo info = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = 2 * passCount;
  VK_CHECK(vkCreateQueryPool(ctx.device, &info, nullptr, &queries.pool));
  return queries;
}

void destroyTimestampQueries(const Context& ctx, TimestampQueries& queries) {
  if (queries.pool != VK_NULL_HANDLE) vkDestroyQueryPool(ctx.device, queries.pool, nullptr);
  queries = TimestampQueries{};
}

void resetTimestamps(VkCommandBuffer cmd, const TimestampQueries& queries) {
  vkCmdResetQueryPool(cmd, queries.pool, 0, 2 * queries.passCount);
}

void writePassBegin(VkCommandBuffer cmd, const TimestampQueries& queries, uint32_t pass) {
  // Top of pipe: when the pass's first command starts.
  vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries.pool, 2 * pass);
}

void writePassEnd(VkCommandBuffer cmd, const TimestampQueries& queries, uint32_t pass) {
  // Bottom of pipe: after every command of the pass has completed.
  vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries.pool, 2 * pass + 1);
}

std::vector<double> readPassTimesMs(const Context& ctx, const TimestampQueries& queries) {
  std::vector<uint64_t> ticks(2 * queries.passCount);
  if (ticks.empty()) return {};
  VK_CHECK(vkGetQueryPoolResults(ctx.device, queries.pool, 0, static_cast<uint32_t>(ticks.size()),
                                 ticks.size() * sizeof(uint64_t), ticks.data(), sizeof(uint64_t),
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  uint64_t mask = ctx.timestampValidBits >= 64 ? ~0ull : ((1ull << ctx.timestampValidBits) - 1);
  std::vector<double> ms(queries.passCount);
  for (uint32_t i = 0; i < queries.passCount; ++i) {
    // Unsigned subtraction modulo the valid bits survives one wrap of the counter.
    uint64_t delta = (ticks[2 * i + 1] - ticks[2 * i]) & mask;
    ms[i] = static_cast<double>(delta) * ctx.timestampPeriod * 1e-6;
  }
  return ms;
}

StatisticsQueries createStatisticsQueries(const Context& ctx, uint32_t passCount,
                                          VkQueryPipelineStatisticFlags flags) {
  if (!ctx.pipelineStatistics) {
    throwVulkanError(VK_ERROR_FEATURE_NOT_PRESENT, "createStatisticsQueries (no pipelineStatisticsQuery)",
                     __FILE__, __LINE__);
  }
  StatisticsQueries queries;
  queries.passCount = passCount;
  queries.flags = flags;
  VkQueryPoolCreateInfo info = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
  info.queryCount = passCount;
  info.pipelineStatistics = flags;
  VK_CHECK(vkCreateQueryPool(ctx.device, &info, nullptr, &queries.pool));
  return queries;
}

void destroyStatisticsQueries(const Context& ctx, StatisticsQueries& queries) {
  if (queries.pool != VK_NULL_HANDLE) vkDestroyQueryPool(ctx.device, queries.pool, nullptr);
  queries = StatisticsQueries{};
}

void resetStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries) {
  vkCmdResetQueryPool(cmd, queries.pool, 0, queries.passCount);
}

void beginStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries, uint32_t pass) {
  vkCmdBeginQuery(cmd, queries.pool, pass, 0);
}

void endStatistics(VkCommandBuffer cmd, const StatisticsQueries& queries, uint32_t pass) {
  vkCmdEndQuery(cmd, queries.pool, pass);
}

std::vector<PipelineStatistics> readStatistics(const Context& ctx, const StatisticsQueries& queries) {
  // Results come as one uint64 per enabled flag, in increasing bit order.
  const uint32_t perQuery = static_cast<uint32_t>(std::popcount(queries.flags));
  std::vector<uint64_t> values(size_t(perQuery) * queries.passCount);
  if (values.empty()) return std::vector<PipelineStatistics>(queries.passCount);
  VK_CHECK(vkGetQueryPoolResults(ctx.device, queries.pool, 0, queries.passCount,
                                 values.size() * sizeof(uint64_t), values.data(), perQuery * sizeof(uint64_t),
                                 VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  std::vector<PipelineStatistics> out(queries.passCount);
  for (uint32_t q = 0; q < queries.passCount; ++q) {
    const uint64_t* v = &values[size_t(q) * perQuery];
    PipelineStatistics& s = out[q];
    uint32_t i = 0;
    auto take = [&](VkQueryPipelineStatisticFlagBits bit, uint64_t& field) {
      if (queries.flags & bit) field = v[i++];
    };
    take(VK_QUERY_PIPELINE_STATISTIC_INPUT_ASSEMBLY_VERTICES_BIT, s.inputAssemblyVertices);
    take(VK_QUERY_PIPELINE_STATISTIC_INPUT_ASSEMBLY_PRIMITIVES_BIT, s.inputAssemblyPrimitives);
    take(VK_QUERY_PIPELINE_STATISTIC_VERTEX_SHADER_INVOCATIONS_BIT, s.vertexShaderInvocations);
    take(VK_QUERY_PIPELINE_STATISTIC_GEOMETRY_SHADER_INVOCATIONS_BIT, s.geometryShaderInvocations);
    take(VK_QUERY_PIPELINE_STATISTIC_GEOMETRY_SHADER_PRIMITIVES_BIT, s.geometryShaderPrimitives);
    take(VK_QUERY_PIPELINE_STATISTIC_CLIPPING_INVOCATIONS_BIT, s.clippingInvocations);
    take(VK_QUERY_PIPELINE_STATISTIC_CLIPPING_PRIMITIVES_BIT, s.clippingPrimitives);
    take(VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT, s.fragmentShaderInvocations);
    take(VK_QUERY_PIPELINE_STATISTIC_TESSELLATION_CONTROL_SHADER_PATCHES_BIT, s.tessControlPatches);
    take(VK_QUERY_PIPELINE_STATISTIC_TESSELLATION_EVALUATION_SHADER_INVOCATIONS_BIT,
         s.tessEvaluationInvocations);
    take(VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT, s.computeShaderInvocations);
  }
  return out;
}

}  // namespace tally::gpu
