// VkShaderModule creation from embedded SPIR-V.
#include "pbdam/gpu/ShaderModule.h"

#include "pbdam/gpu/VulkanError.h"

#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {

Result<UniqueShaderModule> createShaderModule(VkDevice device, std::span<const uint32_t> spirvWords,
                                              std::string_view name) {
  constexpr uint32_t kSpirvMagic = 0x07230203u;
  if (spirvWords.size() < 5 || spirvWords[0] != kSpirvMagic) {
    return makeError(ErrorCode::InvalidArgument, "shader " + std::string(name) +
                                                     " is not a SPIR-V module (" +
                                                     std::to_string(spirvWords.size()) + " words)");
  }
  VkShaderModuleCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  info.codeSize = spirvWords.size_bytes();
  info.pCode = spirvWords.data();
  VkShaderModule raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateShaderModule(device, &info, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateShaderModule (" + std::string(name) + ")");
  }
  return UniqueShaderModule(device, raw);
}

}  // namespace pbdam::gpu
