// One pass's render pass and per-patch draws (DrawRecorder.h; [P-BDAM 2003] §4.2).
#include "DrawRecorder.h"

#include <algorithm>
#include <cstring>
#include <limits>

namespace pbdam::gpu {

void recordSky(VkCommandBuffer cmd, VkPipeline sky) {
  // sky.vert's band: kSkySegments quads of two triangles.
  constexpr std::uint32_t kSkyVertices = 128 * 6;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, sky);
  vkCmdDraw(cmd, kSkyVertices, 1, 0, 0);
}

void DrawRecorder::record(VkCommandBuffer cmd, const OffscreenTarget& target,
                          const PassPlacement& placement, std::span<const std::byte> push,
                          std::span<const DrawItem> items) const {
  const bool radiance =
      placement.toneMapExposure > 0.0f && radiance_ != nullptr && target.keepsRadiance();
  if (placement.first) {
    target.recordBeginRendering(cmd, placement.clearRgba, OffscreenTarget::kFarDepth,
                                !placement.last, radiance);
  } else {
    target.recordResumeRendering(cmd, !placement.last, radiance);
  }
  PatchPush values{};
  std::memcpy(&values, push.data(), std::min(push.size(), sizeof values));
  VkPipeline patches = radiance ? radiance_->patch.get() : pipeline_->pipeline();
  if (placement.first && values.camera[3] > 0.0f) {
    // With the atmosphere, the sky first (no depth test; the patches cover it), with the
    // patches' sets and push constants bound.
    recordBindingsAndDraws(cmd, patches, push, {});
    recordSky(cmd, radiance ? radiance_->sky.get() : pipeline_->skyPipeline());
  }
  recordBindingsAndDraws(cmd, patches, push, items);
  vkCmdEndRendering(cmd);
  if (placement.last && radiance) target.recordToneMap(cmd, placement.toneMapExposure);
}

void DrawRecorder::recordDraws(VkCommandBuffer cmd, VkPipeline pipeline, std::uint32_t width,
                               std::uint32_t height, std::span<const std::byte> push,
                               std::span<const DrawItem> items) const {
  VkViewport viewport{};
  viewport.width = static_cast<float>(width);
  viewport.height = static_cast<float>(height);
  viewport.maxDepth = 1.0f;
  const VkRect2D scissor{{0, 0}, {width, height}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  recordBindingsAndDraws(cmd, pipeline, push, items);
}

void DrawRecorder::recordBindingsAndDraws(VkCommandBuffer cmd, VkPipeline boundPipeline,
                                          std::span<const std::byte> push,
                                          std::span<const DrawItem> items) const {
  const PatchPipeline& pipeline = *pipeline_;
  constexpr VkShaderStageFlags kStages = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, boundPipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 0, 1,
                          &recordsSet_, 0, nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 3, 1,
                          &overlaySet_, 0, nullptr);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 4, 1,
                          &atmosphereSet_, 0, nullptr);
  vkCmdPushConstants(cmd, pipeline.layout(), kStages, 0, static_cast<std::uint32_t>(push.size()),
                     push.data());
  std::uint32_t boundChunk = std::numeric_limits<std::uint32_t>::max();
  std::uint32_t boundPage = std::numeric_limits<std::uint32_t>::max();
  std::uint32_t boundMorphPage = std::numeric_limits<std::uint32_t>::max();
  for (const DrawItem& item : items) {
    const PoolLocation patch = patches_->locate(item.patchSlot);
    const PoolLocation tile = tiles_->locate(item.tileSlot);
    if (patch.chunk != boundChunk) {
      VkBuffer vertexBuffer = patches_->vertexBuffer(patch.chunk);
      const VkDeviceSize zero = 0;
      vkCmdBindVertexBuffers(cmd, 0, 1, &vertexBuffer, &zero);
      vkCmdBindIndexBuffer(cmd, patches_->indexBuffer(patch.chunk), 0, VK_INDEX_TYPE_UINT16);
      boundChunk = patch.chunk;
    }
    if (tile.chunk != boundPage) {
      VkDescriptorSet set = tiles_->descriptorSet(tile.chunk);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 1, 1, &set,
                              0, nullptr);
      boundPage = tile.chunk;
    }
    const PoolLocation morphTile = tiles_->locate(item.morphTileSlot);
    if (morphTile.chunk != boundMorphPage) {
      VkDescriptorSet set = tiles_->descriptorSet(morphTile.chunk);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 2, 1, &set,
                              0, nullptr);
      boundMorphPage = morphTile.chunk;
    }
    vkCmdPushConstants(cmd, pipeline.layout(), kStages, kRecordIndexOffset, sizeof item.recordIndex,
                       &item.recordIndex);
    vkCmdDrawIndexed(cmd, item.indexCount, 1, patches_->firstIndex(patch.local),
                     static_cast<std::int32_t>(patches_->firstVertex(patch.local)), 0);
  }
}

}  // namespace pbdam::gpu
