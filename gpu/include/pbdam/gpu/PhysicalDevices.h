// Enumerating, describing and choosing Vulkan physical devices (for `pbdam devices` and for the
// device a VulkanContext runs on). The default is the best device the machine has: a discrete
// GPU before an integrated one, then a virtual GPU, then a CPU device such as Mesa's lavapipe,
// ties by index. A selector names another: an index, or a case-insensitive part of the device's
// or its driver's name (`--device nvidia`, `--device lavapipe`; also PBDAM_DEVICE).
#pragma once

#include "pbdam/formats/Result.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace pbdam::gpu {

/// What a physical device is, as the Vulkan driver reports it.
struct PhysicalDeviceInfo final {
  uint32_t index = 0;  ///< position in vkEnumeratePhysicalDevices order
  std::string name;    ///< "llvmpipe (LLVM 15.0.6, 256 bits)"
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;  ///< discrete, integrated, CPU, ...
  VkDriverId driverId = VkDriverId{};  ///< 0 where the driver predates Vulkan 1.2
  std::string driverName;              ///< "llvmpipe"
  std::string driverInfo;              ///< "Mesa 22.3.6 (LLVM 15.0.6)"
  uint32_t apiVersion = 0;             ///< VK_MAKE_API_VERSION-encoded
  uint32_t vendorId = 0;               ///< the PCI vendor id (VkPhysicalDeviceProperties::vendorID)
  uint32_t deviceId = 0;  ///< the vendor's device id (VkPhysicalDeviceProperties::deviceID)

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

/// The environment variable that names the device when a command is given no --device.
inline constexpr const char* kDeviceEnvironmentVariable = "PBDAM_DEVICE";

/// How much the default choice prefers a device type: 0 discrete GPU, 1 integrated, 2 virtual,
/// 3 CPU, 4 anything else (lower is preferred).
int defaultDevicePreference(VkPhysicalDeviceType type) noexcept;

/// The device used when none is named: the most preferred type, ties by index; nullopt when the
/// list is empty.
std::optional<uint32_t> defaultPhysicalDevice(const std::vector<PhysicalDeviceInfo>& devices);

/// The device `selector` names among `devices` (enumeration order, index = position):
/// - empty: defaultPhysicalDevice;
/// - all digits: that index;
/// - otherwise a case-insensitive part of the device's name or of its driver's name, or
///   "lavapipe" for Mesa's lavapipe; of several matches, the most preferred (ties by index).
/// Errors: InvalidArgument for an index out of range or a name that matches nothing, NotFound
/// for an empty list; each message lists the devices.
formats::Result<uint32_t> selectPhysicalDevice(const std::vector<PhysicalDeviceInfo>& devices,
                                               std::string_view selector);

/// The selector a command uses: `given` when not empty, else the value of PBDAM_DEVICE, else
/// empty (the default device).
std::string deviceSelector(std::string_view given);

/// "; 2 Vulkan device(s) | 0: ... | 1: ...": the devices, for an error message.
std::string deviceListSuffix(const std::vector<PhysicalDeviceInfo>& devices);

/// Creates a short-lived headless instance (no layers, no window-system extensions) and lists
/// its physical devices: what `pbdam devices` prints. Errors with ErrorCode::DeviceError when
/// no Vulkan driver is installed. Thread-safe.
formats::Result<std::vector<PhysicalDeviceInfo>> listPhysicalDevices();

}  // namespace pbdam::gpu
