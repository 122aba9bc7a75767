// One compute shader and its storage buffers (ComputeProgram.h).
#include "ComputeProgram.h"
#include <algorithm>

#include "GraphicsPipeline.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

namespace pbdam::gpu {

Result<ComputeProgram> ComputeProgram::create(const VulkanContext& context,
                                              std::span<const uint32_t> spirv,
                                              std::string_view name,
                                              const std::vector<const GpuBuffer*>& buffers,
                                              std::uint32_t pushBytes) {
  VkDevice device = context.device();
  const std::string what(name);
  ComputeProgram p;
  const auto count = static_cast<std::uint32_t>(buffers.size());
  std::vector<VkDescriptorSetLayoutBinding> bindings(count);
  for (std::uint32_t b = 0; b < count; ++b) {
    bindings[b].binding = b;
    bindings[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[b].descriptorCount = 1;
    bindings[b].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo setInfo{};
  setInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  setInfo.bindingCount = count;
  setInfo.pBindings = bindings.data();
  VkDescriptorSetLayout rawSet = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorSetLayout(device, &setInfo, nullptr, &rawSet);
      r != VK_SUCCESS) {
    return vulkanError(r, what + " set layout");
  }
  p.setLayout_ = UniqueDescriptorSetLayout(device, rawSet);
  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, pushBytes};
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &rawSet;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
      r != VK_SUCCESS) {
    return vulkanError(r, what + " pipeline layout");
  }
  p.layout_ = UniquePipelineLayout(device, rawLayout);
  auto pipeline = createComputePipeline(device, rawLayout, spirv, (what + " pipeline").c_str());
  if (!pipeline) return std::move(pipeline).error();
  p.pipeline_ = std::move(*pipeline);

  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, count};
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(device, &poolInfo, nullptr, &rawPool); r != VK_SUCCESS) {
    return vulkanError(r, what + " descriptor pool");
  }
  p.pool_ = UniqueDescriptorPool(device, rawPool);
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &rawSet;
  if (VkResult r = vkAllocateDescriptorSets(device, &allocate, &p.set_); r != VK_SUCCESS) {
    return vulkanError(r, what + " descriptor set");
  }
  std::vector<VkDescriptorBufferInfo> infos(count);
  std::vector<VkWriteDescriptorSet> writes(count);
  for (std::uint32_t b = 0; b < count; ++b) {
    infos[b] = VkDescriptorBufferInfo{buffers[b]->buffer(), 0, VK_WHOLE_SIZE};
    writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[b].dstSet = p.set_;
    writes[b].dstBinding = b;
    writes[b].descriptorCount = 1;
    writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[b].pBufferInfo = &infos[b];
  }
  vkUpdateDescriptorSets(device, count, writes.data(), 0, nullptr);
  return p;
}

void ComputeProgram::bind(VkCommandBuffer cmd) const noexcept {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.get());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout_.get(), 0, 1, &set_, 0,
                          nullptr);
}

void ComputeProgram::push(VkCommandBuffer cmd, std::span<const std::byte> bytes) const noexcept {
  vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0,
                     static_cast<std::uint32_t>(bytes.size()), bytes.data());
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStages, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStages, VkAccessFlags2 dstAccess) noexcept {
  VkMemoryBarrier2 barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  barrier.srcStageMask = srcStages;
  barrier.srcAccessMask = srcAccess;
  barrier.dstStageMask = dstStages;
  barrier.dstAccessMask = dstAccess;
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.memoryBarrierCount = 1;
  dependency.pMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

void computeBarrier(VkCommandBuffer cmd, bool toHost) noexcept {
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                toHost ? VK_PIPELINE_STAGE_2_HOST_BIT : VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                toHost
                    ? VK_ACCESS_2_HOST_READ_BIT
                    : (VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT));
}

void dispatchLinear(VkCommandBuffer cmd, std::uint64_t invocations, std::uint32_t localSize,
                    std::uint32_t groupsPerRow) noexcept {
  const std::uint64_t groups = (invocations + localSize - 1) / localSize;
  if (groups == 0) return;
  const std::uint64_t columns = std::min<std::uint64_t>(groups, std::max(groupsPerRow, 1U));
  const std::uint64_t rows = (groups + columns - 1) / columns;
  vkCmdDispatch(cmd, static_cast<std::uint32_t>(columns), static_cast<std::uint32_t>(rows), 1);
}

void transferToComputeBarrier(VkCommandBuffer cmd) noexcept {
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
}

}  // namespace pbdam::gpu
