// Memory-type selection and self-owning buffers/images.
#include "pbdam/gpu/GpuMemory.h"

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

#include <utility>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

struct MemoryFlags {
  VkMemoryPropertyFlags required;
  VkMemoryPropertyFlags preferred;
};

MemoryFlags flagsFor(MemoryUse use) noexcept {
  switch (use) {
    case MemoryUse::HostUpload:
      return {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, VK_MEMORY_PROPERTY_HOST_COHERENT_BIT};
    case MemoryUse::HostReadback:
      return {VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
              VK_MEMORY_PROPERTY_HOST_CACHED_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT};
    case MemoryUse::DeviceLocal:
    default:
      return {VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0};
  }
}

Result<UniqueDeviceMemory> allocate(const VulkanContext& context,
                                    const VkMemoryRequirements& requirements, MemoryFlags flags,
                                    const std::string& debugName, uint32_t& typeIndexOut) {
  const std::optional<uint32_t> type = findMemoryType(
      context.memoryProperties(), requirements.memoryTypeBits, flags.required, flags.preferred);
  if (!type) {
    return makeError(ErrorCode::DeviceError,
                     "no Vulkan memory type for " + debugName + " (allowed type bits " +
                         std::to_string(requirements.memoryTypeBits) + ", required flags " +
                         std::to_string(flags.required) + ") on " + context.deviceInfo().name);
  }
  VkMemoryAllocateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  info.allocationSize = requirements.size;
  info.memoryTypeIndex = *type;
  VkDeviceMemory raw = VK_NULL_HANDLE;
  if (VkResult r = vkAllocateMemory(context.device(), &info, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(
        r, "vkAllocateMemory (" + debugName + ", " + std::to_string(requirements.size) + " bytes)");
  }
  typeIndexOut = *type;
  return UniqueDeviceMemory(context.device(), raw);
}

}  // namespace

std::optional<uint32_t> findMemoryType(const VkPhysicalDeviceMemoryProperties& properties,
                                       uint32_t allowedTypeBits, VkMemoryPropertyFlags required,
                                       VkMemoryPropertyFlags preferred) noexcept {
  std::optional<uint32_t> fallback;
  for (uint32_t i = 0; i < properties.memoryTypeCount; ++i) {
    if ((allowedTypeBits & (1u << i)) == 0) continue;
    const VkMemoryPropertyFlags flags = properties.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (!fallback) fallback = i;
  }
  return fallback;
}

GpuBuffer::GpuBuffer(GpuBuffer&& other) noexcept { swap(other); }

GpuBuffer& GpuBuffer::operator=(GpuBuffer&& other) noexcept {
  if (this != &other) {
    GpuBuffer old(std::move(other));  // `old` takes other's state ...
    swap(old);                        // ... we take it, and `old` destroys ours in order
  }
  return *this;
}

void GpuBuffer::swap(GpuBuffer& other) noexcept {
  std::swap(memory_, other.memory_);
  std::swap(buffer_, other.buffer_);
  std::swap(sizeBytes_, other.sizeBytes_);
  std::swap(mapped_, other.mapped_);
  std::swap(hostCoherent_, other.hostCoherent_);
}

Result<void> GpuBuffer::invalidateForHostRead() const {
  if (hostCoherent_ || mapped_.empty()) return {};
  VkMappedMemoryRange range{};
  range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
  range.memory = memory_.get();
  range.offset = 0;
  range.size = VK_WHOLE_SIZE;
  if (VkResult r = vkInvalidateMappedMemoryRanges(memory_.parent(), 1, &range); r != VK_SUCCESS) {
    return vulkanError(r, "vkInvalidateMappedMemoryRanges");
  }
  return {};
}

Result<void> GpuBuffer::flushHostWrites() const {
  if (hostCoherent_ || mapped_.empty()) return {};
  VkMappedMemoryRange range{};
  range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
  range.memory = memory_.get();
  range.offset = 0;
  range.size = VK_WHOLE_SIZE;
  if (VkResult r = vkFlushMappedMemoryRanges(memory_.parent(), 1, &range); r != VK_SUCCESS) {
    return vulkanError(r, "vkFlushMappedMemoryRanges");
  }
  return {};
}

Result<GpuBuffer> createBuffer(const VulkanContext& context, VkDeviceSize sizeBytes,
                               VkBufferUsageFlags usage, MemoryUse use,
                               const std::string& debugName) {
  if (sizeBytes == 0) {
    return makeError(ErrorCode::InvalidArgument, "buffer " + debugName + " has size 0");
  }
  VkDevice device = context.device();
  VkBufferCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  info.size = sizeBytes;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkBuffer rawBuffer = VK_NULL_HANDLE;
  if (VkResult r = vkCreateBuffer(device, &info, nullptr, &rawBuffer); r != VK_SUCCESS) {
    return vulkanError(
        r, "vkCreateBuffer (" + debugName + ", " + std::to_string(sizeBytes) + " bytes)");
  }
  GpuBuffer result;
  result.buffer_ = UniqueBuffer(device, rawBuffer);
  result.sizeBytes_ = sizeBytes;
  context.setObjectName(VK_OBJECT_TYPE_BUFFER, rawBuffer, debugName.c_str());

  VkMemoryRequirements requirements{};
  vkGetBufferMemoryRequirements(device, rawBuffer, &requirements);
  uint32_t typeIndex = 0;
  Result<UniqueDeviceMemory> memory =
      allocate(context, requirements, flagsFor(use), debugName, typeIndex);
  if (!memory) return std::move(memory).error();
  result.memory_ = std::move(*memory);
  if (VkResult r = vkBindBufferMemory(device, rawBuffer, result.memory_.get(), 0);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkBindBufferMemory (" + debugName + ")");
  }

  const VkMemoryPropertyFlags flags =
      context.memoryProperties().memoryTypes[typeIndex].propertyFlags;
  if ((flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) != 0) {
    void* mapped = nullptr;
    if (VkResult r = vkMapMemory(device, result.memory_.get(), 0, VK_WHOLE_SIZE, 0, &mapped);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkMapMemory (" + debugName + ")");
    }
    // Unmapped implicitly when the memory is freed.
    result.mapped_ =
        std::span<std::byte>(static_cast<std::byte*>(mapped), static_cast<std::size_t>(sizeBytes));
    result.hostCoherent_ = (flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
  }
  return result;
}

GpuImage::GpuImage(GpuImage&& other) noexcept { swap(other); }

GpuImage& GpuImage::operator=(GpuImage&& other) noexcept {
  if (this != &other) {
    GpuImage old(std::move(other));
    swap(old);
  }
  return *this;
}

void GpuImage::swap(GpuImage& other) noexcept {
  std::swap(memory_, other.memory_);
  std::swap(image_, other.image_);
  std::swap(view_, other.view_);
  std::swap(desc_, other.desc_);
}

Result<GpuImage> createImage2D(const VulkanContext& context, const ImageDesc& desc,
                               const std::string& debugName) {
  if (desc.widthPixels == 0 || desc.heightPixels == 0) {
    return makeError(ErrorCode::InvalidArgument, "image " + debugName + " has size " +
                                                     std::to_string(desc.widthPixels) + "x" +
                                                     std::to_string(desc.heightPixels));
  }
  VkImageFormatProperties formatProperties{};
  if (VkResult r = vkGetPhysicalDeviceImageFormatProperties(
          context.physicalDevice(), desc.format, VK_IMAGE_TYPE_2D, VK_IMAGE_TILING_OPTIMAL,
          desc.usage, 0, &formatProperties);
      r != VK_SUCCESS) {
    return vulkanError(r, "image " + debugName + ": format " +
                              std::to_string(static_cast<int>(desc.format)) + " with usage flags " +
                              std::to_string(desc.usage));
  }
  if (desc.arrayLayers == 0 || desc.arrayLayers > formatProperties.maxArrayLayers) {
    return makeError(ErrorCode::InvalidArgument,
                     "image " + debugName + " has " + std::to_string(desc.arrayLayers) +
                         " layers; the device allows 1.." +
                         std::to_string(formatProperties.maxArrayLayers));
  }
  if (desc.widthPixels > formatProperties.maxExtent.width ||
      desc.heightPixels > formatProperties.maxExtent.height) {
    return makeError(ErrorCode::InvalidArgument,
                     "image " + debugName + " is " + std::to_string(desc.widthPixels) + "x" +
                         std::to_string(desc.heightPixels) + " pixels; the device allows " +
                         std::to_string(formatProperties.maxExtent.width) + "x" +
                         std::to_string(formatProperties.maxExtent.height));
  }

  VkDevice device = context.device();
  VkImageCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = desc.format;
  info.extent = {desc.widthPixels, desc.heightPixels, 1};
  info.mipLevels = 1;
  info.arrayLayers = desc.arrayLayers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = desc.usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImage rawImage = VK_NULL_HANDLE;
  if (VkResult r = vkCreateImage(device, &info, nullptr, &rawImage); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateImage (" + debugName + ")");
  }
  GpuImage result;
  result.image_ = UniqueImage(device, rawImage);
  result.desc_ = desc;
  context.setObjectName(VK_OBJECT_TYPE_IMAGE, rawImage, debugName.c_str());

  VkMemoryRequirements requirements{};
  vkGetImageMemoryRequirements(device, rawImage, &requirements);
  uint32_t typeIndex = 0;
  Result<UniqueDeviceMemory> memory =
      allocate(context, requirements, flagsFor(MemoryUse::DeviceLocal), debugName, typeIndex);
  if (!memory) return std::move(memory).error();
  result.memory_ = std::move(*memory);
  if (VkResult r = vkBindImageMemory(device, rawImage, result.memory_.get(), 0); r != VK_SUCCESS) {
    return vulkanError(r, "vkBindImageMemory (" + debugName + ")");
  }

  VkImageViewCreateInfo viewInfo{};
  viewInfo.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
  viewInfo.image = rawImage;
  viewInfo.viewType = desc.arrayView ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
  viewInfo.format = desc.format;
  viewInfo.subresourceRange = {desc.aspect, 0, 1, 0, desc.arrayLayers};
  VkImageView rawView = VK_NULL_HANDLE;
  if (VkResult r = vkCreateImageView(device, &viewInfo, nullptr, &rawView); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateImageView (" + debugName + ")");
  }
  result.view_ = UniqueImageView(device, rawView);
  return result;
}

}  // namespace pbdam::gpu
