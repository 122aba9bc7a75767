// OffscreenTarget: colour + reversed-Z depth attachments, dynamic rendering, readback.
#include "pbdam/gpu/OffscreenTarget.h"

#include <glm/gtc/packing.hpp>

#include "ToneMapPass.h"
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

/// Records one image barrier.
void barrier(VkCommandBuffer cmd, const VkImageMemoryBarrier2& image) {
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.imageMemoryBarrierCount = 1;
  dependency.pImageMemoryBarriers = &image;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

/// Records a copy of `image` (TRANSFER_SRC) into `buffer`, made visible to host reads.
void copyToHost(VkCommandBuffer cmd, VkImage image, VkExtent2D extent, VkBuffer buffer) {
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent.width, extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &region);
  VkBufferMemoryBarrier2 toHost{};
  toHost.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2;
  toHost.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  toHost.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toHost.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
  toHost.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
  toHost.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toHost.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toHost.buffer = buffer;
  toHost.size = VK_WHOLE_SIZE;
  VkDependencyInfo after{};
  after.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  after.bufferMemoryBarrierCount = 1;
  after.pBufferMemoryBarriers = &toHost;
  vkCmdPipelineBarrier2(cmd, &after);
}

}  // namespace

Result<void> OffscreenTarget::createRadiance(const VulkanContext& context,
                                             const ToneMapPass& toneMap) {
  const std::string size = std::to_string(widthPixels()) + "x" + std::to_string(heightPixels());
  ImageDesc desc = color_.desc();
  desc.format = kRadianceFormat;
  desc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
               VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  Result<GpuImage> image = createImage2D(context, desc, "offscreen radiance " + size);
  if (!image) return std::move(image).error();
  radiance_ = std::move(*image);
  const VkDeviceSize bytes = VkDeviceSize{8} * widthPixels() * heightPixels();
  Result<GpuBuffer> staging = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                           MemoryUse::HostReadback, "radiance readback " + size);
  if (!staging) return std::move(staging).error();
  radianceStaging_ = std::move(*staging);

  VkDevice device = context.device();
  const VkDescriptorPoolSize poolSize{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1};
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &poolSize;
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(device, &poolInfo, nullptr, &rawPool); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (tone map)");
  }
  toneMapPool_ = UniqueDescriptorPool(device, rawPool);
  VkDescriptorSetLayout layout = toneMap.setLayout();
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &layout;
  if (VkResult r = vkAllocateDescriptorSets(device, &allocate, &toneMapSet_); r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (tone map)");
  }
  const VkDescriptorImageInfo imageInfo{toneMap.sampler(), radiance_.view(),
                                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = toneMapSet_;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  write.pImageInfo = &imageInfo;
  vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);
  toneMap_ = &toneMap;
  return {};
}

Result<OffscreenTarget> OffscreenTarget::create(const VulkanContext& context, uint32_t widthPixels,
                                                uint32_t heightPixels, const ToneMapPass* toneMap) {
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
  if (toneMap != nullptr) {
    if (Result<void> r = target.createRadiance(context, *toneMap); !r) {
      return std::move(r).error();
    }
  }
  return target;
}

void OffscreenTarget::recordBeginRendering(VkCommandBuffer cmd,
                                           const std::array<float, 4>& clearRgba, float clearDepth,
                                           bool keepDepth, bool radiance) const {
  // Old contents are discarded (UNDEFINED); the source scopes cover the previous frame's
  // attachment writes, tone map read and readback copy (write-after-write / write-after-read).
  const GpuImage& colour = radiance ? radiance_ : color_;
  const std::array<VkImageMemoryBarrier2, 2> barriers = {
      imageBarrier(colour.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT |
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
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

  beginRendering(cmd, VK_ATTACHMENT_LOAD_OP_CLEAR, clearRgba, clearDepth, keepDepth, radiance);
}

void OffscreenTarget::recordResumeRendering(VkCommandBuffer cmd, bool keepDepth,
                                            bool radiance) const {
  // Same layouts: a memory dependency from the previous pass's attachment writes to this one's
  // loads and writes.
  const GpuImage& colour = radiance ? radiance_ : color_;
  const std::array<VkImageMemoryBarrier2, 2> barriers = {
      imageBarrier(
          colour.image(), VK_IMAGE_ASPECT_COLOR_BIT,
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
  beginRendering(cmd, VK_ATTACHMENT_LOAD_OP_LOAD, {0.0f, 0.0f, 0.0f, 0.0f}, kFarDepth, keepDepth,
                 radiance);
}

void OffscreenTarget::beginRendering(VkCommandBuffer cmd, VkAttachmentLoadOp loadOp,
                                     const std::array<float, 4>& clearRgba, float clearDepth,
                                     bool keepDepth, bool radiance) const {
  VkRenderingAttachmentInfo colorAttachment{};
  colorAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  colorAttachment.imageView = radiance ? radiance_.view() : color_.view();
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

void OffscreenTarget::recordToneMap(VkCommandBuffer cmd, float exposure) const {
  barrier(cmd, imageBarrier(
                   radiance_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                   VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL));
  // The colour image's old contents are discarded, after the previous frame's readback or
  // window copy has read them.
  barrier(cmd, imageBarrier(color_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT |
                                VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT,
                            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL));
  VkRenderingAttachmentInfo colorAttachment{};
  colorAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  colorAttachment.imageView = color_.view();
  colorAttachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  colorAttachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  rendering.renderArea = {{0, 0}, extent()};
  rendering.layerCount = 1;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachments = &colorAttachment;
  vkCmdBeginRendering(cmd, &rendering);
  VkViewport viewport{};
  viewport.width = static_cast<float>(widthPixels());
  viewport.height = static_cast<float>(heightPixels());
  viewport.maxDepth = 1.0f;
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  const VkRect2D scissor{{0, 0}, extent()};
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, toneMap_->pipeline());
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, toneMap_->layout(), 0, 1,
                          &toneMapSet_, 0, nullptr);
  vkCmdPushConstants(cmd, toneMap_->layout(), VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof exposure,
                     &exposure);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  vkCmdEndRendering(cmd);
}

void OffscreenTarget::recordRadianceReadback(VkCommandBuffer cmd) const {
  barrier(cmd, imageBarrier(radiance_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                            VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                            VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL));
  copyToHost(cmd, radiance_.image(), extent(), radianceStaging_.buffer());
}

Result<std::vector<float>> OffscreenTarget::readRadiance() const {
  if (!radiance_) {
    return makeError(ErrorCode::InvalidArgument, "the target keeps no radiance (no tone map)");
  }
  if (Result<void> r = radianceStaging_.invalidateForHostRead(); !r) return std::move(r).error();
  const std::size_t pixels = std::size_t{widthPixels()} * heightPixels();
  std::vector<float> rgb(pixels * 3);
  const std::byte* bytes = radianceStaging_.mappedBytes().data();
  for (std::size_t i = 0; i < pixels; ++i) {
    std::uint64_t packed = 0;
    std::memcpy(&packed, bytes + i * 8, 8);
    const glm::vec4 v = glm::unpackHalf4x16(packed);
    rgb[i * 3] = v.x;
    rgb[i * 3 + 1] = v.y;
    rgb[i * 3 + 2] = v.z;
  }
  return rgb;
}

void OffscreenTarget::recordEndRenderingAndReadback(VkCommandBuffer cmd) const {
  vkCmdEndRendering(cmd);
  recordReadback(cmd);
}

void OffscreenTarget::recordReadback(VkCommandBuffer cmd) const {
  barrier(cmd, imageBarrier(color_.image(), VK_IMAGE_ASPECT_COLOR_BIT,
                            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                            VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                            VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL));
  copyToHost(cmd, color_.image(), extent(), staging_.buffer());
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
