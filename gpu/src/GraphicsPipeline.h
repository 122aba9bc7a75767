// GraphicsPipeline (internal to pbdam_gpu): one function for the graphics pipelines the renderer
// makes (the patches', the sky's, the tone map's, the test triangle's) — two shader stages,
// triangle lists, dynamic viewport and scissor, one colour attachment written whole, no blending —
// from what differs between them: the shaders, the fragment stage's specialisation, the vertex
// input, culling, the depth test and the pass (formats, samples; a render pass or dynamic
// rendering). Thread-safety: a pure function of its arguments.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/UniqueHandle.h"

namespace pbdam::gpu {

/// What a graphics pipeline is made of (see the file comment for what every one shares).
struct GraphicsPipelineDesc final {
  std::span<const std::uint32_t> vertexSpirv;
  const char* vertexName = "";
  std::span<const std::uint32_t> fragmentSpirv;
  const char* fragmentName = "";
  /// The fragment stage's specialisation constants; null: none.
  const VkSpecializationInfo* fragmentSpecialization = nullptr;
  /// Vertex buffers and attributes; null: none (the shader makes its vertices).
  const VkPipelineVertexInputStateCreateInfo* vertexInput = nullptr;
  VkCullModeFlags cullMode = VK_CULL_MODE_NONE;  ///< front faces are counter-clockwise
  bool depthTest = false;
  bool depthWrite = false;
  VkCompareOp depthCompare = VK_COMPARE_OP_ALWAYS;  ///< with depthTest
  /// Formats, samples, and a render pass and subpass or dynamic rendering (renderPass null).
  HostPass pass;
  const char* what = "";  ///< named in the error
};

/// Creates the pipeline with `layout`. DeviceError naming `desc.what` on failure.
formats::Result<UniquePipeline> createGraphicsPipeline(VkDevice device, VkPipelineLayout layout,
                                                       const GraphicsPipelineDesc& desc);

}  // namespace pbdam::gpu
