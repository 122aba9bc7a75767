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

/// Tile slots: layers of 2D-array images of `format` (sizeTexels², one mip), `layersPerPage`
/// layers a page (the last page may hold fewer), each page with a descriptor set (set 1 of the
/// patch pipeline) and kept in SHADER_READ_ONLY_OPTIMAL between uploads.
class TilePool final {
 public:
  TilePool() = default;

  /// Creates the descriptor pool for every page the capacity can need.
  static formats::Result<TilePool> create(const VulkanContext& context, VkFormat format,
                                          std::uint32_t sizeTexels, std::uint64_t slotBytes,
                                          std::uint32_t capacitySlots, std::uint32_t layersPerPage,
                                          VkDescriptorSetLayout setLayout, VkSampler sampler);

  /// Allocates pages until slots [0, slotCount) exist (slotCount ≤ capacity); new pages are
  /// moved to SHADER_READ_ONLY_OPTIMAL by a submission of their own.
  formats::Result<void> ensureSlots(VulkanContext& context, std::uint32_t slotCount);

  PoolLocation locate(std::uint32_t slot) const noexcept {
    return {slot / layersPerPage_, slot % layersPerPage_};
  }
  VkImage image(std::uint32_t page) const noexcept { return pages_[page].image.image(); }
  VkDescriptorSet descriptorSet(std::uint32_t page) const noexcept { return pages_[page].set; }
  VkFormat format() const noexcept { return format_; }
  std::uint32_t sizeTexels() const noexcept { return sizeTexels_; }
  std::uint64_t allocatedBytes() const noexcept { return allocatedBytes_; }

 private:
  struct Page {
    GpuImage image;
    VkDescriptorSet set = VK_NULL_HANDLE;  ///< freed with the descriptor pool
  };
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  std::uint32_t sizeTexels_ = 0;
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
