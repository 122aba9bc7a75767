// Layout transitions of a sampled image around its upload (internal to pbdam_gpu): the barrier
// from `from` to `to` (every layer), for images written by a copy and read by fragment or vertex
// shaders (SurfaceOverlayBinding, AtmosphereBinding).
#pragma once

#include <vulkan/vulkan.h>

namespace pbdam::gpu {

/// The barrier taking every layer of `image` from `from` to `to` (UNDEFINED → TRANSFER_DST before
/// a copy, TRANSFER_DST → SHADER_READ_ONLY after it).
inline VkImageMemoryBarrier2 uploadLayoutBarrier(VkImage image, VkImageLayout from,
                                                 VkImageLayout to) {
  VkImageMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  b.srcStageMask =
      from == VK_IMAGE_LAYOUT_UNDEFINED ? VK_PIPELINE_STAGE_2_NONE : VK_PIPELINE_STAGE_2_COPY_BIT;
  b.srcAccessMask =
      from == VK_IMAGE_LAYOUT_UNDEFINED ? VK_ACCESS_2_NONE : VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b.dstStageMask =
      to == VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL
          ? VK_PIPELINE_STAGE_2_COPY_BIT
          : VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  b.dstAccessMask = to == VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL
                        ? VK_ACCESS_2_TRANSFER_WRITE_BIT
                        : VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
  return b;
}

/// Records `barrier` alone.
inline void recordBarrier(VkCommandBuffer cmd, const VkImageMemoryBarrier2& barrier) {
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.imageMemoryBarrierCount = 1;
  dependency.pImageMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

}  // namespace pbdam::gpu
