// GraphicsPipeline (internal to pbdam_gpu): one function for the graphics pipelines the renderer
// makes (the patches', the sky's, the tone map's, the test triangle's) — two shader stages,
// triangle lists, dynamic viewport and scissor, one colour attachment written whole, no blending —
// from what differs between them: the shaders, the fragment stage's specialisation, the vertex
// input, culling, the depth test and the pass (formats, samples; a render pass or dynamic
// rendering). Also the pieces every pipeline of the renderer is made of: one-binding set layouts,
// samplers, compute pipelines. Thread-safety: pure functions of their arguments.
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

/// The pieces the pipelines share; DeviceError naming `what` (or `name`) on failure.
/// A set layout of one descriptor of `type` at binding 0, read by `stages`.
formats::Result<UniqueDescriptorSetLayout> createSetLayout(VkDevice device, VkDescriptorType type,
                                                           VkShaderStageFlags stages,
                                                           const char* what);
/// A sampler without mipmaps: `filter` both ways, `address` on every axis (`border` outside the
/// image when that clamps to the border).
formats::Result<UniqueSampler> createSampler(VkDevice device, VkFilter filter,
                                             VkSamplerAddressMode address, VkBorderColor border,
                                             const char* what);
/// The compute pipeline of `spirv` with `layout`.
formats::Result<UniquePipeline> createComputePipeline(VkDevice device, VkPipelineLayout layout,
                                                      std::span<const std::uint32_t> spirv,
                                                      const char* name);

}  // namespace pbdam::gpu
