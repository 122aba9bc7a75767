// SurfaceOverlayBinding (internal to pbdam_gpu): descriptor set 3 of the patch pipeline, a
// raster draped over the terrain (TerrainRenderer.h SurfaceOverlay; a viewshed): its image,
// sampled nearest and transparent outside, and a uniform block placing it relative to the camera
// each frame (patch.frag). Without an overlay the block says "off" and a 1×1 transparent image
// is bound, so frames are what they were without one. Thread-safety: none (the render thread).
#pragma once

#include <memory>

#include "PatchPipeline.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::gpu {

/// Mirrors `Overlay` in patch.frag (std140, 64 bytes).
struct OverlayBlock final {
  float origin[4];  ///< xyz: the overlay's centre on the reference surface, camera-relative; w: 1
                    ///< drawn
  float east[4];    ///< xyz: unit east there; w: the surface's radius of curvature (metres)
  float north[4];   ///< xyz: unit north; w: metres per cell
  float up[4];      ///< xyz: unit up; w: cells a side
};
static_assert(sizeof(OverlayBlock) == 64);

class SurfaceOverlayBinding final {
 public:
  /// The set, the uniform buffer and the empty image. DeviceError for Vulkan failures.
  static formats::Result<SurfaceOverlayBinding> create(VulkanContext& context,
                                                       const PatchPipeline& pipeline);

  /// Binds `overlay` (null: none) for a frame seen from `cameraEcef`. A new overlay is uploaded
  /// (one submission); it must not be called while a submission that uses the set is pending.
  /// InvalidArgument for an overlay whose image is not square or does not match its size.
  formats::Result<void> prepare(const std::shared_ptr<const SurfaceOverlay>& overlay,
                                const runtime::Planet& planet, const glm::dvec3& cameraEcef);

  VkDescriptorSet set() const noexcept { return set_; }

 private:
  formats::Result<void> upload(const RgbaImage& image);
  void writeImage();

  VulkanContext* context_ = nullptr;
  VkSampler sampler_ = VK_NULL_HANDLE;
  UniqueDescriptorPool pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  GpuBuffer block_;
  GpuImage image_;
  std::shared_ptr<const SurfaceOverlay> bound_;
};

}  // namespace pbdam::gpu
