// Minimal device-memory helpers: choosing a memory type, and buffers/images that own their
// VkDeviceMemory (one allocation each — fine for render targets and staging; the patch pool
// will sub-allocate). Debian 12 ships no Vulkan Memory Allocator package, hence no VMA.
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

namespace pbdam::gpu {

class VulkanContext;

/// The index of a memory type allowed by `allowedTypeBits` (VkMemoryRequirements::
/// memoryTypeBits) that has all `required` property flags, preferring one that also has all
/// `preferred` flags; nullopt if none qualifies. Thread-safe.
std::optional<uint32_t> findMemoryType(const VkPhysicalDeviceMemoryProperties& properties,
                                       uint32_t allowedTypeBits, VkMemoryPropertyFlags required,
                                       VkMemoryPropertyFlags preferred = 0) noexcept;

/// Where a buffer's memory lives and how the host uses it.
enum class MemoryUse {
  DeviceLocal,   ///< GPU-only (vertex/index pools, textures)
  HostUpload,    ///< host-visible, written by the CPU, read by the GPU (staging uploads)
  HostReadback,  ///< host-visible, written by the GPU, read by the CPU (cached if possible)
};

/// A VkBuffer with its own memory, persistently mapped when host-visible. Move-only; a
/// moved-from buffer is empty. Must be destroyed before the VulkanContext and only after the
/// GPU has finished with it. Thread-safety: none; externally synchronised like a VkBuffer.
class GpuBuffer final {
 public:
  GpuBuffer() noexcept = default;
  /// Takes over `other`'s buffer and memory, leaving it empty.
  /// @{
  GpuBuffer(GpuBuffer&& other) noexcept;
  GpuBuffer& operator=(GpuBuffer&& other) noexcept;
  /// @}
  GpuBuffer(const GpuBuffer&) = delete;
  GpuBuffer& operator=(const GpuBuffer&) = delete;
  ~GpuBuffer() = default;  // members: the buffer is destroyed before its memory

  /// The buffer (VK_NULL_HANDLE when empty); ownership stays here.
  VkBuffer buffer() const noexcept { return buffer_.get(); }
  /// The memory bound to it; ownership stays here.
  VkDeviceMemory memory() const noexcept { return memory_.get(); }
  /// The buffer's size.
  VkDeviceSize sizeBytes() const noexcept { return sizeBytes_; }
  /// Whether it holds a buffer.
  explicit operator bool() const noexcept { return static_cast<bool>(buffer_); }

  /// The mapped bytes (sizeBytes() of them); empty unless the memory is host-visible.
  std::span<std::byte> mappedBytes() const noexcept { return mapped_; }
  /// Whether host writes/reads need no flush/invalidate.
  bool hostCoherent() const noexcept { return hostCoherent_; }
  /// Makes GPU writes visible to the host (vkInvalidateMappedMemoryRanges; no-op if coherent).
  /// Call after the GPU work and its host-visibility barrier have completed.
  formats::Result<void> invalidateForHostRead() const;
  /// Makes host writes visible to the GPU (vkFlushMappedMemoryRanges; no-op if coherent).
  formats::Result<void> flushHostWrites() const;

 private:
  friend formats::Result<GpuBuffer> createBuffer(const VulkanContext&, VkDeviceSize,
                                                 VkBufferUsageFlags, MemoryUse, const std::string&);
  void swap(GpuBuffer& other) noexcept;

  UniqueDeviceMemory memory_;  // declared first: destroyed last
  UniqueBuffer buffer_;
  VkDeviceSize sizeBytes_ = 0;
  std::span<std::byte> mapped_;
  bool hostCoherent_ = false;
};

/// Creates a buffer of `sizeBytes` with `usage`, allocates memory for `use`, binds it and maps
/// it if host-visible. `debugName` names the buffer in messages. Errors: DeviceError (memory
/// type missing, allocation failure, ...), InvalidArgument for a zero size.
formats::Result<GpuBuffer> createBuffer(const VulkanContext& context, VkDeviceSize sizeBytes,
                                        VkBufferUsageFlags usage, MemoryUse use,
                                        const std::string& debugName);

/// What createImage2D makes: a single-mip, optimal-tiling 2D image, or a 2D array of
/// `arrayLayers` layers (viewed as VK_IMAGE_VIEW_TYPE_2D_ARRAY when `arrayView` is set).
struct ImageDesc final {
  VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;             ///< the texel format
  uint32_t widthPixels = 0;                               ///< the image's size
  uint32_t heightPixels = 0;                              ///< the image's size
  VkImageUsageFlags usage = 0;                            ///< what it will be used for
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;  ///< for the view
  uint32_t arrayLayers = 1;                               ///< 1 for a plain 2D image
  bool arrayView = false;  ///< view type 2D_ARRAY (required for sampler2DArray)
};

/// A 2D VkImage with its own device-local memory and a view of the whole image. Move-only; a
/// moved-from image is empty. Created in VK_IMAGE_LAYOUT_UNDEFINED; the user tracks layouts.
/// Thread-safety: none; externally synchronised like a VkImage.
class GpuImage final {
 public:
  GpuImage() noexcept = default;
  /// Takes over `other`'s image, view and memory, leaving it empty.
  /// @{
  GpuImage(GpuImage&& other) noexcept;
  GpuImage& operator=(GpuImage&& other) noexcept;
  /// @}
  GpuImage(const GpuImage&) = delete;
  GpuImage& operator=(const GpuImage&) = delete;
  ~GpuImage() = default;  // members: view, then image, then memory

  /// The image (VK_NULL_HANDLE when empty); ownership stays here.
  VkImage image() const noexcept { return image_.get(); }
  /// The view of the whole image; ownership stays here.
  VkImageView view() const noexcept { return view_.get(); }
  /// What it was created as.
  const ImageDesc& desc() const noexcept { return desc_; }
  /// Its size in pixels.
  VkExtent2D extent() const noexcept { return {desc_.widthPixels, desc_.heightPixels}; }
  /// Whether it holds an image.
  explicit operator bool() const noexcept { return static_cast<bool>(image_); }

 private:
  friend formats::Result<GpuImage> createImage2D(const VulkanContext&, const ImageDesc&,
                                                 const std::string&);
  void swap(GpuImage& other) noexcept;

  UniqueDeviceMemory memory_;
  UniqueImage image_;
  UniqueImageView view_;
  ImageDesc desc_;
};

/// Creates the image described by `desc` in device-local memory, and its view of all layers.
/// Errors: InvalidArgument for a zero or too-large size or layer count, DeviceError for Vulkan
/// failures (including a format the device cannot use this way, VK_ERROR_FORMAT_NOT_SUPPORTED).
formats::Result<GpuImage> createImage2D(const VulkanContext& context, const ImageDesc& desc,
                                        const std::string& debugName);

}  // namespace pbdam::gpu
