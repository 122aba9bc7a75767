// ToneMapPass (internal to pbdam_gpu): the pipeline that turns a frame's radiance into display
// colour (shaders/tonemap.vert, tonemap.frag): a triangle over the viewport whose fragments read
// their pixel of the radiance image (set 0, binding 0) and write the exposure and tone curve of
// tone.glsl into a display-format attachment, no depth. OffscreenTarget::recordToneMap draws it.
// Thread-safety: immutable after creation.
#pragma once

#include <vulkan/vulkan.h>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/UniqueHandle.h"

namespace pbdam::gpu {

class VulkanContext;

class ToneMapPass final {
 public:
  /// Creates the layouts, the sampler (nearest; the shader reads texels by position) and the
  /// pipeline drawing into `displayFormat` with dynamic rendering.
  static formats::Result<ToneMapPass> create(const VulkanContext& context, VkFormat displayFormat);

  VkDescriptorSetLayout setLayout() const noexcept { return setLayout_.get(); }
  VkPipelineLayout layout() const noexcept { return layout_.get(); }
  VkPipeline pipeline() const noexcept { return pipeline_.get(); }
  VkSampler sampler() const noexcept { return sampler_.get(); }

 private:
  UniqueDescriptorSetLayout setLayout_;
  UniquePipelineLayout layout_;
  UniqueSampler sampler_;
  UniquePipeline pipeline_;
};

}  // namespace pbdam::gpu
