// The staging buffer and its copies into the GPU cache's pools (StagingUploader.h).
#include "StagingUploader.h"

#include <algorithm>
#include <vector>

#include "pbdam/gpu/VulkanContext.h"

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::gpu {
namespace {

VkImageMemoryBarrier2 layerBarrier(VkImage image, std::uint32_t layer,
                                   VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                                   VkImageLayout oldLayout, VkImageLayout newLayout) {
  VkImageMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.oldLayout = oldLayout;
  b.newLayout = newLayout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, layer, 1};
  return b;
}

}  // namespace

Result<void> StagingUploader::ensure(const VulkanContext& context, std::uint64_t bytes,
                                     DeferredDestruction& garbage, std::uint64_t lastUse) {
  if (bytes == 0 || (staging_ && staging_.sizeBytes() >= bytes)) return {};
  const std::uint64_t size =
      std::max<std::uint64_t>(bytes, staging_ ? 2 * staging_.sizeBytes() : std::uint64_t{4} << 20);
  garbage.retire(std::move(staging_), lastUse);
  staging_ = GpuBuffer();
  auto buffer = createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUse::HostUpload,
                             "terrain upload staging");
  if (!buffer) return std::move(buffer).error();
  staging_ = std::move(*buffer);
  return {};
}

Result<void> StagingUploader::flush() const {
  return staging_ ? staging_.flushHostWrites() : Result<void>();
}

void StagingUploader::record(VkCommandBuffer cmd, std::span<const DecodeJob> jobs,
                             std::span<const std::uint32_t> slots, const PatchPool& patches,
                             const TilePool& tiles) const {
  // Before: earlier submissions read the pool regions being overwritten (write-after-read),
  // and tile layers go to TRANSFER_DST (their old contents are discarded).
  VkMemoryBarrier2 before{};
  before.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  before.srcStageMask =
      VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT;
  before.dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  before.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  VkMemoryBarrier2 after{};
  after.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  after.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  after.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  after.dstStageMask =
      VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT;
  after.dstAccessMask = VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT;
  std::vector<VkImageMemoryBarrier2> toTransfer;
  std::vector<VkImageMemoryBarrier2> toSampled;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    if (jobs[j].key.kind() != ResidentKind::Tile) continue;
    const PoolLocation at = tiles.locate(slots[j]);
    for (VkImage image : {tiles.image(at.chunk), tiles.normalImage(at.chunk)}) {
      toTransfer.push_back(layerBarrier(image, at.local, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                        VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
                                        VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL));
      toSampled.push_back(layerBarrier(
          image, at.local, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
          VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
          VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL));
    }
  }
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.memoryBarrierCount = 1;
  dependency.pMemoryBarriers = &before;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(toTransfer.size());
  dependency.pImageMemoryBarriers = toTransfer.data();
  vkCmdPipelineBarrier2(cmd, &dependency);

  const TileFormats& formats = tiles.formats();
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const DecodeJob& job = jobs[j];
    if (job.key.kind() == ResidentKind::Patch) {
      const PoolLocation at = patches.locate(slots[j]);
      const VkBufferCopy vertices{
          job.offset, VkDeviceSize{sizeof(PatchGpuVertex)} * patches.firstVertex(at.local),
          job.vertexBytes};
      vkCmdCopyBuffer(cmd, staging_.buffer(), patches.vertexBuffer(at.chunk), 1, &vertices);
      const VkBufferCopy indices{job.offset + job.vertexBytes,
                                 VkDeviceSize{2} * patches.firstIndex(at.local),
                                 job.bytes - job.vertexBytes};
      vkCmdCopyBuffer(cmd, staging_.buffer(), patches.indexBuffer(at.chunk), 1, &indices);
    } else {
      const PoolLocation at = tiles.locate(slots[j]);
      VkBufferImageCopy region{};
      region.bufferOffset = job.offset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, at.local, 1};
      region.imageExtent = {formats.colourTexels, formats.colourTexels, 1};
      vkCmdCopyBufferToImage(cmd, staging_.buffer(), tiles.image(at.chunk),
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      // The normal map, after the colour texels in the decoded tile.
      region.bufferOffset = job.offset + formats.normalOffset;
      region.imageExtent = {formats.normalTexels, formats.normalTexels, 1};
      vkCmdCopyBufferToImage(cmd, staging_.buffer(), tiles.normalImage(at.chunk),
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    }
  }

  dependency.pMemoryBarriers = &after;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(toSampled.size());
  dependency.pImageMemoryBarriers = toSampled.data();
  vkCmdPipelineBarrier2(cmd, &dependency);
}

}  // namespace pbdam::gpu
