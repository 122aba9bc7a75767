// Enumerating and describing Vulkan physical devices (for `pbdam devices` and for choosing the
// device a VulkanContext runs on; lavapipe by default, docs/architecture.md "What pbdam is").
#pragma once

#include "pbdam/formats/Result.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

namespace pbdam::gpu {

/// What a physical device is, as the Vulkan driver reports it.
struct PhysicalDeviceInfo final {
  uint32_t index = 0;  ///< position in vkEnumeratePhysicalDevices order
  std::string name;    ///< "llvmpipe (LLVM 15.0.6, 256 bits)"
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  VkDriverId driverId = VkDriverId{};  ///< 0 where the driver predates Vulkan 1.2
  std::string driverName;              ///< "llvmpipe"
  std::string driverInfo;              ///< "Mesa 22.3.6 (LLVM 15.0.6)"
  uint32_t apiVersion = 0;             ///< VK_MAKE_API_VERSION-encoded
  uint32_t vendorId = 0;
  uint32_t deviceId = 0;

  /// True for Mesa's lavapipe (llvmpipe driver, CPU device type).
  bool isLavapipe() const noexcept;
};

/// "cpu", "discrete-gpu", "integrated-gpu", "virtual-gpu" or "other". Thread-safe.
const char* physicalDeviceTypeName(VkPhysicalDeviceType type) noexcept;

/// "1.3.230" for a VK_MAKE_API_VERSION-encoded version.
std::string apiVersionString(uint32_t apiVersion);

/// One line: "0: llvmpipe (LLVM 15.0.6, 256 bits) [cpu, driver llvmpipe Mesa 22.3.6 (LLVM
/// 15.0.6), Vulkan 1.3.230]".
std::string describe(const PhysicalDeviceInfo& info);

/// Queries `device`'s properties (Vulkan 1.2 driver properties where the device supports them).
/// `index` is recorded as-is. Thread-safe.
PhysicalDeviceInfo queryPhysicalDeviceInfo(VkPhysicalDevice device, uint32_t index);

/// The physical devices of `instance`, in enumeration order. Thread-safe.
formats::Result<std::vector<PhysicalDeviceInfo>> listPhysicalDevices(VkInstance instance);

/// Creates a short-lived headless instance (no layers, no window-system extensions) and lists
/// its physical devices: what `pbdam devices` prints. Errors with ErrorCode::DeviceError when
/// no Vulkan driver is installed. Thread-safe.
formats::Result<std::vector<PhysicalDeviceInfo>> listPhysicalDevices();

}  // namespace pbdam::gpu
