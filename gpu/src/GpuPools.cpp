// GPU-resident patch and tile pools (GpuPools.h).
#include "GpuPools.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <string>
#include <vector>

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"
#include "pbdam/streaming/DecodeScheduler.h"

using namespace pbdam::formats;

namespace pbdam::gpu {

PatchPool::PatchPool(std::uint32_t maxVertices, std::uint32_t maxIndices,
                     std::uint32_t capacitySlots, std::uint32_t slotsPerChunk) noexcept
    : maxVertices_(maxVertices),
      maxIndices_(maxIndices),
      capacitySlots_(capacitySlots),
      slotsPerChunk_(std::max<std::uint32_t>(1, slotsPerChunk)) {}

Result<void> PatchPool::ensureSlots(const VulkanContext& context, std::uint32_t slotCount) {
  assert(slotCount <= capacitySlots_);
  while (static_cast<std::uint64_t>(chunks_.size()) * slotsPerChunk_ < slotCount) {
    const auto first = static_cast<std::uint32_t>(chunks_.size()) * slotsPerChunk_;
    const std::uint32_t slots = std::min(slotsPerChunk_, capacitySlots_ - first);
    const std::string name = "patch pool chunk " + std::to_string(chunks_.size());
    const VkDeviceSize vertexBytes =
        VkDeviceSize{sizeof(streaming::PatchGpuVertex)} * maxVertices_ * slots;
    const VkDeviceSize indexBytes = VkDeviceSize{2} * maxIndices_ * slots;
    Chunk chunk;
    auto vertices = createBuffer(
        context, vertexBytes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
        MemoryUse::DeviceLocal, name + " vertices");
    if (!vertices) return std::move(vertices).error();
    chunk.vertices = std::move(*vertices);
    auto indices = createBuffer(context, indexBytes,
                                VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUse::DeviceLocal, name + " indices");
    if (!indices) return std::move(indices).error();
    chunk.indices = std::move(*indices);
    chunks_.push_back(std::move(chunk));
    allocatedBytes_ += vertexBytes + indexBytes;
  }
  return {};
}

Result<TilePool> TilePool::create(const VulkanContext& context, const TileFormats& formats,
                                  std::uint64_t slotBytes, std::uint32_t capacitySlots,
                                  std::uint32_t layersPerPage, VkDescriptorSetLayout setLayout,
                                  VkSampler sampler) {
  TilePool pool;
  pool.formats_ = formats;
  pool.slotBytes_ = slotBytes;
  pool.capacitySlots_ = capacitySlots;
  pool.layersPerPage_ = std::max<std::uint32_t>(1, layersPerPage);
  pool.setLayout_ = setLayout;
  pool.sampler_ = sampler;
  const std::uint32_t maxPages =
      std::max<std::uint32_t>(1, (capacitySlots + pool.layersPerPage_ - 1) / pool.layersPerPage_);
  VkDescriptorPoolSize size{};
  size.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  size.descriptorCount = 2 * maxPages;
  VkDescriptorPoolCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  info.maxSets = maxPages;
  info.poolSizeCount = 1;
  info.pPoolSizes = &size;
  VkDescriptorPool raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(context.device(), &info, nullptr, &raw);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (tile pages)");
  }
  pool.descriptorPool_ = UniqueDescriptorPool(context.device(), raw);
  return pool;
}

Result<void> TilePool::ensureSlots(VulkanContext& context, std::uint32_t slotCount) {
  assert(slotCount <= capacitySlots_);
  const std::size_t firstNew = pages_.size();
  while (static_cast<std::uint64_t>(pages_.size()) * layersPerPage_ < slotCount) {
    const auto first = static_cast<std::uint32_t>(pages_.size()) * layersPerPage_;
    const std::uint32_t layers = std::min(layersPerPage_, capacitySlots_ - first);
    ImageDesc desc;
    desc.format = formats_.colour;
    desc.widthPixels = formats_.colourTexels;
    desc.heightPixels = formats_.colourTexels;
    desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    desc.aspect = VK_IMAGE_ASPECT_COLOR_BIT;
    desc.arrayLayers = layers;
    desc.arrayView = true;
    auto image = createImage2D(context, desc, "tile page " + std::to_string(pages_.size()));
    if (!image) return std::move(image).error();
    desc.format = formats_.normal;
    desc.widthPixels = formats_.normalTexels;
    desc.heightPixels = formats_.normalTexels;
    auto normalImage =
        createImage2D(context, desc, "normal-map page " + std::to_string(pages_.size()));
    if (!normalImage) return std::move(normalImage).error();
    Page page;
    page.image = std::move(*image);
    page.normalImage = std::move(*normalImage);

    VkDescriptorSetAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    allocate.descriptorPool = descriptorPool_.get();
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &setLayout_;
    if (VkResult r = vkAllocateDescriptorSets(context.device(), &allocate, &page.set);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkAllocateDescriptorSets (tile page)");
    }
    std::array<VkDescriptorImageInfo, 2> imageInfo{};
    std::array<VkWriteDescriptorSet, 2> writes{};
    for (std::uint32_t b = 0; b < 2; ++b) {
      imageInfo[b].sampler = sampler_;
      imageInfo[b].imageView = b == 0 ? page.image.view() : page.normalImage.view();
      imageInfo[b].imageLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
      writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[b].dstSet = page.set;
      writes[b].dstBinding = b;
      writes[b].descriptorCount = 1;
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
      writes[b].pImageInfo = &imageInfo[b];
    }
    vkUpdateDescriptorSets(context.device(), static_cast<std::uint32_t>(writes.size()),
                           writes.data(), 0, nullptr);
    pages_.push_back(std::move(page));
    allocatedBytes_ += slotBytes_ * layers;
  }
  if (pages_.size() == firstNew) return {};

  // Every layer of a new page goes to the sampling layout once; uploads then move single layers
  // to TRANSFER_DST and back.
  std::vector<VkImageMemoryBarrier2> barriers;
  std::vector<VkImage> images;
  for (std::size_t p = firstNew; p < pages_.size(); ++p) {
    images.push_back(pages_[p].image.image());
    images.push_back(pages_[p].normalImage.image());
  }
  for (VkImage image : images) {
    VkImageMemoryBarrier2 b{};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
    b.srcStageMask = VK_PIPELINE_STAGE_2_NONE;
    b.srcAccessMask = VK_ACCESS_2_NONE;
    b.dstStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT;
    b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
    barriers.push_back(b);
  }
  return context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        VkDependencyInfo dependency{};
        dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
        dependency.imageMemoryBarrierCount = static_cast<uint32_t>(barriers.size());
        dependency.pImageMemoryBarriers = barriers.data();
        vkCmdPipelineBarrier2(cmd, &dependency);
      },
      "tile page layout");
}

}  // namespace pbdam::gpu
