// Drawing the terrain into a render pass the host owns (docs/embedding.md "Drawing into your own
// pass"): the host's attachment formats and depth convention, which the terrain's pipeline is
// made for, and what the host hands back so that the terrain knows when the frame is done. The
// host draws its own objects into the same depth buffer with the camera's double-precision
// matrices (hostProjection), relative to the camera's position. Thread-safety: plain values and
// pure functions.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <glm/mat4x4.hpp>

#include "pbdam/runtime/Camera.h"

namespace pbdam::gpu {

/// What depth the host's attachment holds and how its pipelines test it.
enum class DepthConvention {
  /// Reversed-Z, the terrain's own: depth 1 at the near plane, 0 at infinity, cleared to 0,
  /// nearer passes with VK_COMPARE_OP_GREATER_OR_EQUAL. Keeps float depth precise from metres to
  /// a planet's radius; the frame is byte-identical to the terrain's offscreen frame.
  ReversedZ,
  /// Conventional: depth 0 at the near plane, → 1 at infinity, cleared to 1, nearer passes with
  /// VK_COMPARE_OP_LESS_OR_EQUAL. For hosts whose pipelines assume it; distant depth is coarse.
  ZeroNearOneFar,
};

/// The host's pass the terrain is drawn into: its attachments' formats and sample count, and
/// either a render pass and subpass (Vulkan 1.0 style) or, with renderPass VK_NULL_HANDLE,
/// dynamic rendering (vkCmdBeginRendering) with one colour attachment and a depth attachment.
/// The terrain makes one pipeline per distinct HostPass and keeps it.
struct HostPass final {
  VkFormat colorFormat = VK_FORMAT_R8G8B8A8_UNORM;  ///< the colour attachment's format
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;      ///< the depth attachment's format
  VkRenderPass renderPass = VK_NULL_HANDLE;         ///< VK_NULL_HANDLE: dynamic rendering
  std::uint32_t subpass = 0;  ///< the subpass of renderPass the terrain draws in
  VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;  ///< of both attachments
  DepthConvention depth = DepthConvention::ReversedZ;     ///< what the depth attachment holds

  /// Passes that take the same pipeline.
  bool operator==(const HostPass&) const = default;
};

/// The projection for `depth`: the camera's infinite reversed-Z projection (Camera::
/// projectionDouble) as it is, or remapped to depth 0 at the near plane and 1 at infinity.
/// Clip space = hostProjection · viewRotationDouble · (position − camera.position()).
glm::dmat4 hostProjection(const runtime::Camera& camera, DepthConvention depth) noexcept;

/// The depth test that passes the nearer fragment under `depth`.
VkCompareOp nearerPasses(DepthConvention depth) noexcept;

/// The depth a host clears its attachment to under `depth` (the far end).
float farDepth(DepthConvention depth) noexcept;

}  // namespace pbdam::gpu
