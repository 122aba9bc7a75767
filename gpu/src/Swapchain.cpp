#include "pbdam/gpu/Swapchain.h"

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

#include <algorithm>
#include <array>
#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

VkPresentModeKHR vulkanMode(PresentMode mode) {
  switch (mode) {
    case PresentMode::Mailbox:
      return VK_PRESENT_MODE_MAILBOX_KHR;
    case PresentMode::Immediate:
      return VK_PRESENT_MODE_IMMEDIATE_KHR;
    case PresentMode::Fifo:
      break;
  }
  return VK_PRESENT_MODE_FIFO_KHR;
}

bool blitsTo(VkPhysicalDevice physical, VkFormat format) {
  VkFormatProperties properties{};
  vkGetPhysicalDeviceFormatProperties(physical, format, &properties);
  return (properties.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT) != 0;
}

}  // namespace

std::optional<PresentMode> parsePresentMode(std::string_view text) {
  if (text == "fifo") return PresentMode::Fifo;
  if (text == "mailbox") return PresentMode::Mailbox;
  if (text == "immediate") return PresentMode::Immediate;
  return std::nullopt;
}

const char* toString(PresentMode mode) noexcept {
  switch (mode) {
    case PresentMode::Mailbox:
      return "mailbox";
    case PresentMode::Immediate:
      return "immediate";
    case PresentMode::Fifo:
      break;
  }
  return "fifo";
}

Result<Swapchain> Swapchain::create(VulkanContext& context, std::uint32_t width,
                                    std::uint32_t height, PresentMode mode) {
  if (context.surface() == VK_NULL_HANDLE) {
    return makeError(ErrorCode::InvalidArgument, "a swapchain needs a context with a window");
  }
  Swapchain swapchain;
  swapchain.context_ = &context;
  swapchain.wanted_ = mode;
  if (Result<void> r = swapchain.build(width, height); !r) return std::move(r).error();
  return swapchain;
}

Result<void> Swapchain::recreate(std::uint32_t width, std::uint32_t height) {
  if (Result<void> r = context_->waitIdle(); !r) return r;
  return build(width, height);
}

Result<void> Swapchain::build(std::uint32_t width, std::uint32_t height) {
  if (width == 0 || height == 0) {
    return makeError(ErrorCode::InvalidArgument, "a swapchain of " + std::to_string(width) + "x" +
                                                     std::to_string(height) + " pixels");
  }
  VkPhysicalDevice physical = context_->physicalDevice();
  VkSurfaceKHR surface = context_->surface();
  VkSurfaceCapabilitiesKHR caps{};
  if (VkResult r = vkGetPhysicalDeviceSurfaceCapabilitiesKHR(physical, surface, &caps);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
  }
  if ((caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT) == 0) {
    return makeError(ErrorCode::DeviceError,
                     "the window's surface takes no transfer writes (VK_IMAGE_USAGE_TRANSFER_DST)");
  }

  std::uint32_t formatCount = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface, &formatCount, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(formatCount);
  vkGetPhysicalDeviceSurfaceFormatsKHR(physical, surface, &formatCount, formats.data());
  std::optional<VkSurfaceFormatKHR> chosen;
  // UNORM, as the offscreen target is: the window shows the bytes a frame's PNG holds.
  for (VkFormat wanted : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM}) {
    for (const VkSurfaceFormatKHR& format : formats) {
      if (!chosen && format.format == wanted &&
          format.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR && blitsTo(physical, wanted)) {
        chosen = format;
      }
    }
  }
  if (!chosen) {
    return makeError(ErrorCode::DeviceError,
                     "the window's surface offers neither B8G8R8A8_UNORM nor R8G8B8A8_UNORM "
                     "with blits (" +
                         std::to_string(formatCount) + " formats)");
  }

  std::uint32_t modeCount = 0;
  vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface, &modeCount, nullptr);
  std::vector<VkPresentModeKHR> modes(modeCount);
  vkGetPhysicalDeviceSurfacePresentModesKHR(physical, surface, &modeCount, modes.data());
  mode_ = std::find(modes.begin(), modes.end(), vulkanMode(wanted_)) != modes.end()
              ? wanted_
              : PresentMode::Fifo;

  VkExtent2D extent = caps.currentExtent;
  if (extent.width == 0xFFFFFFFFu) {
    extent.width = std::clamp(width, caps.minImageExtent.width, caps.maxImageExtent.width);
    extent.height = std::clamp(height, caps.minImageExtent.height, caps.maxImageExtent.height);
  }
  if (extent.width == 0 || extent.height == 0) {
    return makeError(ErrorCode::InvalidArgument, "the window has no area (minimised)");
  }
  std::uint32_t imageCount = caps.minImageCount + 1;
  if (caps.maxImageCount != 0) imageCount = std::min(imageCount, caps.maxImageCount);

  VkSwapchainCreateInfoKHR create{};
  create.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
  create.surface = surface;
  create.minImageCount = imageCount;
  create.imageFormat = chosen->format;
  create.imageColorSpace = chosen->colorSpace;
  create.imageExtent = extent;
  create.imageArrayLayers = 1;
  create.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  create.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  create.preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR) != 0
                            ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                            : caps.currentTransform;
  create.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  for (VkCompositeAlphaFlagBitsKHR alpha :
       {VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR, VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR,
        VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR}) {
    if ((caps.supportedCompositeAlpha & static_cast<VkCompositeAlphaFlagsKHR>(alpha)) != 0) {
      create.compositeAlpha = alpha;
      break;
    }
  }
  create.presentMode = vulkanMode(mode_);
  create.clipped = VK_TRUE;
  create.oldSwapchain = swapchain_.get();
  VkDevice device = context_->device();
  VkSwapchainKHR raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateSwapchainKHR(device, &create, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateSwapchainKHR");
  }
  swapchain_ = UniqueSwapchain(device, raw);
  std::uint32_t count = 0;
  vkGetSwapchainImagesKHR(device, raw, &count, nullptr);
  images_.assign(count, VK_NULL_HANDLE);
  vkGetSwapchainImagesKHR(device, raw, &count, images_.data());
  rendered_.clear();
  for (std::uint32_t i = 0; i < count; ++i) {
    VkSemaphoreCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    VkSemaphore semaphore = VK_NULL_HANDLE;
    if (VkResult r = vkCreateSemaphore(device, &info, nullptr, &semaphore); r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateSemaphore (swapchain)");
    }
    rendered_.emplace_back(device, semaphore);
  }
  extent_ = extent;
  format_ = chosen->format;
  return {};
}

Result<std::optional<AcquiredImage>> Swapchain::acquire(VkSemaphore acquired,
                                                        std::uint64_t timeoutNanoseconds) {
  std::uint32_t index = 0;
  const VkResult r = vkAcquireNextImageKHR(context_->device(), swapchain_.get(), timeoutNanoseconds,
                                           acquired, VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) return std::optional<AcquiredImage>();
  if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) return vulkanError(r, "vkAcquireNextImageKHR");
  AcquiredImage image;
  image.image = images_[index];
  image.extent = extent_;
  image.format = format_;
  image.index = index;
  image.acquired = acquired;
  image.rendered = rendered_[index].get();
  return std::optional<AcquiredImage>(image);
}

Result<bool> Swapchain::present(const AcquiredImage& image) {
  VkSwapchainKHR swapchain = swapchain_.get();
  VkPresentInfoKHR info{};
  info.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
  info.waitSemaphoreCount = 1;
  info.pWaitSemaphores = &image.rendered;
  info.swapchainCount = 1;
  info.pSwapchains = &swapchain;
  info.pImageIndices = &image.index;
  const VkResult r = context_->present(info);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) return false;
  if (r != VK_SUCCESS) return vulkanError(r, "vkQueuePresentKHR");
  return true;
}

}  // namespace pbdam::gpu
