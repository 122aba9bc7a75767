// PatchPipeline (internal to pbdam_gpu): the graphics pipeline that draws P-BDAM patches
// (shaders/patch.vert, shaders/patch.frag), its descriptor-set layouts (set 0: the per-draw
// records, sets 1 and 2: texture-array pages, set 3: the surface overlay) and the samplers.
// Thread-safety: immutable after creation.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/streaming/DecodeScheduler.h"

namespace pbdam::gpu {

class VulkanContext;

/// Mirrors `PatchPush` in patch.vert/patch.frag (std430 push constants, 112 bytes). The frame
/// sets it once; recordIndex is pushed again before each draw.
struct PatchPush final {
  float viewProjection[16];   ///< column-major projection · viewRotation
  float sunAmbient[4];        ///< xyz: unit direction towards the sun (ECEF axes), w: ambient
  std::uint32_t recordIndex;  ///< the draw's PatchDrawRecord in the records buffer
  float sunDisc;              ///< sine of the sun's angular radius; 0: a light with no horizon
  float normalMaps;           ///< 1: simplified patches shaded by their normal maps under the sun
  float pad;                  ///< std430: the vec4 below starts at 96
  float camera[4];  ///< xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
};
static_assert(sizeof(PatchPush) == 112);
static_assert(offsetof(PatchPush, camera) == 96);
inline constexpr std::uint32_t kRecordIndexOffset = 80;
static_assert(offsetof(PatchPush, recordIndex) == kRecordIndexOffset);

// The vertex layout of the patch pools is PatchGpuVertex (streaming/DecodeScheduler.h): b1, b2 as
// R16G16_UINT, h and the morph target's h (metres) as R32G32_SFLOAT, then the offset o (metres) as
// R32G32B32_SFLOAT.

/// The patch, indirect and sky pipelines of PatchPipeline for a frame that keeps radiance (a
/// floating-point colour target, tone-mapped after its last pass: ToneMapPass.h): the same
/// shaders and layout with their fragment stages' kRadianceOutput set. `indirect` is empty where
/// PatchPipeline::indirectPipeline() is.
struct RadiancePipelines final {
  UniquePipeline patch;
  UniquePipeline indirect;
  UniquePipeline sky;
};

class PatchPipeline final {
 public:
  /// Creates the layouts, the sampler (linear, clamp to edge, no mipmaps) and the pipeline for
  /// dynamic rendering into `colorFormat` + `depthFormat`: triangle lists, back faces culled
  /// (patches are counter-clockwise seen from outside the planet), reversed-Z depth test
  /// GREATER_OR_EQUAL with writes, dynamic viewport and scissor.
  static formats::Result<PatchPipeline> create(const VulkanContext& context, VkFormat colorFormat,
                                               VkFormat depthFormat);

  /// The same shaders and layout (so the cache's descriptor sets bind to it) for a host's pass:
  /// its formats, render pass or dynamic rendering, samples and depth test (HostPass.h).
  formats::Result<UniquePipeline> createForHostPass(const VulkanContext& context,
                                                    const HostPass& pass) const;

  /// The pipelines for frames that keep radiance in `radianceFormat` + `depthFormat`.
  formats::Result<RadiancePipelines> createRadiancePipelines(const VulkanContext& context,
                                                             VkFormat radianceFormat,
                                                             VkFormat depthFormat) const;

  VkPipeline pipeline() const noexcept { return pipeline_.get(); }
  /// The same pipeline with patch_indirect.vert (the record index from gl_DrawID) for draw
  /// lists made on the device; VK_NULL_HANDLE where the device lacks draw parameters, indirect
  /// draw counts or multi-draw indirect.
  VkPipeline indirectPipeline() const noexcept { return indirectPipeline_.get(); }
  VkPipelineLayout layout() const noexcept { return layout_.get(); }
  VkDescriptorSetLayout recordsSetLayout() const noexcept { return recordsSetLayout_.get(); }
  VkDescriptorSetLayout tilesSetLayout() const noexcept { return tilesSetLayout_.get(); }
  VkSampler sampler() const noexcept { return sampler_.get(); }
  /// Set 3: the surface overlay (binding 0: its image, binding 1: its uniform block).
  VkDescriptorSetLayout overlaySetLayout() const noexcept { return overlaySetLayout_.get(); }
  /// Nearest, transparent black outside the image.
  VkSampler overlaySampler() const noexcept { return overlaySampler_.get(); }
  /// Set 4: the atmosphere (bindings 0–3: its tables, binding 4: its uniform block, binding 5:
  /// the frame's sky-view table).
  VkDescriptorSetLayout atmosphereSetLayout() const noexcept { return atmosphereSetLayout_.get(); }
  /// The sky behind the terrain (sky.vert, sky.frag) for this pipeline's attachments and layout.
  VkPipeline skyPipeline() const noexcept { return skyPipeline_.get(); }

 private:
  UniqueDescriptorSetLayout recordsSetLayout_;
  UniqueDescriptorSetLayout tilesSetLayout_;
  UniqueSampler sampler_;
  UniqueDescriptorSetLayout overlaySetLayout_;
  UniqueSampler overlaySampler_;
  UniqueDescriptorSetLayout atmosphereSetLayout_;
  UniquePipelineLayout layout_;
  UniquePipeline skyPipeline_;
  UniquePipeline pipeline_;
  UniquePipeline indirectPipeline_;
};

}  // namespace pbdam::gpu
