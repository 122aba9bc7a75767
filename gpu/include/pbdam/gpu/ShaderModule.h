// Creating VkShaderModules from SPIR-V words embedded at build time (pbdam_embed_shaders).
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <string_view>

namespace pbdam::gpu {

/// Creates a shader module from `spirvWords` (a whole SPIR-V module). `name` appears in error
/// messages. Errors: InvalidArgument for an empty or non-SPIR-V array, DeviceError otherwise.
/// Thread-safe (as vkCreateShaderModule).
formats::Result<UniqueShaderModule> createShaderModule(VkDevice device,
                                                       std::span<const uint32_t> spirvWords,
                                                       std::string_view name);

}  // namespace pbdam::gpu
