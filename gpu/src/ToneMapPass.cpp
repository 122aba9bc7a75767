// The tone map's pipeline (ToneMapPass.h).
#include "ToneMapPass.h"

#include <array>
#include <cstdint>

#include "GraphicsPipeline.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

// glslc -mfmt=c writes a braced initializer list, braces included.
const uint32_t kToneMapVert[] =
#include "tonemap.vert.inc"
    ;
const uint32_t kToneMapFrag[] =
#include "tonemap.frag.inc"
    ;

Result<UniquePipeline> createToneMapPipeline(VkDevice device, VkPipelineLayout layout,
                                             VkFormat displayFormat) {
  GraphicsPipelineDesc desc;
  desc.vertexSpirv = kToneMapVert;
  desc.vertexName = "tonemap.vert";
  desc.fragmentSpirv = kToneMapFrag;
  desc.fragmentName = "tonemap.frag";
  desc.pass.colorFormat = displayFormat;
  desc.pass.depthFormat = VK_FORMAT_UNDEFINED;  // no depth attachment
  desc.what = "tone map";
  return createGraphicsPipeline(device, layout, desc);
}

}  // namespace

Result<ToneMapPass> ToneMapPass::create(const VulkanContext& context, VkFormat displayFormat) {
  VkDevice device = context.device();
  ToneMapPass pass;
  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
  VkDescriptorSetLayoutCreateInfo setInfo{};
  setInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  setInfo.bindingCount = 1;
  setInfo.pBindings = &binding;
  VkDescriptorSetLayout rawSet = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorSetLayout(device, &setInfo, nullptr, &rawSet);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorSetLayout (tone map)");
  }
  pass.setLayout_ = UniqueDescriptorSetLayout(device, rawSet);

  VkPushConstantRange range{};
  range.stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
  range.size = sizeof(float);
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &rawSet;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreatePipelineLayout (tone map)");
  }
  pass.layout_ = UniquePipelineLayout(device, rawLayout);

  VkSamplerCreateInfo samplerInfo{};
  samplerInfo.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  samplerInfo.magFilter = VK_FILTER_NEAREST;
  samplerInfo.minFilter = VK_FILTER_NEAREST;
  samplerInfo.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  samplerInfo.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  samplerInfo.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  samplerInfo.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler rawSampler = VK_NULL_HANDLE;
  if (VkResult r = vkCreateSampler(device, &samplerInfo, nullptr, &rawSampler); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateSampler (tone map)");
  }
  pass.sampler_ = UniqueSampler(device, rawSampler);

  auto pipeline = createToneMapPipeline(device, rawLayout, displayFormat);
  if (!pipeline) return std::move(pipeline).error();
  pass.pipeline_ = std::move(*pipeline);
  return pass;
}

}  // namespace pbdam::gpu
