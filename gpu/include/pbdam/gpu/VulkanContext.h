// VulkanContext: the Vulkan instance, the chosen physical device (the machine's best unless told
// otherwise, PhysicalDevices.h), the logical device with one graphics queue, optional Khronos
// validation, and a blocking "record, submit, wait" helper. Headless unless ContextOptions asks
// for a window's surface (pbdam fly): then the queue also presents to it (Swapchain.h).
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/DeviceCaps.h"
#include "pbdam/gpu/PhysicalDevices.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/gpu/ValidationLog.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

/// The gpu layer: the Vulkan context and device choice, the terrain renderer and its GPU cache,
/// offscreen targets and swapchains, the device-side selection of cuts, and GPU sightlines and
/// viewsheds. Every Vulkan object is owned by a move-only handle (UniqueHandle.h).
namespace pbdam::gpu {

/// Whether validation is on when ContextOptions does not say: on in Debug builds
/// (gpu/CMakeLists.txt defines PBDAM_VALIDATION_BY_DEFAULT there). Not tied to NDEBUG: the
/// ASan build keeps its asserts without paying for the layer in every command it runs.
#ifdef PBDAM_VALIDATION_BY_DEFAULT
inline constexpr bool kValidationByDefault = true;
#else
inline constexpr bool kValidationByDefault = false;
#endif

/// Presentation to a window: what the window library needs of the instance, and how it makes
/// the window's surface (GLFW: glfwGetRequiredInstanceExtensions, glfwCreateWindowSurface).
struct WindowPresentation final {
  /// Instance extensions the surface needs (VK_KHR_surface and the platform's).
  std::vector<std::string> instanceExtensions;
  /// Makes the surface from the new instance; the context owns it from then on.
  std::function<formats::Result<VkSurfaceKHR>(VkInstance)> createSurface;
};

/// How to create a VulkanContext.
struct ContextOptions final {
  /// The physical device (the CLI's `--device`): a vkEnumeratePhysicalDevices index or a
  /// case-insensitive part of the device's or driver's name ("lavapipe", "nvidia"); empty:
  /// PBDAM_DEVICE's value, else the machine's best device (selectPhysicalDevice).
  std::string device;
  /// Load VK_LAYER_KHRONOS_validation and record its warnings/errors in the validation log.
  /// Creation fails if this is set and the layer is not installed.
  bool enableValidation = kValidationByDefault;
  /// With validation: also run synchronization validation (VK_EXT_validation_features), when
  /// the layer offers it.
  bool enableSynchronizationValidation = true;
  /// Print validation messages to stderr as they arrive (they are recorded either way). Used
  /// only when validationLog is null.
  bool echoValidationToStderr = true;
  /// Where validation messages go. Null: the context makes its own. Pass one to keep reading
  /// it after the context is destroyed (destruction-time messages count too).
  std::shared_ptr<ValidationLog> validationLog;
  /// Reported to the driver in VkApplicationInfo.
  std::string applicationName = "pbdam";
  /// A window to present to: the device must have a queue family that draws and presents to
  /// its surface, and gets VK_KHR_swapchain. Empty: headless.
  std::optional<WindowPresentation> presentation;
};

/// The Vulkan instance, device and graphics queue that everything in pbdam_gpu is created from.
/// Move-only; objects created from it (buffers, images, pipelines) must be destroyed before it.
/// Destruction waits for the device to be idle, then destroys the command pool, the device, the
/// debug messenger and the instance, in that order.
///
/// Thread-safety: the accessors are thread-safe. The one queue and the context's command pool
/// must be externally synchronised in Vulkan; the context does that itself: submit(),
/// submitAndWait() and waitIdle() take its queue lock (submitAndWait() also serialises its own
/// command pool), so several threads — each with its own command buffers, e.g. one
/// TerrainRenderer per thread in `pbdam serve` — may share one context. Never call
/// vkQueueSubmit* on queue() directly; use submit(). Creating device objects from device() is
/// thread-safe, as in Vulkan.
class VulkanContext final {
 public:
  /// Creates the instance (Vulkan 1.3, no window-system extensions), picks the physical device
  /// (see ContextOptions::device) and creates the logical device with dynamic rendering,
  /// synchronization2 and timeline semaphores, plus whichever optional features of DeviceCaps
  /// the device has. Errors: ErrorCode::InvalidArgument for a device index out of range or a
  /// name that matches no device, NotFound when there is no device or the validation layer is
  /// requested but missing, DeviceError when
  /// a Vulkan call fails or the device lacks a required feature; messages list the devices.
  static formats::Result<VulkanContext> create(const ContextOptions& options = {});

  /// Takes over another context, leaving it moved-from (operator bool false).
  /// @{
  VulkanContext(VulkanContext&&) noexcept;
  VulkanContext& operator=(VulkanContext&&) noexcept;
  /// @}
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;
  ~VulkanContext();

  /// False only for a moved-from context, which may only be destroyed or assigned to.
  explicit operator bool() const noexcept { return impl_ != nullptr; }

  /// The Vulkan instance, the chosen physical device and the logical device; ownership stays
  /// here.
  /// @{
  VkInstance instance() const noexcept;
  VkPhysicalDevice physicalDevice() const noexcept;
  VkDevice device() const noexcept;
  /// @}
  /// The graphics queue (it also does transfers); family queueFamilyIndex().
  VkQueue queue() const noexcept;
  /// The family of queue().
  uint32_t queueFamilyIndex() const noexcept;

  /// What the chosen device is.
  const PhysicalDeviceInfo& deviceInfo() const noexcept;
  /// The optional features enabled on it and its limits.
  const DeviceCaps& caps() const noexcept;
  /// Its memory types and heaps.
  const VkPhysicalDeviceMemoryProperties& memoryProperties() const noexcept;

  /// Whether the validation layer is loaded (the messenger feeds validationLog()).
  bool validationEnabled() const noexcept;
  /// The log the debug messenger writes to (empty forever when validation is off).
  ValidationLog& validationLog() const noexcept;
  /// The same log, as a shared pointer that keeps it alive beyond the context.
  std::shared_ptr<ValidationLog> sharedValidationLog() const noexcept;

  /// Records commands with `record` into a fresh primary command buffer, submits it to the
  /// queue and blocks until it has executed (fence wait, at most `timeoutNanoseconds`).
  /// `what` names the work in error messages. Thread-safe: calls are serialised.
  formats::Result<void> submitAndWait(const std::function<void(VkCommandBuffer)>& record,
                                      std::string_view what = "submitAndWait",
                                      uint64_t timeoutNanoseconds = 60'000'000'000ull);

  /// vkQueueSubmit2 of one batch under the queue lock; `fence` may be VK_NULL_HANDLE. The caller
  /// owns (and synchronises) the command buffers and the fence. `what` names the work in error
  /// messages. Thread-safe.
  formats::Result<void> submit(const VkSubmitInfo2& batch, VkFence fence, std::string_view what);

  /// The window's surface (ContextOptions::presentation), else VK_NULL_HANDLE.
  VkSurfaceKHR surface() const noexcept;

  /// vkQueuePresentKHR under the queue lock; returns its result (VK_SUCCESS, VK_SUBOPTIMAL_KHR,
  /// VK_ERROR_OUT_OF_DATE_KHR...) for the caller to act on. Thread-safe.
  VkResult present(const VkPresentInfoKHR& info);

  /// vkDeviceWaitIdle under the queue lock. Thread-safe.
  formats::Result<void> waitIdle();

  /// Creates a timeline semaphore starting at `initialValue`.
  formats::Result<UniqueSemaphore> createTimelineSemaphore(uint64_t initialValue = 0) const;

  /// Names a Vulkan object for validation messages (no-op when validation is off).
  /// @{
  void setObjectName(VkObjectType type, uint64_t handle, const char* name) const noexcept;
  template <typename Handle>
  void setObjectName(VkObjectType type, Handle handle, const char* name) const noexcept {
    setObjectName(type, reinterpret_cast<uint64_t>(handle), name);
  }
  /// @}

 private:
  struct Impl;
  explicit VulkanContext(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbdam::gpu
