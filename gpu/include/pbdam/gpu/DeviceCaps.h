// DeviceCaps: which optional features and limits the chosen Vulkan device has, recorded when
// the VulkanContext enables them, so later code (f64 shaders, BC textures, MDI) can branch.
#pragma once

#include <cstdint>

namespace pbdam::gpu {

/// Optional features enabled on the device (each true only if present and enabled) and the
/// limits pbdam's renderer sizes itself by. Required features (dynamic rendering,
/// synchronization2, timeline semaphores) are always on and not listed. A plain value.
struct DeviceCaps final {
  bool shaderFloat64 = false;
  bool storageBuffer16BitAccess = false;
  bool textureCompressionBC = false;
  bool multiDrawIndirect = false;
  bool drawIndirectFirstInstance = false;
  /// vkCmdDrawIndexedIndirectCount and gl_DrawID: draw lists made on the device.
  bool drawIndirectCount = false;
  bool shaderDrawParameters = false;
  bool geometryShader = false;
  bool fillModeNonSolid = false;  ///< wireframe debug views
  /// Storage-buffer writes from vertex shaders (the GPU tests' vertex-position capture).
  bool vertexPipelineStoresAndAtomics = false;

  uint32_t maxPushConstantsBytes = 0;  ///< 128 on lavapipe (docs/architecture.md "Measured facts")
  uint32_t maxImageDimension2DPixels = 0;
  uint32_t maxDrawIndexedIndexValue = 0;
  float timestampPeriodNanoseconds = 0.0f;
  uint64_t nonCoherentAtomSizeBytes = 0;
};

}  // namespace pbdam::gpu
