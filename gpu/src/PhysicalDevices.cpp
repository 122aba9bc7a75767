// Physical device enumeration, description and choice.
#include "pbdam/gpu/PhysicalDevices.h"

#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/gpu/VulkanError.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>

using namespace pbdam::formats;

namespace pbdam::gpu {

bool PhysicalDeviceInfo::isLavapipe() const noexcept {
  return driverId == VK_DRIVER_ID_MESA_LLVMPIPE ||
         (type == VK_PHYSICAL_DEVICE_TYPE_CPU && name.rfind("llvmpipe", 0) == 0);
}

const char* physicalDeviceTypeName(VkPhysicalDeviceType type) noexcept {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "cpu";
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete-gpu";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated-gpu";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual-gpu";
    default:
      return "other";
  }
}

std::string apiVersionString(uint32_t apiVersion) {
  return std::to_string(VK_API_VERSION_MAJOR(apiVersion)) + "." +
         std::to_string(VK_API_VERSION_MINOR(apiVersion)) + "." +
         std::to_string(VK_API_VERSION_PATCH(apiVersion));
}

std::string describe(const PhysicalDeviceInfo& info) {
  std::string line =
      std::to_string(info.index) + ": " + info.name + " [" + physicalDeviceTypeName(info.type);
  if (!info.driverName.empty()) {
    line += ", driver " + info.driverName;
    if (!info.driverInfo.empty()) line += " " + info.driverInfo;
  }
  line += ", Vulkan " + apiVersionString(info.apiVersion) + "]";
  return line;
}

PhysicalDeviceInfo queryPhysicalDeviceInfo(VkPhysicalDevice device, uint32_t index) {
  VkPhysicalDeviceProperties properties{};
  vkGetPhysicalDeviceProperties(device, &properties);

  PhysicalDeviceInfo info;
  info.index = index;
  info.name = properties.deviceName;
  info.type = properties.deviceType;
  info.apiVersion = properties.apiVersion;
  info.vendorId = properties.vendorID;
  info.deviceId = properties.deviceID;
  if (properties.apiVersion >= VK_API_VERSION_1_2) {
    VkPhysicalDeviceDriverProperties driver{};
    driver.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES;
    VkPhysicalDeviceProperties2 properties2{};
    properties2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    properties2.pNext = &driver;
    vkGetPhysicalDeviceProperties2(device, &properties2);
    info.driverId = driver.driverID;
    info.driverName = driver.driverName;
    info.driverInfo = driver.driverInfo;
  }
  return info;
}

int defaultDevicePreference(VkPhysicalDeviceType type) noexcept {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

namespace {

/// The most preferred of `devices` that `keep` accepts, ties by index.
template <typename Keep>
std::optional<uint32_t> mostPreferred(const std::vector<PhysicalDeviceInfo>& devices, Keep keep) {
  std::optional<uint32_t> best;
  int bestRank = 0;
  for (uint32_t i = 0; i < devices.size(); ++i) {
    if (!keep(devices[i])) continue;
    const int rank = defaultDevicePreference(devices[i].type);
    if (!best || rank < bestRank) {
      best = i;
      bestRank = rank;
    }
  }
  return best;
}

std::string lowercase(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

}  // namespace

std::optional<uint32_t> defaultPhysicalDevice(const std::vector<PhysicalDeviceInfo>& devices) {
  return mostPreferred(devices, [](const PhysicalDeviceInfo&) { return true; });
}

std::string deviceListSuffix(const std::vector<PhysicalDeviceInfo>& devices) {
  std::string message = "; " + std::to_string(devices.size()) + " Vulkan device(s)";
  for (const PhysicalDeviceInfo& info : devices) message += " | " + describe(info);
  return message;
}

Result<uint32_t> selectPhysicalDevice(const std::vector<PhysicalDeviceInfo>& devices,
                                      std::string_view selector) {
  if (devices.empty()) {
    return makeError(ErrorCode::NotFound,
                     "no Vulkan device found; install a GPU driver or Mesa's lavapipe "
                     "(mesa-vulkan-drivers), or check VK_ICD_FILENAMES");
  }
  if (selector.empty()) return *defaultPhysicalDevice(devices);
  if (std::all_of(selector.begin(), selector.end(),
                  [](unsigned char c) { return std::isdigit(c) != 0; })) {
    if (selector.size() > 9 || std::stoul(std::string(selector)) >= devices.size()) {
      return invalidArgument("Vulkan device index " + std::string(selector) + " is out of range" +
                             deviceListSuffix(devices));
    }
    return static_cast<uint32_t>(std::stoul(std::string(selector)));
  }
  const std::string wanted = lowercase(selector);
  const auto match = mostPreferred(devices, [&](const PhysicalDeviceInfo& d) {
    return lowercase(d.name).find(wanted) != std::string::npos ||
           lowercase(d.driverName).find(wanted) != std::string::npos ||
           (wanted == "lavapipe" && d.isLavapipe());
  });
  if (!match) {
    return invalidArgument("no Vulkan device matches '" + std::string(selector) +
                           "' (a device index, or part of a device's or driver's name)" +
                           deviceListSuffix(devices));
  }
  return *match;
}

std::string deviceSelector(std::string_view given) {
  if (!given.empty()) return std::string(given);
  const char* env = std::getenv(kDeviceEnvironmentVariable);
  return env ? std::string(env) : std::string();
}

Result<std::vector<PhysicalDeviceInfo>> listPhysicalDevices(VkInstance instance) {
  uint32_t count = 0;
  if (VkResult r = vkEnumeratePhysicalDevices(instance, &count, nullptr); r != VK_SUCCESS) {
    return vulkanError(r, "vkEnumeratePhysicalDevices");
  }
  std::vector<VkPhysicalDevice> devices(count);
  if (VkResult r = vkEnumeratePhysicalDevices(instance, &count, devices.data());
      r != VK_SUCCESS && r != VK_INCOMPLETE) {
    return vulkanError(r, "vkEnumeratePhysicalDevices");
  }
  devices.resize(count);
  std::vector<PhysicalDeviceInfo> infos;
  infos.reserve(devices.size());
  for (uint32_t i = 0; i < count; ++i) {
    infos.push_back(queryPhysicalDeviceInfo(devices[i], i));
  }
  return infos;
}

Result<std::vector<PhysicalDeviceInfo>> listPhysicalDevices() {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "pbdam devices";
  app.pEngineName = "pbdam";
  app.apiVersion = VK_API_VERSION_1_3;
  VkInstanceCreateInfo create{};
  create.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  create.pApplicationInfo = &app;
  VkInstance raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateInstance(&create, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateInstance (listing devices)");
  }
  const UniqueInstance instance(raw);
  return listPhysicalDevices(instance.get());
}

}  // namespace pbdam::gpu
