// TrianglePipeline: the smallest graphics pipeline — one flat-coloured triangle whose vertices
// come from push constants in framebuffer pixels — used to test the device, dynamic rendering,
// reversed-Z depth and readback end to end (shaders/triangle.vert, shaders/triangle.frag).
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <vulkan/vulkan.h>

#include <array>

namespace pbdam::gpu {

class VulkanContext;

/// One triangle to draw.
struct TriangleDraw final {
  /// Per vertex: x and y in framebuffer pixels (origin at the top-left corner of the top-left
  /// pixel, y down; pixel centres at +0.5), and depth in 0..1 (reversed-Z: 1 is near).
  std::array<std::array<float, 3>, 3> verticesPixels{};
  /// Linear RGBA in 0..1, written as-is to the colour attachment.
  std::array<float, 4> colorRgba{1.0f, 1.0f, 1.0f, 1.0f};
};

/// A graphics pipeline for dynamic rendering into OffscreenTarget's formats (RGBA8 colour,
/// D32_SFLOAT depth) with reversed-Z depth testing (GREATER_OR_EQUAL, writes on), no culling,
/// dynamic viewport and scissor. Move-only; destroy before the VulkanContext.
/// Thread-safety: none of its own; record() may be called from several threads into
/// different command buffers (it only reads the pipeline handles).
class TrianglePipeline final {
 public:
  /// Builds the pipeline for `colorFormat`/`depthFormat`. Errors: DeviceError.
  static formats::Result<TrianglePipeline> create(const VulkanContext& context,
                                                  VkFormat colorFormat, VkFormat depthFormat);

  /// Records binding the pipeline, its push constants and a 3-vertex draw. Must be called
  /// inside dynamic rendering on a target of `viewportPixels` size, with viewport and scissor
  /// set (OffscreenTarget::recordBeginRendering does that).
  void record(VkCommandBuffer cmd, const TriangleDraw& draw, VkExtent2D viewportPixels) const;

  /// The graphics pipeline; ownership stays here.
  VkPipeline pipeline() const noexcept { return pipeline_.get(); }
  /// Its layout (the push constants record() sets); ownership stays here.
  VkPipelineLayout layout() const noexcept { return layout_.get(); }

 private:
  UniquePipelineLayout layout_;
  UniquePipeline pipeline_;
};

}  // namespace pbdam::gpu
