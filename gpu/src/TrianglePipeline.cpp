// TrianglePipeline: a flat-coloured push-constant triangle for end-to-end GPU tests.
#include "pbdam/gpu/TrianglePipeline.h"

#include "GraphicsPipeline.h"
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

  GraphicsPipelineDesc desc;
  desc.vertexSpirv = kTriangleVert;
  desc.vertexName = "triangle.vert";
  desc.fragmentSpirv = kTriangleFrag;
  desc.fragmentName = "triangle.frag";
  desc.depthTest = true;
  desc.depthWrite = true;
  desc.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z
  desc.pass.colorFormat = colorFormat;
  desc.pass.depthFormat = depthFormat;
  desc.what = "triangle";
  auto pipeline = createGraphicsPipeline(device, rawLayout, desc);
  if (!pipeline) return std::move(pipeline).error();
  result.pipeline_ = std::move(*pipeline);
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
