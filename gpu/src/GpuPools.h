// GPU-resident pools (internal to pbdam_gpu) whose slots ResidencyLru hands out: fixed-size patch
// slots (vertices + 16-bit indices) in device-local vertex/index buffers, and texture tiles as
// layers of 2D-array images ("pages", one descriptor set each). Both grow in chunks on demand up
// to the capacity the budget allows, never beyond. Thread-safety: none (the render thread).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/UniqueHandle.h"

namespace pbdam::gpu {

class VulkanContext;

/// Where a slot lives: chunk (or page) and index inside it.
struct PoolLocation final {
  std::uint32_t chunk = 0;
  std::uint32_t local = 0;
};

/// Patch slots of `maxVertices` 24-byte vertices (streaming::PatchGpuVertex) and `maxIndices`
/// 16-bit indices, in chunks of one vertex buffer and one index buffer each.
class PatchPool final {
 public:
  PatchPool() = default;
  PatchPool(std::uint32_t maxVertices, std::uint32_t maxIndices, std::uint32_t capacitySlots,
            std::uint32_t slotsPerChunk) noexcept;

  /// Allocates chunks until slots [0, slotCount) exist; slotCount must be ≤ the capacity.
  formats::Result<void> ensureSlots(const VulkanContext& context, std::uint32_t slotCount);

  PoolLocation locate(std::uint32_t slot) const noexcept {
    return {slot / slotsPerChunk_, slot % slotsPerChunk_};
  }
  VkBuffer vertexBuffer(std::uint32_t chunk) const noexcept {
    return chunks_[chunk].vertices.buffer();
  }
  VkBuffer indexBuffer(std::uint32_t chunk) const noexcept {
    return chunks_[chunk].indices.buffer();
  }
  std::uint32_t firstVertex(std::uint32_t local) const noexcept { return local * maxVertices_; }
  std::uint32_t firstIndex(std::uint32_t local) const noexcept { return local * maxIndices_; }
  std::uint64_t allocatedBytes() const noexcept { return allocatedBytes_; }

 private:
  struct Chunk {
    GpuBuffer vertices;
    GpuBuffer indices;
  };
  std::uint32_t maxVertices_ = 0;
  std::uint32_t maxIndices_ = 0;
  std::uint32_t capacitySlots_ = 0;
  std::uint32_t slotsPerChunk_ = 1;
  std::vector<Chunk> chunks_;
  std::uint64_t allocatedBytes_ = 0;
};

/// What a tile slot holds: its colour texels and its normal map's (half the size), and where
/// the normal map's texels start in a decoded tile (DecodeScheduler::normalTileOffset).
struct TileFormats final {
  VkFormat colour = VK_FORMAT_UNDEFINED;
  std::uint32_t colourTexels = 0;
  VkFormat normal = VK_FORMAT_UNDEFINED;
  std::uint32_t normalTexels = 0;
  std::uint64_t normalOffset = 0;
};

/// Tile slots: layers of two 2D-array images a page, the colour tiles (`colour`,
/// colourTexels², one mip) and their normal maps (`normal`, normalTexels²) in the same layer,
/// `layersPerPage` layers a page (the last page may hold fewer), each page with a descriptor set
/// (set 1 of the patch pipeline: binding 0 the colour, 1 the normal maps) and kept in
/// SHADER_READ_ONLY_OPTIMAL between uploads.
class TilePool final {
 public:
  TilePool() = default;

  /// Creates the descriptor pool for every page the capacity can need.
  static formats::Result<TilePool> create(const VulkanContext& context, const TileFormats& formats,
                                          std::uint64_t slotBytes, std::uint32_t capacitySlots,
                                          std::uint32_t layersPerPage,
                                          VkDescriptorSetLayout setLayout, VkSampler sampler);

  /// Allocates pages until slots [0, slotCount) exist (slotCount ≤ capacity); new pages are
  /// moved to SHADER_READ_ONLY_OPTIMAL by a submission of their own.
  formats::Result<void> ensureSlots(VulkanContext& context, std::uint32_t slotCount);

  PoolLocation locate(std::uint32_t slot) const noexcept {
    return {slot / layersPerPage_, slot % layersPerPage_};
  }
  VkImage image(std::uint32_t page) const noexcept { return pages_[page].image.image(); }
  VkImage normalImage(std::uint32_t page) const noexcept {
    return pages_[page].normalImage.image();
  }
  VkDescriptorSet descriptorSet(std::uint32_t page) const noexcept { return pages_[page].set; }
  const TileFormats& formats() const noexcept { return formats_; }
  std::uint64_t allocatedBytes() const noexcept { return allocatedBytes_; }

 private:
  struct Page {
    GpuImage image;
    GpuImage normalImage;
    VkDescriptorSet set = VK_NULL_HANDLE;  ///< freed with the descriptor pool
  };
  TileFormats formats_;
  std::uint64_t slotBytes_ = 0;
  std::uint32_t capacitySlots_ = 0;
  std::uint32_t layersPerPage_ = 1;
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkSampler sampler_ = VK_NULL_HANDLE;
  UniqueDescriptorPool descriptorPool_;
  std::vector<Page> pages_;
  std::uint64_t allocatedBytes_ = 0;
};

}  // namespace pbdam::gpu
