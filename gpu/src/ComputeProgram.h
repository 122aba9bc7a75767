// One compute shader with its storage buffers bound at set 0, bindings 0..n−1, and a push
// constant block: the set layout, pipeline layout, pipeline, descriptor pool and its one set.
// Used by the cut selection and the line-of-sight passes. Thread-safety: immutable once made.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/UniqueHandle.h"

namespace pbdam::gpu {

class VulkanContext;

class ComputeProgram final {
 public:
  /// `spirv` is the shader, `buffers` are bound in order, `pushBytes` the push constants' size.
  static formats::Result<ComputeProgram> create(const VulkanContext& context,
                                                std::span<const uint32_t> spirv,
                                                std::string_view name,
                                                const std::vector<const GpuBuffer*>& buffers,
                                                std::uint32_t pushBytes);

  /// Binds the pipeline and the set on `cmd`.
  void bind(VkCommandBuffer cmd) const noexcept;
  /// Push constants for the next dispatches.
  void push(VkCommandBuffer cmd, std::span<const std::byte> bytes) const noexcept;

 private:
  UniqueDescriptorSetLayout setLayout_;
  UniquePipelineLayout layout_;
  UniquePipeline pipeline_;
  UniqueDescriptorPool pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

/// Dispatches `invocations` invocations of a shader of `localSize` × 1 × 1 in as many rows of
/// at most `groupsPerRow` groups (default 65,535: the least maxComputeWorkGroupCount Vulkan
/// guarantees) as it takes; the shader's index is gl_GlobalInvocationID.x +
/// gl_GlobalInvocationID.y · gl_NumWorkGroups.x · localSize, and a whole group's is
/// gl_WorkGroupID.x + gl_WorkGroupID.y · gl_NumWorkGroups.x. The last row may hold groups past
/// the end: the shader returns for indices past `invocations`.
void dispatchLinear(VkCommandBuffer cmd, std::uint64_t invocations, std::uint32_t localSize,
                    std::uint32_t groupsPerRow = 65535) noexcept;

/// One global memory barrier (synchronization2) from `srcStages`' `srcAccess` to `dstStages`'
/// `dstAccess`.
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStages, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStages, VkAccessFlags2 dstAccess) noexcept;

/// Makes one dispatch's shader-storage writes visible to the next dispatch (`toHost`: to host
/// reads instead).
void computeBarrier(VkCommandBuffer cmd, bool toHost = false) noexcept;

/// Makes transfer writes (vkCmdFillBuffer, copies) visible to the next dispatches.
void transferToComputeBarrier(VkCommandBuffer cmd) noexcept;

}  // namespace pbdam::gpu
