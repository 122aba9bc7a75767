// VkResult names and reasons for pbdam's DeviceError messages.
#include "pbdam/gpu/VulkanError.h"

#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {

const char* vkResultName(VkResult result) noexcept {
  switch (result) {
#define PBDAM_VK_RESULT_CASE(name) \
  case name:                       \
    return #name;
    PBDAM_VK_RESULT_CASE(VK_SUCCESS)
    PBDAM_VK_RESULT_CASE(VK_NOT_READY)
    PBDAM_VK_RESULT_CASE(VK_TIMEOUT)
    PBDAM_VK_RESULT_CASE(VK_EVENT_SET)
    PBDAM_VK_RESULT_CASE(VK_EVENT_RESET)
    PBDAM_VK_RESULT_CASE(VK_INCOMPLETE)
    PBDAM_VK_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    PBDAM_VK_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
    PBDAM_VK_RESULT_CASE(VK_ERROR_DEVICE_LOST)
    PBDAM_VK_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    PBDAM_VK_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    PBDAM_VK_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    PBDAM_VK_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    PBDAM_VK_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    PBDAM_VK_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    PBDAM_VK_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
    PBDAM_VK_RESULT_CASE(VK_ERROR_UNKNOWN)
    PBDAM_VK_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    PBDAM_VK_RESULT_CASE(VK_ERROR_FRAGMENTATION)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    PBDAM_VK_RESULT_CASE(VK_PIPELINE_COMPILE_REQUIRED)
    PBDAM_VK_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
    PBDAM_VK_RESULT_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    PBDAM_VK_RESULT_CASE(VK_SUBOPTIMAL_KHR)
    PBDAM_VK_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
    PBDAM_VK_RESULT_CASE(VK_ERROR_VALIDATION_FAILED_EXT)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INVALID_SHADER_NV)
    PBDAM_VK_RESULT_CASE(VK_ERROR_INVALID_DRM_FORMAT_MODIFIER_PLANE_LAYOUT_EXT)
    PBDAM_VK_RESULT_CASE(VK_ERROR_NOT_PERMITTED_KHR)
    PBDAM_VK_RESULT_CASE(VK_THREAD_IDLE_KHR)
    PBDAM_VK_RESULT_CASE(VK_THREAD_DONE_KHR)
    PBDAM_VK_RESULT_CASE(VK_OPERATION_DEFERRED_KHR)
    PBDAM_VK_RESULT_CASE(VK_OPERATION_NOT_DEFERRED_KHR)
    PBDAM_VK_RESULT_CASE(VK_ERROR_COMPRESSION_EXHAUSTED_EXT)
#undef PBDAM_VK_RESULT_CASE
    default:
      return "VK_RESULT_UNKNOWN_VALUE";
  }
}

const char* vkResultReason(VkResult result) noexcept {
  switch (result) {
    case VK_SUCCESS:
      return "success";
    case VK_NOT_READY:
      return "the fence or query is not ready yet";
    case VK_TIMEOUT:
      return "the wait timed out";
    case VK_INCOMPLETE:
      return "the returned array was too small for all results";
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return "the driver ran out of host memory";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      return "the device ran out of memory";
    case VK_ERROR_INITIALIZATION_FAILED:
      return "the driver could not initialise the object";
    case VK_ERROR_DEVICE_LOST:
      return "the device was lost (driver crash, hang or reset)";
    case VK_ERROR_MEMORY_MAP_FAILED:
      return "mapping the memory into the host address space failed";
    case VK_ERROR_LAYER_NOT_PRESENT:
      return "a requested layer is not installed (validation needs vulkan-validationlayers)";
    case VK_ERROR_EXTENSION_NOT_PRESENT:
      return "a requested extension is not supported";
    case VK_ERROR_FEATURE_NOT_PRESENT:
      return "a requested device feature is not supported";
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      return "no installed driver supports the requested Vulkan version (is an ICD installed? "
             "lavapipe comes with mesa-vulkan-drivers; check VK_ICD_FILENAMES)";
    case VK_ERROR_TOO_MANY_OBJECTS:
      return "too many objects of this type were created";
    case VK_ERROR_FORMAT_NOT_SUPPORTED:
      return "the format is not supported for this use";
    case VK_ERROR_FRAGMENTED_POOL:
    case VK_ERROR_FRAGMENTATION:
      return "the pool is too fragmented";
    case VK_ERROR_OUT_OF_POOL_MEMORY:
      return "the pool has no room left";
    case VK_ERROR_VALIDATION_FAILED_EXT:
      return "the validation layer rejected the call";
    default:
      return "unexpected Vulkan result";
  }
}

Error vulkanError(VkResult result, std::string_view what) {
  std::string message(what);
  message += ": ";
  message += vkResultName(result);
  if (std::string_view(vkResultName(result)) == "VK_RESULT_UNKNOWN_VALUE") {
    message += " (" + std::to_string(static_cast<int>(result)) + ")";
  }
  message += " — ";
  message += vkResultReason(result);
  return makeError(ErrorCode::DeviceError, std::move(message));
}

}  // namespace pbdam::gpu
