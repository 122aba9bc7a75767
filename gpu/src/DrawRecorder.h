// DrawRecorder (internal to pbdam_gpu): records one pass of a terrain frame ([P-BDAM 2003] §4.2):
// the render pass into the offscreen target, the patch pipeline, and one indexed draw per patch
// in cut order, binding a pool chunk's vertex/index buffers and a tile page's descriptor set only
// when they change. Thread-safety: const; the command buffer is the caller's.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <span>

#include "GpuPools.h"
#include "PatchPipeline.h"
#include "pbdam/gpu/OffscreenTarget.h"

namespace pbdam::gpu {

/// One patch to draw: its pool slots and per-draw record.
struct DrawItem final {
  std::uint32_t patchSlot = 0;
  std::uint32_t tileSlot = 0;
  std::uint32_t morphTileSlot = 0;  ///< the coarser tile it blends in (tileSlot when none)
  std::uint32_t recordIndex = 0;    ///< index of its PatchDrawRecord in the records buffer
  std::uint32_t indexCount = 0;     ///< 3 × triangles
};

/// How the pass sits in its frame.
struct PassPlacement final {
  bool first = true;  ///< clears the attachments (else resumes the previous pass's)
  bool last = true;   ///< the frame's last pass: its attachments are stored for readback
  std::array<float, 4> clearRgba{0.0f, 0.0f, 0.0f, 1.0f};
  /// > 0: the frame keeps radiance (the target's radiance image, the radiance pipelines) and
  /// its last pass is followed by the tone map with this exposure; 0: display colour.
  float toneMapExposure = 0.0f;
};

/// The sky (PatchPipeline::skyPipeline, or RadiancePipelines::sky): the band of view directions
/// that can see air (sky.vert), inside rendering begun by the caller with the patch layout's
/// sets and push constants bound (the atmosphere's set 4 and a PatchPush whose camera.w is the
/// exposure), before the patches, which cover it.
void recordSky(VkCommandBuffer cmd, VkPipeline sky);

class DrawRecorder final {
 public:
  /// Everything referenced must outlive the recorder and the command buffers it records.
  DrawRecorder(const PatchPipeline& pipeline, const PatchPool& patches, const TilePool& tiles,
               VkDescriptorSet recordsSet, VkDescriptorSet overlaySet,
               VkDescriptorSet atmosphereSet, const RadiancePipelines* radiance = nullptr) noexcept
      : pipeline_(&pipeline),
        radiance_(radiance),
        patches_(&patches),
        tiles_(&tiles),
        recordsSet_(recordsSet),
        overlaySet_(overlaySet),
        atmosphereSet_(atmosphereSet) {}

  /// Records begin (or resume) rendering into `target`, the draws of `items` in order with
  /// `push` (PatchPush bytes), and the end of rendering.
  void record(VkCommandBuffer cmd, const OffscreenTarget& target, const PassPlacement& placement,
              std::span<const std::byte> push, std::span<const DrawItem> items) const;
  /// Records only the draws, with `pipeline` (the patch pipeline or one made for a host's pass
  /// from its layout), into rendering the caller has begun: viewport and scissor `width` x
  /// `height` at the origin, depth range 0..1.
  void recordDraws(VkCommandBuffer cmd, VkPipeline pipeline, std::uint32_t width,
                   std::uint32_t height, std::span<const std::byte> push,
                   std::span<const DrawItem> items) const;

 private:
  /// Binds `boundPipeline`, the records and overlay sets and the push constants, then draws
  /// `items` binding chunks and tile pages as they change.
  void recordBindingsAndDraws(VkCommandBuffer cmd, VkPipeline boundPipeline,
                              std::span<const std::byte> push,
                              std::span<const DrawItem> items) const;

  const PatchPipeline* pipeline_;
  const RadiancePipelines* radiance_;  ///< for frames that keep radiance; may be null
  const PatchPool* patches_;
  const TilePool* tiles_;
  VkDescriptorSet recordsSet_;
  VkDescriptorSet overlaySet_;
  VkDescriptorSet atmosphereSet_;
};

}  // namespace pbdam::gpu
