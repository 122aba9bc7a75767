// The renderer's graphics pipelines from their differences (GraphicsPipeline.h).
#include "GraphicsPipeline.h"

#include <array>
#include <string>

#include "pbdam/gpu/ShaderModule.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

namespace pbdam::gpu {

Result<UniquePipeline> createGraphicsPipeline(VkDevice device, VkPipelineLayout layout,
                                              const GraphicsPipelineDesc& desc) {
  Result<UniqueShaderModule> vert = createShaderModule(device, desc.vertexSpirv, desc.vertexName);
  if (!vert) return std::move(vert).error();
  Result<UniqueShaderModule> frag =
      createShaderModule(device, desc.fragmentSpirv, desc.fragmentName);
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
  stages[1].pSpecializationInfo = desc.fragmentSpecialization;

  VkPipelineVertexInputStateCreateInfo noVertices{};
  noVertices.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
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
  raster.cullMode = desc.cullMode;
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{};
  multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  multisample.rasterizationSamples = desc.pass.samples;
  VkPipelineDepthStencilStateCreateInfo depth{};
  depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depth.depthTestEnable = desc.depthTest ? VK_TRUE : VK_FALSE;
  depth.depthWriteEnable = desc.depthWrite ? VK_TRUE : VK_FALSE;
  depth.depthCompareOp = desc.depthCompare;
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
  dynamic.dynamicStateCount = static_cast<std::uint32_t>(dynamicStates.size());
  dynamic.pDynamicStates = dynamicStates.data();
  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &desc.pass.colorFormat;
  rendering.depthAttachmentFormat = desc.pass.depthFormat;

  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  // A render pass's subpass, or dynamic rendering to the formats.
  info.pNext = desc.pass.renderPass == VK_NULL_HANDLE ? &rendering : nullptr;
  info.renderPass = desc.pass.renderPass;
  info.subpass = desc.pass.subpass;
  info.stageCount = static_cast<std::uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = desc.vertexInput != nullptr ? desc.vertexInput : &noVertices;
  info.pInputAssemblyState = &inputAssembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  VkPipeline raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &raw);
      r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkCreateGraphicsPipelines (") + desc.what + ")");
  }
  return UniquePipeline(device, raw);
}

Result<UniqueDescriptorSetLayout> createSetLayout(VkDevice device, VkDescriptorType type,
                                                  VkShaderStageFlags stages, const char* what) {
  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 0;
  binding.descriptorType = type;
  binding.descriptorCount = 1;
  binding.stageFlags = stages;
  VkDescriptorSetLayoutCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  info.bindingCount = 1;
  info.pBindings = &binding;
  VkDescriptorSetLayout raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorSetLayout(device, &info, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkCreateDescriptorSetLayout (") + what + ")");
  }
  return UniqueDescriptorSetLayout(device, raw);
}

/// A sampler without mipmaps: `filter` both ways, `address` on every axis (`border` outside the
/// image when that clamps to the border).
Result<UniqueSampler> createSampler(VkDevice device, VkFilter filter, VkSamplerAddressMode address,
                                    VkBorderColor border, const char* what) {
  VkSamplerCreateInfo samplerInfo{};
  samplerInfo.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  samplerInfo.magFilter = filter;
  samplerInfo.minFilter = filter;
  samplerInfo.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  samplerInfo.addressModeU = address;
  samplerInfo.addressModeV = address;
  samplerInfo.addressModeW = address;
  samplerInfo.borderColor = border;
  samplerInfo.maxLod = 0.0f;
  VkSampler rawSampler = VK_NULL_HANDLE;
  if (VkResult r = vkCreateSampler(device, &samplerInfo, nullptr, &rawSampler); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkCreateSampler (") + what + ")");
  }
  return UniqueSampler(device, rawSampler);
}

Result<UniquePipeline> createComputePipeline(VkDevice device, VkPipelineLayout layout,
                                             std::span<const std::uint32_t> spirv,
                                             const char* name) {
  auto module = createShaderModule(device, spirv, name);
  if (!module) return std::move(module).error();
  VkComputePipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
  info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module->get();
  info.stage.pName = "main";
  info.layout = layout;
  VkPipeline raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &raw);
      r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkCreateComputePipelines (") + name + ")");
  }
  return UniquePipeline(device, raw);
}

}  // namespace pbdam::gpu
