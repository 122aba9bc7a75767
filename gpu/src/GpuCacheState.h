// The inside of a GpuCache (internal to pbdam_gpu): the texel format choice, slot sizes, the
// patch pipeline every renderer of the cache draws with, and — under `mutex` — the LRU, the
// pools and the pass epoch. TerrainRenderer.cpp holds the protocol (GpuCache.h).
#pragma once

#include <vulkan/vulkan.h>

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>

#include "GpuPools.h"
#include "PatchPipeline.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/streaming/ResidencyLru.h"

namespace pbdam::gpu {

/// How tiles are held on the device.
struct TextureChoice final {
  VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
  formats::TexelFormat texels = formats::TexelFormat::Rgba8;
  /// The normal maps': BC5 beside BC1, RG8 beside RGBA8 (DecodeScheduler::normalTexels).
  VkFormat normalFormat = VK_FORMAT_R8G8_UNORM;
  /// A slot's device bytes: the colour tile's and its normal map's.
  std::uint64_t slotBytes = 0;
};

/// BC1 and BC5 where the dataset and the device have them (and they are not refused), RGBA8 and
/// RG8 otherwise.
TextureChoice chooseTexture(const VulkanContext& context, const runtime::DatasetView& dataset,
                            bool forceRgba8);
/// Bytes of one patch slot: the dataset's largest patch, 24-byte vertices and 16-bit indices.
std::uint64_t patchSlotBytes(const runtime::DatasetView& dataset);

/// Whether a node has a patch to draw (triangles, vertices and a blob).
inline bool drawable(const formats::NodeRecord& record) {
  return record.triangleCount > 0 && record.vertexCount > 0 && record.blobBytes > 0;
}

struct GpuCache::State {
  VulkanContext* context = nullptr;
  const runtime::DatasetView* dataset = nullptr;
  TextureChoice texture;
  double exaggeration = 1.0;  ///< GpuCacheOptions::exaggeration of the resident patches
  std::uint64_t patchSlot = 0;
  std::uint32_t maxIndices = 0;
  /// Immutable after creation; command buffers of every renderer bind it at once.
  PatchPipeline pipeline;

  /// Guards everything below. Held by a renderer from planning a pass through its uploads.
  std::mutex mutex;
  /// Signalled whenever pins are released (a pass finished or failed).
  std::condition_variable unpinned;
  std::optional<streaming::ResidencyLru> lru;
  PatchPool patches;
  TilePool tiles;
  /// Pass numbers, over every renderer of the cache.
  std::uint64_t epoch = 0;
  std::uint64_t waits = 0;
  /// What the passes' leases (CacheLease) cost the other renderers: leases taken, the time spent
  /// waiting to take the lock, and the time it was held (waits for room excluded), in ms.
  std::uint64_t leases = 0;
  double lockWaitMs = 0.0;
  double lockHeldMs = 0.0;
};

}  // namespace pbdam::gpu
