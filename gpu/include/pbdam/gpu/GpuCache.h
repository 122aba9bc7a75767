// GpuCache: the GPU-resident patch and texture cache of docs/architecture.md "Streaming"
// ([P-BDAM 2003] §4.4) as an object of its own — one byte budget, one LRU over patches and tiles
// (ResidencyLru), one set of device pools and the patch pipeline — so that several
// TerrainRenderers, each driven by its own thread, can share it: what one render context uploads,
// every other one draws from. A TerrainRenderer created without one makes a private cache.
// Thread-safety: every public member is thread-safe; the renderers that share a cache take its lock
// for the bookkeeping, decoding and uploads of a pass and draw outside it, with the pass's entries
// pinned (never evicted while a draw may read them).
#pragma once

#include <cstdint>
#include <memory>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::gpu {

class VulkanContext;

/// How a GpuCache is set up.
struct GpuCacheOptions final {
  /// Slot bytes of resident patches and tiles together (a patch slot holds
  /// DatasetView::maxPatchVertices vertices of 20 bytes and maxPatchTriangles triangles of 16-bit
  /// indices; a tile slot one texture-array layer).
  std::uint64_t budgetBytes = std::uint64_t{256} << 20;
  /// Upload BC1 tiles expanded to RGBA8 even when the device samples BC1 (tests, comparisons).
  bool forceRgba8Textures = false;
  /// Bytes of one pool chunk (a vertex and an index buffer) and of one texture page (at most
  /// the device's array layers).
  std::uint64_t chunkBytes = std::uint64_t{16} << 20;
  /// Vertical exaggeration of the patches decoded into the cache (their vertices drawn at
  /// height × F: runtime::PatchVertexPlacement): fixed for the cache's life, so every renderer
  /// sharing it must draw with the same F.
  double exaggeration = 1.0;
};

/// What a cache holds now, and how often renderers waited for room.
struct GpuCacheStats final {
  std::uint64_t budgetBytes = 0;      ///< GpuCacheOptions::budgetBytes
  std::uint64_t residentBytes = 0;    ///< slot bytes resident
  std::uint64_t pinnedBytes = 0;      ///< slot bytes pinned by passes in flight
  std::uint64_t poolBytes = 0;        ///< device memory the pools hold (allocated capacity)
  std::uint32_t residentPatches = 0;  ///< patches resident
  std::uint32_t residentTiles = 0;    ///< texture tiles resident
  /// Passes that found the budget pinned by other renderers' passes in flight and waited for
  /// them to finish before making room.
  std::uint64_t waits = 0;
  /// Passes' reservations (from reserving their entries through their uploads, under the
  /// cache's lock), the milliseconds they spent waiting to take the lock (another renderer's
  /// pass held it), and the milliseconds they held it: how much the shared cache serialises.
  /// @{
  std::uint64_t leases = 0;
  double lockWaitMs = 0.0;
  double lockHeldMs = 0.0;
  /// @}
};

/// Created once per (VulkanContext, DatasetView); both must outlive it and every renderer that
/// uses it. Held through shared_ptr by the renderers that use it. Non-copyable.
class GpuCache final {
 public:
  /// Errors: InvalidArgument for a budget below minimumBytes (the message names both),
  /// CorruptData for a dataset without drawable patches or with an invalid tile size,
  /// DeviceError for Vulkan failures.
  static formats::Result<std::shared_ptr<GpuCache>> create(VulkanContext& context,
                                                           const runtime::DatasetView& dataset,
                                                           const GpuCacheOptions& options);

  /// The smallest budget that can draw any frame: one patch slot plus one tile slot, for the
  /// texel format a cache would use on `context`'s device.
  static std::uint64_t minimumBytes(const VulkanContext& context,
                                    const runtime::DatasetView& dataset,
                                    bool forceRgba8Textures = false);

  /// The budget that holds every patch (with triangles) and every tile of `dataset` at once:
  /// what TerrainRenderer::renderSelected needs.
  static std::uint64_t bytesForEverything(const VulkanContext& context,
                                          const runtime::DatasetView& dataset,
                                          bool forceRgba8Textures = false);

  GpuCache(const GpuCache&) = delete;
  GpuCache& operator=(const GpuCache&) = delete;
  ~GpuCache();

  /// The budget it was made with (GpuCacheOptions::budgetBytes).
  std::uint64_t budgetBytes() const noexcept;
  /// Whether tiles are sampled as BC1 on the device (else RGBA8).
  bool usesBc1Textures() const noexcept;
  /// What it holds now, and its waits and leases so far.
  GpuCacheStats stats() const;
  /// Whether the patch (the tile) is resident now, drawable without a decode. Until the
  /// caller's next pass through this cache plans its uploads it stays so, unless a pass of
  /// another renderer of the cache, or an earlier pass of the same frame (a cut larger than the
  /// budget), makes room in between.
  /// @{
  bool holds(const runtime::NodeKey& patch) const;
  bool holds(const runtime::TileKey& tile) const;
  /// @}

  /// The state behind the cache (gpu/src/GpuCacheState.h); only pbdam_gpu's sources see inside.
  struct State;
  /// The state behind the cache, for pbdam_gpu's own sources.
  State& state() noexcept { return *state_; }

 private:
  explicit GpuCache(std::unique_ptr<State> state) noexcept;
  std::unique_ptr<State> state_;
};

}  // namespace pbdam::gpu
