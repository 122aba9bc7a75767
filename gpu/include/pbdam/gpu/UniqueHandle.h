// UniqueHandle: a move-only owner of one Vulkan handle that destroys it with the matching
// vkDestroy*/vkFree* function, plus aliases for the handle types pbdam owns.
#pragma once

#include <vulkan/vulkan.h>

#include <type_traits>
#include <utility>

namespace pbdam::gpu {

/// Parent type of handles that have none (VkInstance, VkDevice): their destroy function takes
/// only the handle and the allocator.
struct NoParent final {};

/// Owns `Handle`, created from `Parent` (a VkDevice or VkInstance, or NoParent), and calls
/// `Destroy(parent, handle, nullptr)` (or `Destroy(handle, nullptr)` for NoParent) when it goes
/// out of scope or is reset. Move-only; a moved-from owner is empty (get() == VK_NULL_HANDLE)
/// and destroying an empty owner does nothing.
///
/// The parent must outlive the owner: owners of device children must be destroyed before the
/// VkDevice. Thread-safety: none of its own; like the handle it owns, an owner is externally
/// synchronised (Vulkan's rules for the destroy call apply).
template <typename Handle, typename Parent, auto Destroy>
class UniqueHandle final {
 public:
  UniqueHandle() noexcept = default;

  /// Takes ownership of `handle`, which was created from `parent`.
  UniqueHandle(Parent parent, Handle handle) noexcept : parent_(parent), handle_(handle) {}

  /// Takes ownership of a handle without a parent (VkInstance, VkDevice).
  explicit UniqueHandle(Handle handle) noexcept : handle_(handle) {}

  UniqueHandle(const UniqueHandle&) = delete;
  UniqueHandle& operator=(const UniqueHandle&) = delete;

  /// Takes over `other`'s handle, leaving it empty (an assigned-to owner destroys its own
  /// first).
  /// @{
  UniqueHandle(UniqueHandle&& other) noexcept
      : parent_(std::exchange(other.parent_, Parent{})),
        handle_(std::exchange(other.handle_, Handle{})) {}

  UniqueHandle& operator=(UniqueHandle&& other) noexcept {
    if (this != &other) {
      reset();
      parent_ = std::exchange(other.parent_, Parent{});
      handle_ = std::exchange(other.handle_, Handle{});
    }
    return *this;
  }
  /// @}

  ~UniqueHandle() { reset(); }

  /// The owned handle, VK_NULL_HANDLE when empty. Ownership stays here.
  Handle get() const noexcept { return handle_; }
  /// The parent the handle was created from (null when empty).
  Parent parent() const noexcept { return parent_; }
  /// Whether it owns a handle.
  explicit operator bool() const noexcept { return handle_ != Handle{}; }

  /// Gives up ownership without destroying; the caller now owns the returned handle.
  [[nodiscard]] Handle release() noexcept {
    parent_ = Parent{};
    return std::exchange(handle_, Handle{});
  }

  /// Destroys the owned handle, if any, and leaves the owner empty.
  void reset() noexcept {
    if (handle_ != Handle{}) {
      if constexpr (std::is_same_v<Parent, NoParent>) {
        Destroy(handle_, nullptr);
      } else {
        Destroy(parent_, handle_, nullptr);
      }
    }
    parent_ = Parent{};
    handle_ = Handle{};
  }

 private:
  [[no_unique_address]] Parent parent_{};
  Handle handle_{};
};

/// Destroys a debug messenger through vkGetInstanceProcAddr (the loader does not export the
/// extension's entry points).
void destroyDebugMessenger(VkInstance instance, VkDebugUtilsMessengerEXT messenger,
                           const VkAllocationCallbacks* allocator) noexcept;

/// The owner of each kind of Vulkan handle pbdam creates: UniqueX owns a VkX and destroys it
/// with vkDestroyX (vkFreeMemory for memory) through the parent it was created from.
/// @{
using UniqueInstance = UniqueHandle<VkInstance, NoParent, &vkDestroyInstance>;
using UniqueDevice = UniqueHandle<VkDevice, NoParent, &vkDestroyDevice>;
using UniqueDebugMessenger =
    UniqueHandle<VkDebugUtilsMessengerEXT, VkInstance, &destroyDebugMessenger>;
using UniqueBuffer = UniqueHandle<VkBuffer, VkDevice, &vkDestroyBuffer>;
using UniqueImage = UniqueHandle<VkImage, VkDevice, &vkDestroyImage>;
using UniqueImageView = UniqueHandle<VkImageView, VkDevice, &vkDestroyImageView>;
using UniqueDeviceMemory = UniqueHandle<VkDeviceMemory, VkDevice, &vkFreeMemory>;
using UniqueCommandPool = UniqueHandle<VkCommandPool, VkDevice, &vkDestroyCommandPool>;
using UniqueFence = UniqueHandle<VkFence, VkDevice, &vkDestroyFence>;
using UniqueSemaphore = UniqueHandle<VkSemaphore, VkDevice, &vkDestroySemaphore>;
using UniqueShaderModule = UniqueHandle<VkShaderModule, VkDevice, &vkDestroyShaderModule>;
using UniquePipelineLayout = UniqueHandle<VkPipelineLayout, VkDevice, &vkDestroyPipelineLayout>;
using UniquePipeline = UniqueHandle<VkPipeline, VkDevice, &vkDestroyPipeline>;
using UniqueDescriptorSetLayout =
    UniqueHandle<VkDescriptorSetLayout, VkDevice, &vkDestroyDescriptorSetLayout>;
using UniqueDescriptorPool = UniqueHandle<VkDescriptorPool, VkDevice, &vkDestroyDescriptorPool>;
using UniqueSampler = UniqueHandle<VkSampler, VkDevice, &vkDestroySampler>;
using UniqueQueryPool = UniqueHandle<VkQueryPool, VkDevice, &vkDestroyQueryPool>;
using UniqueSurface = UniqueHandle<VkSurfaceKHR, VkInstance, &vkDestroySurfaceKHR>;
using UniqueSwapchain = UniqueHandle<VkSwapchainKHR, VkDevice, &vkDestroySwapchainKHR>;
/// @}

}  // namespace pbdam::gpu
