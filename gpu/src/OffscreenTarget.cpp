// OffscreenTarget: colour + reversed-Z depth attachments, dynamic rendering, readback.
#include "pbdam/gpu/OffscreenTarget.h"

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

VkImageMemoryBarrier2 imageBarrier(VkImage image, VkImageAspectFlags aspect,
                                   VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                                   VkImageLayout oldLayout, VkImageLayout newLayout) noexcept {
  VkImageMemoryBarrier2 barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  barrier.srcStageMask = srcStage;
  barrier.srcAccessMask = srcAccess;
  barrier.dstStageMask = dstStage;
  barrier.dstAccessMask = dstAccess;
  barrier.oldLayout = oldLayout;
  barrier.newLayout = newLayout;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image;
  barrier.subresourceRange = {aspect, 0, 1, 0, 1};
  return barrier;
}

constexpr VkPipelineStageFlags2 kDepthStages =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;

}  // namespace

Result<OffscreenTarget> OffscreenTarget::create(const VulkanContext& context, uint32_t widthPixels,
                                                uint32_t heightPixels) {
  const std::string size = std::to_string(widthPixels) + "x" + std::to_string(heightPixels);
  OffscreenTarget target;

  ImageDesc colorDesc;
  colorDesc.format = kColorFormat;
  colorDesc.widthPixels = widthPixels;
  colorDesc.heightPixels = heightPixels;
  colorDesc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  colorDesc.aspect = VK_IMAGE_ASPECT_COLOR_BIT;
  Result<GpuImage> color = createImage2D(context, colorDesc, "offscreen colour " + size);
  if (!color) return std::move(color).error();
  target.color_ = std::move(*color);

  ImageDesc depthDesc = colorDesc;
  depthDesc.format = kDepthFormat;
  depthDesc.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  depthDesc.aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
  Result<GpuImage> depth = createImage2D(context, depthDesc, "offscreen depth " + size);
  if (!depth) return std::move(depth).error();
  target.depth_ = std::move(*depth);

  const VkDeviceSize bytes = VkDeviceSize{4} * widthPixels * heightPixels;
  Result<GpuBuffer> staging = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                           MemoryUse::HostReadback, "offscreen readback " + size);
  if (!staging) return std::move(staging).error();
  target.staging_ = std::move(*staging);
  return target;
}

void OffscreenTarget::recordBeginRendering(VkCommandBuffer cmd,
                                           const std::array<float, 4>& clearRgba, float clearDepth,
                                           bool keepDepth) const {
  // Old contents are discarded (UNDEFINED); the source scopes cover the previous frame's
  // attachment writes and readback copy (write-after-write / write-after-read).
  const std::array<VkImageMemoryBarrier2, 2> barriers = {
      imageBarrier(color_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT,
                   VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL),
      imageBarrier(depth_.image(), VK_IMAGE_ASPECT_DEPTH_BIT, kDepthStages,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kDepthStages,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
                   VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL),
  };
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(barriers.size());
  dependency.pImageMemoryBarriers = barriers.data();
  vkCmdPipelineBarrier2(cmd, &dependency);

  beginRendering(cmd, VK_ATTACHMENT_LOAD_OP_CLEAR, clearRgba, clearDepth, keepDepth);
}

void OffscreenTarget::recordResumeRendering(VkCommandBuffer cmd, bool keepDepth) const {
  // Same layouts: a memory dependency from the previous pass's attachment writes to this one's
  // loads and writes.
  const std::array<VkImageMemoryBarrier2, 2> barriers = {
      imageBarrier(
          color_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
          VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
          VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT,
          VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL),
      imageBarrier(depth_.image(), VK_IMAGE_ASPECT_DEPTH_BIT, kDepthStages,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kDepthStages,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
                   VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                   VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL),
  };
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(barriers.size());
  dependency.pImageMemoryBarriers = barriers.data();
  vkCmdPipelineBarrier2(cmd, &dependency);
  beginRendering(cmd, VK_ATTACHMENT_LOAD_OP_LOAD, {0.0f, 0.0f, 0.0f, 0.0f}, kFarDepth, keepDepth);
}

void OffscreenTarget::beginRendering(VkCommandBuffer cmd, VkAttachmentLoadOp loadOp,
                                     const std::array<float, 4>& clearRgba, float clearDepth,
                                     bool keepDepth) const {
  VkRenderingAttachmentInfo colorAttachment{};
  colorAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  colorAttachment.imageView = color_.view();
  colorAttachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAttachment.loadOp = loadOp;
  colorAttachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  colorAttachment.clearValue.color = {{clearRgba[0], clearRgba[1], clearRgba[2], clearRgba[3]}};

  VkRenderingAttachmentInfo depthAttachment{};
  depthAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  depthAttachment.imageView = depth_.view();
  depthAttachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAttachment.loadOp = loadOp;
  depthAttachment.storeOp =
      keepDepth ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE;
  depthAttachment.clearValue.depthStencil = {clearDepth, 0};

  VkRenderingInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  rendering.renderArea = {{0, 0}, extent()};
  rendering.layerCount = 1;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachments = &colorAttachment;
  rendering.pDepthAttachment = &depthAttachment;
  vkCmdBeginRendering(cmd, &rendering);

  VkViewport viewport{};
  viewport.width = static_cast<float>(widthPixels());
  viewport.height = static_cast<float>(heightPixels());
  viewport.minDepth = 0.0f;
  viewport.maxDepth = 1.0f;
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  const VkRect2D scissor{{0, 0}, extent()};
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void OffscreenTarget::recordEndRenderingAndReadback(VkCommandBuffer cmd) const {
  vkCmdEndRendering(cmd);
  recordReadback(cmd);
}

void OffscreenTarget::recordReadback(VkCommandBuffer cmd) const {
  const VkImageMemoryBarrier2 toTransfer = imageBarrier(
      color_.image(), VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
      VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
      VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
      VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  VkDependencyInfo before{};
  before.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  before.imageMemoryBarrierCount = 1;
  before.pImageMemoryBarriers = &toTransfer;
  vkCmdPipelineBarrier2(cmd, &before);

  VkBufferImageCopy region{};
  region.bufferOffset = 0;
  region.bufferRowLength = 0;  // tightly packed
  region.bufferImageHeight = 0;
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {widthPixels(), heightPixels(), 1};
  vkCmdCopyImageToBuffer(cmd, color_.image(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                         staging_.buffer(), 1, &region);

  VkBufferMemoryBarrier2 toHost{};
  toHost.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2;
  toHost.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  toHost.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toHost.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
  toHost.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
  toHost.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toHost.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toHost.buffer = staging_.buffer();
  toHost.offset = 0;
  toHost.size = VK_WHOLE_SIZE;
  VkDependencyInfo after{};
  after.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  after.bufferMemoryBarrierCount = 1;
  after.pBufferMemoryBarriers = &toHost;
  vkCmdPipelineBarrier2(cmd, &after);
}

Result<RgbaImage> OffscreenTarget::readPixels() const {
  if (Result<void> r = staging_.invalidateForHostRead(); !r) return std::move(r).error();
  RgbaImage image;
  image.widthPixels = widthPixels();
  image.heightPixels = heightPixels();
  image.rgba.resize(std::size_t{4} * widthPixels() * heightPixels());
  std::memcpy(image.rgba.data(), staging_.mappedBytes().data(), image.rgba.size());
  return image;
}

Result<RgbaImage> OffscreenTarget::render(VulkanContext& context,
                                          const std::array<float, 4>& clearRgba,
                                          const std::function<void(VkCommandBuffer)>& draw) const {
  Result<void> done = context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        recordBeginRendering(cmd, clearRgba);
        draw(cmd);
        recordEndRenderingAndReadback(cmd);
      },
      "offscreen render");
  if (!done) return std::move(done).error();
  return readPixels();
}

void OffscreenTarget::recordPresent(VkCommandBuffer cmd, const PresentTarget& present,
                                    bool afterReadback) const {
  const std::array<VkImageMemoryBarrier2, 2> toBlit = {
      afterReadback
          ? imageBarrier(color_.image(), VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                         VK_ACCESS_2_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                         VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                         VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL)
          : imageBarrier(color_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                         VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                         VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                         VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                         VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
      // In the same stage as the semaphore wait: the acquisition is done before the transition.
      imageBarrier(present.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                   VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL)};
  VkDependencyInfo before{};
  before.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  before.imageMemoryBarrierCount = static_cast<std::uint32_t>(toBlit.size());
  before.pImageMemoryBarriers = toBlit.data();
  vkCmdPipelineBarrier2(cmd, &before);

  VkImageBlit region{};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.srcOffsets[1] = {static_cast<std::int32_t>(widthPixels()),
                          static_cast<std::int32_t>(heightPixels()), 1};
  region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.dstOffsets[1] = {static_cast<std::int32_t>(present.extent.width),
                          static_cast<std::int32_t>(present.extent.height), 1};
  vkCmdBlitImage(cmd, color_.image(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, present.image,
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region, VK_FILTER_NEAREST);

  VkPipelineStageFlags2 lastStage = VK_PIPELINE_STAGE_2_BLIT_BIT;
  const std::uint32_t panelWidth =
      std::min(present.overlayExtent.width,
               present.extent.width -
                   std::min<std::uint32_t>(present.extent.width,
                                           static_cast<std::uint32_t>(present.overlayOffset.x)));
  const std::uint32_t panelHeight =
      std::min(present.overlayExtent.height,
               present.extent.height -
                   std::min<std::uint32_t>(present.extent.height,
                                           static_cast<std::uint32_t>(present.overlayOffset.y)));
  if (present.overlay != VK_NULL_HANDLE && panelWidth > 0 && panelHeight > 0 &&
      present.overlayOffset.x >= 0 && present.overlayOffset.y >= 0) {
    // The blit and the panel's copy write the same pixels: the copy comes second.
    const VkImageMemoryBarrier2 afterBlit =
        imageBarrier(present.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkDependencyInfo between{};
    between.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
    between.imageMemoryBarrierCount = 1;
    between.pImageMemoryBarriers = &afterBlit;
    vkCmdPipelineBarrier2(cmd, &between);
    VkBufferImageCopy panel{};
    panel.bufferRowLength = present.overlayExtent.width;
    panel.bufferImageHeight = present.overlayExtent.height;
    panel.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    panel.imageOffset = {present.overlayOffset.x, present.overlayOffset.y, 0};
    panel.imageExtent = {panelWidth, panelHeight, 1};
    vkCmdCopyBufferToImage(cmd, present.overlay, present.image,
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &panel);
    lastStage = VK_PIPELINE_STAGE_2_COPY_BIT;
  }

  // The presentation engine waits for the submission's semaphore, which orders it after this.
  const VkImageMemoryBarrier2 toPresent =
      imageBarrier(present.image, VK_IMAGE_ASPECT_COLOR_BIT, lastStage,
                   VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
  VkDependencyInfo after{};
  after.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  after.imageMemoryBarrierCount = 1;
  after.pImageMemoryBarriers = &toPresent;
  vkCmdPipelineBarrier2(cmd, &after);
}

}  // namespace pbdam::gpu
