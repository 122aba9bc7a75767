// AtmosphereBinding (internal to pbdam_gpu): descriptor set 4 of the patch pipeline, the
// atmosphere's precomputed tables (runtime/Atmosphere.h) as textures — transmittance and ground
// irradiance 2D, the two 4D scattering tables as 2D arrays of one layer per radius — and a
// uniform block of the constants the lookups need (atmosphere.glsl) — and the frame's sky-view
// table (binding 5), which recordSkyView() computes before a frame with the atmosphere
// (sky_view.comp). Without an atmosphere 1×1 tables are bound and the block says "none", so
// frames are what they were. Uploaded once; the set never changes after. Thread-safety: none
// (the render thread).
#pragma once

#include <memory>

#include "PatchPipeline.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/runtime/Atmosphere.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::gpu {

class VulkanContext;

/// Mirrors `Atmosphere` in atmosphere.glsl (std140, 64 bytes).
struct AtmosphereBlock final {
  float solarIrradiance[4];  ///< xyz: at the top of the atmosphere; w: the sun's angular radius
  float miePhaseG[4];        ///< xyz: Mie asymmetry; w: cos of the largest sun zenith angle
  float radii[4];            ///< x bottom, y top (km); z ν size, w μ_s size
  float sizes[4];            ///< x μ size, y r size; z 1 with an atmosphere; w the z-axis stretch
};
static_assert(sizeof(AtmosphereBlock) == 64);

class AtmosphereBinding final {
 public:
  /// Uploads `tables` (null: none) for `planet`, whose reference surface the atmosphere's bottom
  /// sphere stands for (an ellipsoid is stretched along its axis onto the sphere of its
  /// equatorial radius). DeviceError for Vulkan failures.
  static formats::Result<AtmosphereBinding> create(
      VulkanContext& context, const PatchPipeline& pipeline,
      const std::shared_ptr<const runtime::AtmosphereTables>& tables,
      const runtime::Planet& planet);

  VkDescriptorSet set() const noexcept { return set_; }
  /// Records the sky-view table's computation for the frame of `push` (its camera and sun),
  /// ordered after the draws of earlier frames that read it and before this frame's. Outside a
  /// render pass; nothing when no tables are bound or the frame has no atmosphere.
  void recordSkyView(VkCommandBuffer cmd, const PatchPush& push) const;
  /// Whether real tables are bound.
  bool present() const noexcept { return tables_ != nullptr; }
  /// The planet-centred position (km) the shaders take for an ECEF position: stretched along the
  /// polar axis so that the reference surface is the atmosphere's bottom sphere.
  glm::dvec3 toAtmosphere(const glm::dvec3& ecefMeters) const noexcept;

 private:
  formats::Result<void> createSkyView(const PatchPipeline& pipeline);

  VulkanContext* context_ = nullptr;
  UniqueDescriptorPool pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  GpuBuffer block_;
  GpuImage transmittance_;
  GpuImage scattering_;
  GpuImage singleMie_;
  GpuImage irradiance_;
  // The sky-view table (GENERAL layout throughout) and its compute pass: pipeline, layout, the
  // storage image's set layout and set.
  GpuImage skyView_;
  UniqueDescriptorSetLayout skyViewSetLayout_;
  UniquePipelineLayout skyViewLayout_;
  UniquePipeline skyViewPipeline_;
  VkDescriptorSet skyViewSet_ = VK_NULL_HANDLE;
  std::shared_ptr<const runtime::AtmosphereTables> tables_;
  double zStretch_ = 1.0;
};

}  // namespace pbdam::gpu
