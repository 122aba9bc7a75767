// DeviceCaps: which optional features and limits the chosen Vulkan device has, recorded when
// the VulkanContext enables them, so later code (f64 shaders, BC textures, MDI) can branch.
#pragma once

#include <cstdint>

namespace pbdam::gpu {

/// Optional features enabled on the device (each true only if present and enabled) and the
/// limits pbdam's renderer sizes itself by. Required features (dynamic rendering,
/// synchronization2, timeline semaphores) are always on and not listed. A plain value.
struct DeviceCaps final {
  bool shaderFloat64 = false;              ///< doubles in shaders
  bool storageBuffer16BitAccess = false;   ///< 16-bit values in storage buffers
  bool textureCompressionBC = false;       ///< BC1 texture tiles sampled as they are stored
  bool multiDrawIndirect = false;          ///< many draws from one indirect buffer
  bool drawIndirectFirstInstance = false;  ///< a first instance in indirect draws
  /// vkCmdDrawIndexedIndirectCount and gl_DrawID: draw lists made on the device.
  bool drawIndirectCount = false;
  bool shaderDrawParameters = false;  ///< gl_DrawID and gl_BaseInstance in shaders
  bool geometryShader = false;        ///< geometry shaders
  bool fillModeNonSolid = false;      ///< wireframe debug views
  /// Storage-buffer writes from vertex shaders (the GPU tests' vertex-position capture).
  bool vertexPipelineStoresAndAtomics = false;

  uint32_t maxPushConstantsBytes = 0;  ///< 128 on lavapipe (docs/architecture.md "Measured facts")
  uint32_t maxImageDimension2DPixels = 0;   ///< the largest side of a 2D image
  uint32_t maxDrawIndexedIndexValue = 0;    ///< the largest index an indexed draw may use
  float timestampPeriodNanoseconds = 0.0f;  ///< nanoseconds per timestamp-query tick
  uint64_t nonCoherentAtomSizeBytes = 0;    ///< alignment of flushes of non-coherent memory
};

}  // namespace pbdam::gpu
