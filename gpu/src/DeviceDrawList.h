// DeviceDrawList (internal to pbdam_gpu): the cut's draw list made on the device from the
// selection passes' node states (shaders/draw_list.comp, [Yalçın 2011] §8) — indexed indirect draw
// commands, a draw count and the per-draw records, in refine()'s depth-first order — for
// vkCmdDrawIndexedIndirectCount, with no read-back of the cut. Each node's camera-independent
// draw inputs (runtime::PatchDrawTemplate, and where its patch and tiles are in the GPU cache)
// are uploaded once; so every patch the selection may draw must stay resident in one pool chunk
// and its tiles in one page (TerrainRenderer::renderSelected checks this). Thread-safety: one
// thread at a time; the context, dataset and selector must outlive it.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "ComputeProgram.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Refinement.h"

namespace pbdam::gpu {

class VulkanContext;

/// Where one node's draw comes from in the GPU cache (unset for a node without triangles).
struct ResidentDraw final {
  std::uint32_t indexCount = 0;  ///< 3 × triangles; 0: never drawn
  std::uint32_t firstIndex = 0;
  std::uint32_t vertexOffset = 0;
  std::uint32_t textureLayer = 0;  ///< its tile's layer in the page
  /// Its parent's tile when that is another tile (what the patch blends in while it morphs).
  std::optional<runtime::TileKey> parentTile;
  std::uint32_t parentTextureLayer = 0;
};

/// What the last recorded list held, read after its submission has completed.
struct DrawListTotals final {
  std::uint32_t draws = 0;
  std::uint64_t triangles = 0;
};

class DeviceDrawList final {
 public:
  /// `residency` has one entry per node of `selector.index()`. With `readableRecords` the
  /// records are kept in host-readable memory (tests compare them with the host's).
  /// `exaggeration`: the one the resident patches were decoded with (runtime::
  /// makePatchDrawTemplate).
  static formats::Result<DeviceDrawList> create(VulkanContext& context,
                                                const runtime::DatasetView& dataset,
                                                const GpuSelector& selector,
                                                std::span<const ResidentDraw> residency,
                                                bool readableRecords = false,
                                                double exaggeration = 1.0);

  /// Uploads the frame's camera and options and records the three passes into `cmd` after the
  /// selector's, then a barrier that makes the list visible to indirect draws and vertex
  /// shaders.
  formats::Result<void> record(VkCommandBuffer cmd, const runtime::Camera& camera,
                               const runtime::RefinementOptions& refinement);

  const GpuBuffer& records() const noexcept { return records_; }
  const GpuBuffer& commands() const noexcept { return commands_; }
  const GpuBuffer& count() const noexcept { return count_; }
  /// The most draws a list can hold (the nodes with triangles).
  std::uint32_t capacity() const noexcept { return capacity_; }
  /// The last list's draws and triangles (after its submission has completed).
  formats::Result<DrawListTotals> totals() const;
  /// The last list's records in draw order (readableRecords only).
  formats::Result<std::vector<runtime::PatchDrawRecord>> readRecords() const;

 private:
  DeviceDrawList() = default;
  runtime::PatchDrawConstants constants_{};
  std::uint32_t nodeCount_ = 0;
  std::uint32_t groups_ = 0;
  std::uint32_t groupsPerRow_ = 65535;
  std::uint32_t capacity_ = 0;
  GpuBuffer records_, nodes_, frame_, order_, slots_, groupSums_, commands_, count_, parents_;
  std::optional<ComputeProgram> program_;
};

}  // namespace pbdam::gpu
