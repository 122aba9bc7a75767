// Turning VkResult codes into pbdam Errors: the VkResult's name plus a human-readable reason,
// so a failed Vulkan call reads like "vkCreateDevice (llvmpipe): VK_ERROR_FEATURE_NOT_PRESENT —
// a requested device feature is not supported".
#pragma once

#include "pbdam/formats/Result.h"

#include <vulkan/vulkan.h>

#include <string_view>

namespace pbdam::gpu {

/// The enumerator's name ("VK_SUCCESS", "VK_ERROR_DEVICE_LOST", ...), or
/// "VK_RESULT_UNKNOWN_VALUE" for values this build does not know (vulkanError then adds the
/// number). Thread-safe.
const char* vkResultName(VkResult result) noexcept;

/// A short English explanation of `result` ("the device ran out of memory"). Thread-safe.
const char* vkResultReason(VkResult result) noexcept;

/// An ErrorCode::DeviceError whose message is "<what>: <VK_NAME> — <reason>". `what` names the
/// call and, where useful, the object ("vkAllocateMemory (readback buffer, 16384 bytes)").
formats::Error vulkanError(VkResult result, std::string_view what);

}  // namespace pbdam::gpu
