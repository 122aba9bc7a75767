// PassDrawer (internal to pbdam_gpu): one pass of a terrain frame in a frame slot, from the
// reservation of its cache entries to its submission (TerrainRenderer.cpp's file comment): a
// CacheLease reserves the pass's entries (hits pinned, misses given slots), the DecodeScheduler
// decodes the misses into the slot's staging buffer, the per-draw records are written, then the
// uploads and the draws are recorded and submitted — into the slot's offscreen target, or (a
// host's pass, HostFrames.cpp) the uploads submitted and the draws recorded into the host's
// command buffer. Thread-safety: one per frame, on the renderer's thread.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "CacheLease.h"
#include "DrawRecorder.h"
#include "GpuCacheState.h"
#include "TerrainRendererImpl.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/DecodeScheduler.h"

namespace pbdam::gpu {

/// One pass of a frame: the cut's range [begin, end) and how it sits in the frame.
struct PassInput {
  const runtime::Cut& cut;
  const std::vector<formats::NodeRecord>& nodes;
  std::size_t begin = 0;
  std::size_t end = 0;
  const runtime::Camera& camera;
  std::span<const std::byte> push;  ///< the PatchPush bytes
  PassPlacement placement;
  /// The last pass of a frame that keeps radiance also copies it out for the host.
  bool readRadiance = false;
};

/// What a reserved pass uploads and draws.
struct PassWork {
  std::vector<streaming::DecodeJob> misses;
  std::vector<std::uint32_t> missSlots;  ///< pool slot of each miss
  std::vector<DrawItem> draws;           ///< the pass's drawable patches in cut order
};

/// Passes: the longest prefixes of the cut whose slot bytes fit the budget; returns each
/// pass's end (one past its last patch).
std::vector<std::size_t> planPasses(const GpuCache::State& c, const runtime::Cut& cut,
                                    const std::vector<formats::NodeRecord>& nodes);

/// A pass's work in a slot, from reservation to submission.
class PassDrawer final {
 public:
  PassDrawer(TerrainRenderer::Impl& m, FrameSlot& slot, const PassInput& in, FrameStats& stats)
      : m_(m), slot_(slot), in_(in), stats_(stats) {}

  /// Draws the pass into the slot's offscreen target; a frame's last pass is submitted without
  /// waiting.
  formats::Result<void> draw(bool readback, const PresentTarget* present);

  /// The one pass of a frame drawn into a host's pass: the uploads submitted (waited for with a
  /// shared cache, whose other renderers may use the entries once they are committed), the
  /// pins handed to the slot, and the draws recorded into `hostCmd` with `pipeline` (made for
  /// the host's pass) inside the rendering the host has begun.
  formats::Result<void> drawIntoHost(VkCommandBuffer hostCmd, VkPipeline pipeline);

 private:
  formats::Result<void> reserve(CacheLease& lease,
                                const std::vector<streaming::DecodeJob>& entries);
  formats::Result<void> stage();
  formats::Result<void> recordUploads();
  formats::Result<void> record(bool readback, const PresentTarget* present);
  formats::Result<void> submit(CacheLease& lease, const PresentTarget* present);
  /// The pass's misses and the bytes they uploaded, into the frame's stats.
  void countUploads();

  TerrainRenderer::Impl& m_;
  FrameSlot& slot_;
  const PassInput& in_;
  FrameStats& stats_;
  PassWork work_;
};

}  // namespace pbdam::gpu
