// TrianglePipeline: a flat-coloured push-constant triangle for end-to-end GPU tests.
#include "pbdam/gpu/TrianglePipeline.h"

#include "pbdam/gpu/ShaderModule.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

#include <cstdint>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

// glslc -mfmt=c writes a braced initializer list, braces included.
const uint32_t kTriangleVert[] =
#include "triangle.vert.inc"
    ;
const uint32_t kTriangleFrag[] =
#include "triangle.frag.inc"
    ;

/// Mirrors `TrianglePush` in triangle.vert/.frag (std430 push-constant layout: 72 bytes).
struct TrianglePush {
  float pixelPositions[3][4];
  float colorRgba[4];
  float viewportSizePixels[2];
};
static_assert(sizeof(TrianglePush) == 72);

}  // namespace

Result<TrianglePipeline> TrianglePipeline::create(const VulkanContext& context,
                                                  VkFormat colorFormat, VkFormat depthFormat) {
  VkDevice device = context.device();
  Result<UniqueShaderModule> vert = createShaderModule(device, kTriangleVert, "triangle.vert");
  if (!vert) return std::move(vert).error();
  Result<UniqueShaderModule> frag = createShaderModule(device, kTriangleFrag, "triangle.frag");
  if (!frag) return std::move(frag).error();

  TrianglePipeline result;
  VkPushConstantRange range{};
  range.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  range.offset = 0;
  range.size = sizeof(TrianglePush);
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreatePipelineLayout (triangle)");
  }
  result.layout_ = UniquePipelineLayout(device, rawLayout);

  VkPipelineShaderStageCreateInfo stages[2]{};
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
  VkPipelineDepthStencilStateCreateInfo depth{};
  depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depth.depthTestEnable = VK_TRUE;
  depth.depthWriteEnable = VK_TRUE;
  depth.depthCompareOp = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z
  VkPipelineColorBlendAttachmentState blendAttachment{};
  blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                   VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo blend{};
  blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  const VkDynamicState dynamicStates[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dynamicStates;

  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &colorFormat;
  rendering.depthAttachmentFormat = depthFormat;

  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  info.pNext = &rendering;
  info.stageCount = 2;
  info.pStages = stages;
  info.pVertexInputState = &vertexInput;
  info.pInputAssemblyState = &inputAssembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = result.layout_.get();
  VkPipeline rawPipeline = VK_NULL_HANDLE;
  if (VkResult r =
          vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &rawPipeline);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateGraphicsPipelines (triangle)");
  }
  result.pipeline_ = UniquePipeline(device, rawPipeline);
  return result;
}

void TrianglePipeline::record(VkCommandBuffer cmd, const TriangleDraw& draw,
                              VkExtent2D viewportPixels) const {
  TrianglePush push{};
  for (std::size_t v = 0; v < 3; ++v) {
    push.pixelPositions[v][0] = draw.verticesPixels[v][0];
    push.pixelPositions[v][1] = draw.verticesPixels[v][1];
    push.pixelPositions[v][2] = draw.verticesPixels[v][2];
    push.pixelPositions[v][3] = 1.0f;
  }
  for (std::size_t c = 0; c < 4; ++c) push.colorRgba[c] = draw.colorRgba[c];
  push.viewportSizePixels[0] = static_cast<float>(viewportPixels.width);
  push.viewportSizePixels[1] = static_cast<float>(viewportPixels.height);

  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.get());
  vkCmdPushConstants(cmd, layout_.get(), VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                     0, sizeof(TrianglePush), &push);
  vkCmdDraw(cmd, 3, 1, 0, 0);
}

}  // namespace pbdam::gpu
