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
  auto setLayout = createSetLayout(device, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                   VK_SHADER_STAGE_FRAGMENT_BIT, "tone map");
  if (!setLayout) return std::move(setLayout).error();
  pass.setLayout_ = std::move(*setLayout);
  VkDescriptorSetLayout rawSet = pass.setLayout_.get();

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

  auto sampler = createSampler(device, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                               VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK, "tone map");
  if (!sampler) return std::move(sampler).error();
  pass.sampler_ = std::move(*sampler);

  auto pipeline = createToneMapPipeline(device, rawLayout, displayFormat);
  if (!pipeline) return std::move(pipeline).error();
  pass.pipeline_ = std::move(*pipeline);
  return pass;
}

}  // namespace pbdam::gpu
