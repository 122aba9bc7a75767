// The cut selected on the device (docs/architecture.md "Selection by predicate",
// [Yalçın 2011] §6–7): the node tables resident in a device buffer, and per frame three compute
// passes in one submission — the predicate per node, the closure to a fixed point (2·(depth + 1)
// steps with barriers, no host round trip per level), and the drawn flags — then a read-back of the
// flags and screen errors from which the host lists the cut in refine()'s depth-first order, with
// its tiles and geomorph weights. The predicate is runtime::CutSelector's (screen error, focus
// regions, a caller's flags); the arithmetic is the CPU's operation for operation in double,
// so on lavapipe (IEEE doubles, no contraction) the cut is the CPU's, bit for bit in its
// screen errors. Thread-safety: one thread at a time; the
// context and the dataset must outlive it.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/Selection.h"

namespace pbdam::gpu {

class VulkanContext;

/// runtime::CutSelector's cut made on the device: the dataset's node tables in a device
/// buffer, the predicate, the closure and the drawn flags as compute passes, and the cut listed
/// on the host from what they read back — bit for bit the host's on lavapipe. Move-only; used by
/// one thread at a time; the context and the dataset must outlive it.
class GpuSelector final {
 public:
  /// Uploads the node tables (64 bytes a node) and creates the passes. InvalidArgument when the
  /// tables need more than `tableBudgetBytes` (naming both sizes) or the device has no 64-bit
  /// floats in shaders; DeviceError for Vulkan failures. Its passes, and a DeviceDrawList's
  /// made from it, dispatch one invocation a node in rows of at most `groupsPerRow` groups
  /// (65,535, the least maxComputeWorkGroupCount Vulkan guarantees: 4.2 M nodes a row at 64 a
  /// group; the paper-scale dataset has 6.3 M); tests narrow the rows to cover several.
  static formats::Result<GpuSelector> create(VulkanContext& context,
                                             const runtime::DatasetView& dataset,
                                             std::uint64_t tableBudgetBytes = std::uint64_t{256}
                                                                              << 20,
                                             std::uint32_t groupsPerRow = 65535);
  /// Takes over another selector, leaving it empty.
  /// @{
  GpuSelector(GpuSelector&&) noexcept;
  GpuSelector& operator=(GpuSelector&&) noexcept;
  /// @}
  GpuSelector(const GpuSelector&) = delete;
  GpuSelector& operator=(const GpuSelector&) = delete;
  ~GpuSelector();

  /// The cut for `camera` and `selection` (tolerance, culling, level cap, morph range, focus
  /// regions — at most 64 with 4096 points in all — and the caller's predicate, evaluated on
  /// the host into a flag per node): runtime::CutSelector's cut.
  formats::Result<runtime::Cut> select(const runtime::Camera& camera,
                                       const runtime::SelectionOptions& selection);

  /// For a draw list made on the device (TerrainRenderer::renderSelected): uploads the frame's
  /// inputs and records the three passes into `cmd`, ending with a barrier that makes their
  /// writes visible to later compute passes. The node states (bit 1: drawn, bit 2: split for its
  /// screen error) and screen errors stay on the device, in index() order. Errors as select().
  formats::Result<void> recordSelection(VkCommandBuffer cmd, const runtime::Camera& camera,
                                        const runtime::SelectionOptions& selection);
  /// The dataset's nodes in the order of the device's tables.
  const runtime::DiamondIndex& index() const noexcept;
  /// The row width of its dispatches (create's `groupsPerRow`).
  std::uint32_t groupsPerRow() const noexcept;
  /// The device buffers recordSelection() leaves its screen errors and node states in (index()
  /// order).
  /// @{
  const GpuBuffer& screenErrors() const noexcept;
  const GpuBuffer& nodeStates() const noexcept;
  /// @}

 private:
  struct Impl;
  explicit GpuSelector(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbdam::gpu
