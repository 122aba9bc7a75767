// A raster draped over the terrain: descriptor set 3 of the patch pipeline
// (SurfaceOverlayBinding.h).
#include "SurfaceOverlayBinding.h"

#include <array>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>

#include "ImageUpload.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

void copy3(float* to, const glm::dvec3& v, double w) {
  to[0] = static_cast<float>(v.x);
  to[1] = static_cast<float>(v.y);
  to[2] = static_cast<float>(v.z);
  to[3] = static_cast<float>(w);
}

}  // namespace

Result<SurfaceOverlayBinding> SurfaceOverlayBinding::create(VulkanContext& context,
                                                            const PatchPipeline& pipeline) {
  SurfaceOverlayBinding b;
  b.context_ = &context;
  b.sampler_ = pipeline.overlaySampler();
  VkDevice device = context.device();
  const std::array<VkDescriptorPoolSize, 2> sizes = {
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1},
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1}};
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
  poolInfo.pPoolSizes = sizes.data();
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(device, &poolInfo, nullptr, &rawPool); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (surface overlay)");
  }
  b.pool_ = UniqueDescriptorPool(device, rawPool);
  VkDescriptorSetLayout layout = pipeline.overlaySetLayout();
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &layout;
  if (VkResult r = vkAllocateDescriptorSets(device, &allocate, &b.set_); r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (surface overlay)");
  }
  auto block = createBuffer(context, sizeof(OverlayBlock), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                            MemoryUse::HostUpload, "surface overlay block");
  if (!block) return std::move(block).error();
  b.block_ = std::move(*block);
  VkDescriptorBufferInfo blockInfo{b.block_.buffer(), 0, sizeof(OverlayBlock)};
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = b.set_;
  write.dstBinding = 1;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  write.pBufferInfo = &blockInfo;
  vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);
  RgbaImage empty;
  empty.widthPixels = 1;
  empty.heightPixels = 1;
  empty.rgba.assign(4, 0);
  if (auto r = b.upload(empty); !r) return std::move(r).error();
  if (auto r = b.prepare(nullptr, runtime::Planet::mars(), glm::dvec3(0.0)); !r) {
    return std::move(r).error();
  }
  return b;
}

Result<void> SurfaceOverlayBinding::upload(const RgbaImage& image) {
  ImageDesc desc;
  desc.widthPixels = image.widthPixels;
  desc.heightPixels = image.heightPixels;
  desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  auto created = createImage2D(*context_, desc, "surface overlay");
  if (!created) return std::move(created).error();
  auto staging = createBuffer(*context_, image.rgba.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              MemoryUse::HostUpload, "surface overlay staging");
  if (!staging) return std::move(staging).error();
  std::memcpy(staging->mappedBytes().data(), image.rgba.data(), image.rgba.size());
  if (auto r = staging->flushHostWrites(); !r) return r;
  VkImage target = created->image();
  Result<void> copied = context_->submitAndWait(
      [&](VkCommandBuffer cmd) {
        recordBarrier(cmd, uploadLayoutBarrier(target, VK_IMAGE_LAYOUT_UNDEFINED,
                                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL));
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {image.widthPixels, image.heightPixels, 1};
        vkCmdCopyBufferToImage(cmd, staging->buffer(), target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               1, &region);
        recordBarrier(cmd, uploadLayoutBarrier(target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL));
      },
      "surface overlay upload");
  if (!copied) return copied;
  image_ = std::move(*created);
  writeImage();
  return {};
}

void SurfaceOverlayBinding::writeImage() {
  VkDescriptorImageInfo info{sampler_, image_.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = set_;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  write.pImageInfo = &info;
  vkUpdateDescriptorSets(context_->device(), 1, &write, 0, nullptr);
}

Result<void> SurfaceOverlayBinding::prepare(const std::shared_ptr<const SurfaceOverlay>& overlay,
                                            const runtime::Planet& planet,
                                            const glm::dvec3& cameraEcef) {
  OverlayBlock block{};
  if (overlay) {
    const RgbaImage& image = overlay->image;
    if (image.widthPixels == 0 || image.widthPixels != image.heightPixels ||
        image.rgba.size() != std::size_t{4} * image.widthPixels * image.heightPixels ||
        !(overlay->cellMeters > 0.0)) {
      return makeError(ErrorCode::InvalidArgument,
                       "surface overlay: a square image of RGBA cells and a cell size > 0");
    }
    if (overlay != bound_) {
      if (auto r = upload(image); !r) return r;
      bound_ = overlay;
    }
    const runtime::EnuFrame frame = planet.enuFrame(overlay->latDegrees, overlay->lonDegrees, 0.0);
    // Gaussian radius of curvature at the centre: exact on a sphere, within the ellipsoid's
    // spread of normal sections (a fraction of a per cent) elsewhere.
    const double a = planet.equatorialRadiusMeters();
    const double e2 = planet.flattening() * (2.0 - planet.flattening());
    const double s = std::sin(overlay->latDegrees * std::numbers::pi / 180.0);
    const double w2 = 1.0 - e2 * s * s;
    const double radius = a * std::sqrt(1.0 - e2) / w2;
    copy3(block.origin, frame.originEcef - cameraEcef, 1.0);
    copy3(block.east, frame.axes[0], radius);
    copy3(block.north, frame.axes[1], overlay->cellMeters);
    copy3(block.up, frame.axes[2], static_cast<double>(image.widthPixels));
  } else if (bound_) {
    // Back to the empty image, so that nothing holds the last overlay's memory.
    RgbaImage empty;
    empty.widthPixels = 1;
    empty.heightPixels = 1;
    empty.rgba.assign(4, 0);
    if (auto r = upload(empty); !r) return r;
    bound_.reset();
  }
  std::memcpy(block_.mappedBytes().data(), &block, sizeof block);
  return block_.flushHostWrites();
}

}  // namespace pbdam::gpu
