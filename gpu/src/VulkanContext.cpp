// VulkanContext: headless instance + device creation, device selection (PhysicalDevices.h)
// and the Khronos validation layer wiring (docs/architecture.md "What pbdam is", "Modules").
#include "pbdam/gpu/VulkanContext.h"

#include "pbdam/gpu/VulkanError.h"

#include <array>
#include <cassert>
#include <cstring>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

Result<std::vector<VkLayerProperties>> instanceLayers() {
  uint32_t count = 0;
  if (VkResult r = vkEnumerateInstanceLayerProperties(&count, nullptr); r != VK_SUCCESS) {
    return vulkanError(r, "vkEnumerateInstanceLayerProperties");
  }
  std::vector<VkLayerProperties> layers(count);
  if (VkResult r = vkEnumerateInstanceLayerProperties(&count, layers.data());
      r != VK_SUCCESS && r != VK_INCOMPLETE) {
    return vulkanError(r, "vkEnumerateInstanceLayerProperties");
  }
  layers.resize(count);
  return layers;
}

Result<std::vector<VkExtensionProperties>> instanceExtensions(const char* layer) {
  uint32_t count = 0;
  if (VkResult r = vkEnumerateInstanceExtensionProperties(layer, &count, nullptr);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkEnumerateInstanceExtensionProperties");
  }
  std::vector<VkExtensionProperties> extensions(count);
  if (VkResult r = vkEnumerateInstanceExtensionProperties(layer, &count, extensions.data());
      r != VK_SUCCESS && r != VK_INCOMPLETE) {
    return vulkanError(r, "vkEnumerateInstanceExtensionProperties");
  }
  extensions.resize(count);
  return extensions;
}

bool hasExtension(const std::vector<VkExtensionProperties>& extensions, const char* name) {
  for (const VkExtensionProperties& extension : extensions) {
    if (std::strcmp(extension.extensionName, name) == 0) return true;
  }
  return false;
}

}  // namespace

struct VulkanContext::Impl final {
  // Declaration order is destruction order reversed: the log outlives the messenger, the
  // messenger outlives the device, the device outlives the pool and fence.
  std::shared_ptr<ValidationLog> log;
  UniqueInstance instance;
  UniqueSurface surface;  // destroyed after the device (and any swapchain made from it)
  UniqueDebugMessenger messenger;
  UniqueDevice device;
  UniqueCommandPool commandPool;
  UniqueFence submitFence;
  /// Guards the queue (every vkQueueSubmit2 and vkDeviceWaitIdle).
  std::mutex queueMutex;
  /// Serialises submitAndWait(): its command pool and fence.
  std::mutex helperMutex;

  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queueFamilyIndex = 0;
  PhysicalDeviceInfo physicalInfo;
  DeviceCaps caps;
  VkPhysicalDeviceMemoryProperties memoryProperties{};
  bool validation = false;
  PFN_vkSetDebugUtilsObjectNameEXT setObjectName = nullptr;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    if (device) vkDeviceWaitIdle(device.get());
  }

  Result<void> createInstance(const ContextOptions& options);
  Result<void> choosePhysicalDevice(const ContextOptions& options);
  Result<void> createSurface(const WindowPresentation& presentation);
  Result<std::vector<const char*>> chooseQueueFamily();
  Result<void> createDevice();
};

Result<void> VulkanContext::Impl::createSurface(const WindowPresentation& presentation) {
  if (!presentation.createSurface) {
    return makeError(ErrorCode::InvalidArgument, "a window presentation without createSurface");
  }
  Result<VkSurfaceKHR> made = presentation.createSurface(instance.get());
  if (!made) return std::move(made).error();
  surface = UniqueSurface(instance.get(), *made);
  return {};
}

Result<void> VulkanContext::Impl::createInstance(const ContextOptions& options) {
  uint32_t loaderVersion = 0;
  if (VkResult r = vkEnumerateInstanceVersion(&loaderVersion); r != VK_SUCCESS) {
    return vulkanError(r, "vkEnumerateInstanceVersion");
  }
  if (loaderVersion < VK_API_VERSION_1_3) {
    return makeError(ErrorCode::DeviceError, "the Vulkan loader supports Vulkan " +
                                                 apiVersionString(loaderVersion) +
                                                 "; pbdam needs 1.3 (install libvulkan1 >= 1.3)");
  }

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (options.presentation) {
    for (const std::string& name : options.presentation->instanceExtensions) {
      extensions.push_back(name.c_str());
    }
  }
  bool syncValidation = false;
  if (options.enableValidation) {
    Result<std::vector<VkLayerProperties>> available = instanceLayers();
    if (!available) return std::move(available).error();
    bool found = false;
    std::string names;
    for (const VkLayerProperties& layer : *available) {
      found = found || std::strcmp(layer.layerName, kValidationLayer) == 0;
      names += names.empty() ? "" : ", ";
      names += layer.layerName;
    }
    if (!found) {
      return makeError(ErrorCode::NotFound,
                       std::string("Vulkan validation was requested but ") + kValidationLayer +
                           " is not installed (Debian: vulkan-validationlayers; or set "
                           "VK_LAYER_PATH); layers found: " +
                           (names.empty() ? "none" : names));
    }
    layers.push_back(kValidationLayer);
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    if (options.enableSynchronizationValidation) {
      Result<std::vector<VkExtensionProperties>> layerExtensions =
          instanceExtensions(kValidationLayer);
      if (!layerExtensions) return std::move(layerExtensions).error();
      if (hasExtension(*layerExtensions, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME)) {
        extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
        syncValidation = true;
      }
    }
  }

  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = options.applicationName.c_str();
  app.pEngineName = "pbdam";
  app.apiVersion = VK_API_VERSION_1_3;

  // Chained into instance creation so that vkCreateInstance/vkDestroyInstance are covered.
  VkDebugUtilsMessengerCreateInfoEXT messengerInfo = ValidationLog::messengerCreateInfo(*log);
  const std::array<VkValidationFeatureEnableEXT, 1> enables = {
      VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{};
  features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
  features.enabledValidationFeatureCount = static_cast<uint32_t>(enables.size());
  features.pEnabledValidationFeatures = enables.data();
  if (syncValidation) messengerInfo.pNext = &features;

  VkInstanceCreateInfo create{};
  create.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  create.pApplicationInfo = &app;
  create.enabledLayerCount = static_cast<uint32_t>(layers.size());
  create.ppEnabledLayerNames = layers.data();
  create.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  create.ppEnabledExtensionNames = extensions.data();
  if (options.enableValidation) create.pNext = &messengerInfo;

  VkInstance rawInstance = VK_NULL_HANDLE;
  if (VkResult r = vkCreateInstance(&create, nullptr, &rawInstance); r != VK_SUCCESS) {
    return vulkanError(
        r, options.enableValidation ? "vkCreateInstance (with validation)" : "vkCreateInstance");
  }
  instance = UniqueInstance(rawInstance);
  validation = options.enableValidation;

  if (validation) {
    auto createMessenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance.get(), "vkCreateDebugUtilsMessengerEXT"));
    setObjectName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetInstanceProcAddr(instance.get(), "vkSetDebugUtilsObjectNameEXT"));
    if (createMessenger == nullptr) {
      return makeError(ErrorCode::DeviceError,
                       "vkCreateDebugUtilsMessengerEXT is missing although VK_EXT_debug_utils "
                       "was enabled");
    }
    VkDebugUtilsMessengerCreateInfoEXT info = ValidationLog::messengerCreateInfo(*log);
    VkDebugUtilsMessengerEXT rawMessenger = VK_NULL_HANDLE;
    if (VkResult r = createMessenger(instance.get(), &info, nullptr, &rawMessenger);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateDebugUtilsMessengerEXT");
    }
    messenger = UniqueDebugMessenger(instance.get(), rawMessenger);
  }
  return {};
}

Result<void> VulkanContext::Impl::choosePhysicalDevice(const ContextOptions& options) {
  uint32_t count = 0;
  if (VkResult r = vkEnumeratePhysicalDevices(instance.get(), &count, nullptr); r != VK_SUCCESS) {
    return vulkanError(r, "vkEnumeratePhysicalDevices");
  }
  std::vector<VkPhysicalDevice> devices(count);
  if (VkResult r = vkEnumeratePhysicalDevices(instance.get(), &count, devices.data());
      r != VK_SUCCESS && r != VK_INCOMPLETE) {
    return vulkanError(r, "vkEnumeratePhysicalDevices");
  }
  devices.resize(count);
  std::vector<PhysicalDeviceInfo> infos;
  for (uint32_t i = 0; i < count; ++i) infos.push_back(queryPhysicalDeviceInfo(devices[i], i));

  auto chosen = selectPhysicalDevice(infos, deviceSelector(options.device));
  if (!chosen) return std::move(chosen).error();
  physicalDevice = devices[*chosen];
  physicalInfo = infos[*chosen];
  if (physicalInfo.apiVersion < VK_API_VERSION_1_3) {
    return makeError(ErrorCode::DeviceError,
                     "Vulkan device " + describe(physicalInfo) + " supports Vulkan " +
                         apiVersionString(physicalInfo.apiVersion) +
                         "; pbdam needs 1.3 (dynamic rendering, synchronization2)");
  }
  return {};
}

namespace {

/// What createDevice enabled (each `want` is what it asked for: present features only) and the
/// limits the renderer sizes itself by.
DeviceCaps enabledCaps(const VkPhysicalDeviceFeatures2& want,
                       const VkPhysicalDeviceVulkan11Features& want11,
                       const VkPhysicalDeviceVulkan12Features& want12,
                       const VkPhysicalDeviceLimits& limits) {
  DeviceCaps caps;
  caps.shaderFloat64 = want.features.shaderFloat64 == VK_TRUE;
  caps.storageBuffer16BitAccess = want11.storageBuffer16BitAccess == VK_TRUE;
  caps.textureCompressionBC = want.features.textureCompressionBC == VK_TRUE;
  caps.multiDrawIndirect = want.features.multiDrawIndirect == VK_TRUE;
  caps.drawIndirectCount = want12.drawIndirectCount == VK_TRUE;
  caps.shaderDrawParameters = want11.shaderDrawParameters == VK_TRUE;
  caps.drawIndirectFirstInstance = want.features.drawIndirectFirstInstance == VK_TRUE;
  caps.geometryShader = want.features.geometryShader == VK_TRUE;
  caps.fillModeNonSolid = want.features.fillModeNonSolid == VK_TRUE;
  caps.vertexPipelineStoresAndAtomics = want.features.vertexPipelineStoresAndAtomics == VK_TRUE;
  caps.maxPushConstantsBytes = limits.maxPushConstantsSize;
  caps.maxImageDimension2DPixels = limits.maxImageDimension2D;
  caps.maxDrawIndexedIndexValue = limits.maxDrawIndexedIndexValue;
  caps.timestampPeriodNanoseconds = limits.timestampPeriod;
  caps.nonCoherentAtomSizeBytes = limits.nonCoherentAtomSize;
  return caps;
}

}  // namespace

// The graphics queue family (one that also presents to the surface, when there is one) and the
// device extensions the surface needs.
Result<std::vector<const char*>> VulkanContext::Impl::chooseQueueFamily() {
  uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice, &familyCount, families.data());
  std::optional<uint32_t> family;
  bool graphics = false;
  for (uint32_t i = 0; i < familyCount; ++i) {
    if ((families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT) == 0 || families[i].queueCount == 0) {
      continue;
    }
    graphics = true;
    VkBool32 presents = VK_TRUE;
    if (surface && vkGetPhysicalDeviceSurfaceSupportKHR(physicalDevice, i, surface.get(),
                                                        &presents) != VK_SUCCESS) {
      presents = VK_FALSE;
    }
    if (presents == VK_TRUE) {
      family = i;
      break;
    }
  }
  if (!family) {
    return makeError(ErrorCode::DeviceError,
                     "Vulkan device " + describe(physicalInfo) +
                         (graphics ? " cannot present to this window (no queue family both "
                                     "draws and presents; choose another with --device)"
                                   : " has no graphics queue"));
  }
  queueFamilyIndex = *family;
  std::vector<const char*> deviceExtensions;
  if (surface) {
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physicalDevice, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> available(count);
    vkEnumerateDeviceExtensionProperties(physicalDevice, nullptr, &count, available.data());
    if (!hasExtension(available, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) {
      return makeError(ErrorCode::DeviceError, "Vulkan device " + describe(physicalInfo) +
                                                   " has no swapchains (" +
                                                   VK_KHR_SWAPCHAIN_EXTENSION_NAME + ")");
    }
    deviceExtensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  }
  return deviceExtensions;
}

Result<void> VulkanContext::Impl::createDevice() {
  Result<std::vector<const char*>> chosen = chooseQueueFamily();
  if (!chosen) return std::move(chosen).error();
  const std::vector<const char*> deviceExtensions = std::move(*chosen);

  VkPhysicalDeviceVulkan13Features have13{};
  have13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
  VkPhysicalDeviceVulkan12Features have12{};
  have12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  have12.pNext = &have13;
  VkPhysicalDeviceVulkan11Features have11{};
  have11.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES;
  have11.pNext = &have12;
  VkPhysicalDeviceFeatures2 have{};
  have.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  have.pNext = &have11;
  vkGetPhysicalDeviceFeatures2(physicalDevice, &have);

  std::string missing;
  if (have13.dynamicRendering == VK_FALSE) missing += " dynamicRendering";
  if (have13.synchronization2 == VK_FALSE) missing += " synchronization2";
  if (have12.timelineSemaphore == VK_FALSE) missing += " timelineSemaphore";
  if (!missing.empty()) {
    return makeError(ErrorCode::DeviceError, "Vulkan device " + describe(physicalInfo) +
                                                 " lacks required features:" + missing);
  }

  VkPhysicalDeviceVulkan13Features want13{};
  want13.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES;
  want13.dynamicRendering = VK_TRUE;
  want13.synchronization2 = VK_TRUE;
  VkPhysicalDeviceVulkan12Features want12{};
  want12.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES;
  want12.pNext = &want13;
  want12.timelineSemaphore = VK_TRUE;
  want12.drawIndirectCount = have12.drawIndirectCount;
  VkPhysicalDeviceVulkan11Features want11{};
  want11.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES;
  want11.pNext = &want12;
  want11.storageBuffer16BitAccess = have11.storageBuffer16BitAccess;
  want11.shaderDrawParameters = have11.shaderDrawParameters;
  VkPhysicalDeviceFeatures2 want{};
  want.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
  want.pNext = &want11;
  want.features.shaderFloat64 = have.features.shaderFloat64;
  want.features.textureCompressionBC = have.features.textureCompressionBC;
  want.features.multiDrawIndirect = have.features.multiDrawIndirect;
  want.features.drawIndirectFirstInstance = have.features.drawIndirectFirstInstance;
  want.features.geometryShader = have.features.geometryShader;
  want.features.fillModeNonSolid = have.features.fillModeNonSolid;
  want.features.vertexPipelineStoresAndAtomics = have.features.vertexPipelineStoresAndAtomics;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queueInfo{};
  queueInfo.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  queueInfo.queueFamilyIndex = queueFamilyIndex;
  queueInfo.queueCount = 1;
  queueInfo.pQueuePriorities = &priority;

  VkDeviceCreateInfo create{};
  create.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  create.pNext = &want;
  create.queueCreateInfoCount = 1;
  create.pQueueCreateInfos = &queueInfo;
  create.enabledExtensionCount = static_cast<uint32_t>(deviceExtensions.size());
  create.ppEnabledExtensionNames = deviceExtensions.data();
  VkDevice rawDevice = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDevice(physicalDevice, &create, nullptr, &rawDevice); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDevice (" + physicalInfo.name + ")");
  }
  device = UniqueDevice(rawDevice);
  vkGetDeviceQueue(device.get(), queueFamilyIndex, 0, &queue);

  VkPhysicalDeviceProperties properties{};
  vkGetPhysicalDeviceProperties(physicalDevice, &properties);
  vkGetPhysicalDeviceMemoryProperties(physicalDevice, &memoryProperties);
  caps = enabledCaps(want, want11, want12, properties.limits);

  VkCommandPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  poolInfo.flags =
      VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT | VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  poolInfo.queueFamilyIndex = queueFamilyIndex;
  VkCommandPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateCommandPool(device.get(), &poolInfo, nullptr, &rawPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateCommandPool");
  }
  commandPool = UniqueCommandPool(device.get(), rawPool);

  VkFenceCreateInfo fenceInfo{};
  fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence rawFence = VK_NULL_HANDLE;
  if (VkResult r = vkCreateFence(device.get(), &fenceInfo, nullptr, &rawFence); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateFence");
  }
  submitFence = UniqueFence(device.get(), rawFence);
  return {};
}

Result<VulkanContext> VulkanContext::create(const ContextOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->log = options.validationLog
                  ? options.validationLog
                  : std::make_shared<ValidationLog>(options.echoValidationToStderr);
  if (Result<void> r = impl->createInstance(options); !r) return std::move(r).error();
  if (options.presentation) {
    if (Result<void> r = impl->createSurface(*options.presentation); !r) {
      return std::move(r).error();
    }
  }
  if (Result<void> r = impl->choosePhysicalDevice(options); !r) return std::move(r).error();
  if (Result<void> r = impl->createDevice(); !r) return std::move(r).error();
  return VulkanContext(std::move(impl));
}

VulkanContext::VulkanContext(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
VulkanContext::VulkanContext(VulkanContext&&) noexcept = default;
VulkanContext& VulkanContext::operator=(VulkanContext&&) noexcept = default;
VulkanContext::~VulkanContext() = default;

VkInstance VulkanContext::instance() const noexcept { return impl_->instance.get(); }
VkPhysicalDevice VulkanContext::physicalDevice() const noexcept { return impl_->physicalDevice; }
VkDevice VulkanContext::device() const noexcept { return impl_->device.get(); }
VkQueue VulkanContext::queue() const noexcept { return impl_->queue; }
uint32_t VulkanContext::queueFamilyIndex() const noexcept { return impl_->queueFamilyIndex; }
const PhysicalDeviceInfo& VulkanContext::deviceInfo() const noexcept { return impl_->physicalInfo; }
const DeviceCaps& VulkanContext::caps() const noexcept { return impl_->caps; }
const VkPhysicalDeviceMemoryProperties& VulkanContext::memoryProperties() const noexcept {
  return impl_->memoryProperties;
}
bool VulkanContext::validationEnabled() const noexcept { return impl_->validation; }
VkSurfaceKHR VulkanContext::surface() const noexcept { return impl_->surface.get(); }

VkResult VulkanContext::present(const VkPresentInfoKHR& info) {
  assert(impl_ && "use of a moved-from VulkanContext");
  const std::lock_guard<std::mutex> lock(impl_->queueMutex);
  return vkQueuePresentKHR(impl_->queue, &info);
}
ValidationLog& VulkanContext::validationLog() const noexcept { return *impl_->log; }
std::shared_ptr<ValidationLog> VulkanContext::sharedValidationLog() const noexcept {
  return impl_->log;
}

Result<void> VulkanContext::submitAndWait(const std::function<void(VkCommandBuffer)>& record,
                                          std::string_view what, uint64_t timeoutNanoseconds) {
  assert(impl_ && "use of a moved-from VulkanContext");
  const std::lock_guard<std::mutex> helperLock(impl_->helperMutex);
  VkDevice dev = impl_->device.get();
  VkCommandBufferAllocateInfo allocInfo{};
  allocInfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  allocInfo.commandPool = impl_->commandPool.get();
  allocInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  allocInfo.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (VkResult r = vkAllocateCommandBuffers(dev, &allocInfo, &cmd); r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateCommandBuffers (" + std::string(what) + ")");
  }
  // The command buffer goes back to the pool on every path out of this function.
  struct FreeOnExit {
    VkDevice device;
    VkCommandPool pool;
    VkCommandBuffer cmd;
    ~FreeOnExit() { vkFreeCommandBuffers(device, pool, 1, &cmd); }
  } freeOnExit{dev, impl_->commandPool.get(), cmd};

  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  if (VkResult r = vkBeginCommandBuffer(cmd, &begin); r != VK_SUCCESS) {
    return vulkanError(r, "vkBeginCommandBuffer (" + std::string(what) + ")");
  }
  record(cmd);
  if (VkResult r = vkEndCommandBuffer(cmd); r != VK_SUCCESS) {
    return vulkanError(r, "vkEndCommandBuffer (" + std::string(what) + ")");
  }

  VkFence fence = impl_->submitFence.get();
  if (VkResult r = vkResetFences(dev, 1, &fence); r != VK_SUCCESS) {
    return vulkanError(r, "vkResetFences (" + std::string(what) + ")");
  }
  VkCommandBufferSubmitInfo cmdInfo{};
  cmdInfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
  cmdInfo.commandBuffer = cmd;
  VkSubmitInfo2 submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  submit.commandBufferInfoCount = 1;
  submit.pCommandBufferInfos = &cmdInfo;
  if (Result<void> r = this->submit(submit, fence, what); !r) return r;
  if (VkResult r = vkWaitForFences(dev, 1, &fence, VK_TRUE, timeoutNanoseconds); r != VK_SUCCESS) {
    // The work may still be running: wait it out so freeing the command buffer is legal.
    (void)waitIdle();
    return vulkanError(r, "vkWaitForFences (" + std::string(what) + ")");
  }
  return {};
}

Result<void> VulkanContext::submit(const VkSubmitInfo2& batch, VkFence fence,
                                   std::string_view what) {
  assert(impl_ && "use of a moved-from VulkanContext");
  const std::lock_guard<std::mutex> queueLock(impl_->queueMutex);
  if (VkResult r = vkQueueSubmit2(impl_->queue, 1, &batch, fence); r != VK_SUCCESS) {
    return vulkanError(r, "vkQueueSubmit2 (" + std::string(what) + ")");
  }
  return {};
}

Result<void> VulkanContext::waitIdle() {
  const std::lock_guard<std::mutex> queueLock(impl_->queueMutex);
  if (VkResult r = vkDeviceWaitIdle(impl_->device.get()); r != VK_SUCCESS) {
    return vulkanError(r, "vkDeviceWaitIdle");
  }
  return {};
}

Result<UniqueSemaphore> VulkanContext::createTimelineSemaphore(uint64_t initialValue) const {
  VkSemaphoreTypeCreateInfo typeInfo{};
  typeInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO;
  typeInfo.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
  typeInfo.initialValue = initialValue;
  VkSemaphoreCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
  info.pNext = &typeInfo;
  VkSemaphore raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateSemaphore(impl_->device.get(), &info, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateSemaphore (timeline)");
  }
  return UniqueSemaphore(impl_->device.get(), raw);
}

void VulkanContext::setObjectName(VkObjectType type, uint64_t handle,
                                  const char* name) const noexcept {
  if (impl_->setObjectName == nullptr || handle == 0) return;
  VkDebugUtilsObjectNameInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT;
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = name;
  impl_->setObjectName(impl_->device.get(), &info);
}

void destroyDebugMessenger(VkInstance instance, VkDebugUtilsMessengerEXT messenger,
                           const VkAllocationCallbacks* allocator) noexcept {
  auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
      vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
  if (destroy != nullptr) destroy(instance, messenger, allocator);
}

}  // namespace pbdam::gpu
