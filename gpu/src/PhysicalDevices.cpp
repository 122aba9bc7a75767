// Physical device enumeration and description.
#include "pbdam/gpu/PhysicalDevices.h"

#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/gpu/VulkanError.h"

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
