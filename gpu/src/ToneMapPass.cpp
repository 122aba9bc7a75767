// The tone map's pipeline (ToneMapPass.h).
#include "ToneMapPass.h"

#include <array>
#include <cstdint>

#include "pbdam/gpu/ShaderModule.h"
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
  Result<UniqueShaderModule> vert = createShaderModule(device, kToneMapVert, "tonemap.vert");
  if (!vert) return std::move(vert).error();
  Result<UniqueShaderModule> frag = createShaderModule(device, kToneMapFrag, "tonemap.frag");
  if (!frag) return std::move(frag).error();
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert->get();
  stages[0].pName = "main";
  stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag->get();
  stages[1].pName = "main";
  VkPipelineVertexInputStateCreateInfo vertexInput{};
  vertexInput.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  VkPipelineInputAssemblyStateCreateInfo inputAssembly{};
  inputAssembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  inputAssembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{};
  viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{};
  raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{};
  multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineColorBlendAttachmentState blendAttachment{};
  blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                   VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo blend{};
  blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  const std::array<VkDynamicState, 2> dynamicStates = {VK_DYNAMIC_STATE_VIEWPORT,
                                                       VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = static_cast<uint32_t>(dynamicStates.size());
  dynamic.pDynamicStates = dynamicStates.data();
  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &displayFormat;
  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  info.pNext = &rendering;
  info.stageCount = static_cast<uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &vertexInput;
  info.pInputAssemblyState = &inputAssembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  VkPipeline raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &raw);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateGraphicsPipelines (tone map)");
  }
  return UniquePipeline(device, raw);
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
