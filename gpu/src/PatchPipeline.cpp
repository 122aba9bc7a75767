// PatchPipeline: the patch drawing pipeline (PatchPipeline.h).
#include "PatchPipeline.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "GraphicsPipeline.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

using namespace pbdam::streaming;

namespace pbdam::gpu {
namespace {

// glslc -mfmt=c writes a braced initializer list, braces included.
const uint32_t kPatchVert[] =
#include "patch.vert.inc"
    ;
const uint32_t kPatchIndirectVert[] =
#include "patch_indirect.vert.inc"
    ;
const uint32_t kPatchFrag[] =
#include "patch.frag.inc"
    ;
const uint32_t kSkyVert[] =
#include "sky.vert.inc"
    ;
const uint32_t kSkyFrag[] =
#include "sky.frag.inc"
    ;

/// A descriptor set layout of one descriptor per binding, binding k of type types[k], every
/// binding visible to `stages`.
Result<UniqueDescriptorSetLayout> createBindingsLayout(VkDevice device,
                                                       std::span<const VkDescriptorType> types,
                                                       VkShaderStageFlags stages,
                                                       const char* what) {
  std::vector<VkDescriptorSetLayoutBinding> bindings(types.size());
  for (std::uint32_t k = 0; k < bindings.size(); ++k) {
    bindings[k].binding = k;
    bindings[k].descriptorType = types[k];
    bindings[k].descriptorCount = 1;
    bindings[k].stageFlags = stages;
  }
  VkDescriptorSetLayoutCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  info.bindingCount = static_cast<std::uint32_t>(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout raw = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorSetLayout(device, &info, nullptr, &raw); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkCreateDescriptorSetLayout (") + what + ")");
  }
  return UniqueDescriptorSetLayout(device, raw);
}

constexpr VkDescriptorType kSampled = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
constexpr VkDescriptorType kUniform = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;

/// Sets 1 and 2: a tile page's colour tiles (binding 0) and normal-map tiles (binding 1), both
/// sampled by the fragment shader.
Result<UniqueDescriptorSetLayout> createTilesSetLayout(VkDevice device) {
  constexpr std::array<VkDescriptorType, 2> kTypes{kSampled, kSampled};
  return createBindingsLayout(device, kTypes, VK_SHADER_STAGE_FRAGMENT_BIT, "tile pages");
}

/// Set 3: the overlay's image and uniform block, both read by the fragment shader.
Result<UniqueDescriptorSetLayout> createOverlaySetLayout(VkDevice device) {
  constexpr std::array<VkDescriptorType, 2> kTypes{kSampled, kUniform};
  return createBindingsLayout(device, kTypes, VK_SHADER_STAGE_FRAGMENT_BIT, "surface overlay");
}

/// Set 4: the atmosphere's tables (transmittance, scattering, single Mie scattering, irradiance),
/// its uniform block and the frame's sky-view table, read by the patch vertex stage (the aerial
/// perspective, per vertex), the sky's stages and the sky view's compute pass (its set 0).
Result<UniqueDescriptorSetLayout> createAtmosphereSetLayout(VkDevice device) {
  constexpr std::array<VkDescriptorType, 6> kTypes{kSampled, kSampled, kSampled,
                                                   kSampled, kUniform, kSampled};
  return createBindingsLayout(
      device, kTypes,
      VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT,
      "atmosphere");
}

/// The pipeline layout: the five descriptor sets (records, the patch's tile page, the page of
/// the coarser tile it blends in, the surface overlay, the atmosphere) and the per-draw push
/// constants.
Result<UniquePipelineLayout> createPatchLayout(
    VkDevice device, const std::array<VkDescriptorSetLayout, 5>& setLayouts) {
  VkPushConstantRange range{};
  range.stageFlags = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  range.offset = 0;
  range.size = sizeof(PatchPush);
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.setLayoutCount = static_cast<uint32_t>(setLayouts.size());
  layoutInfo.pSetLayouts = setLayouts.data();
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreatePipelineLayout (patch)");
  }
  return UniquePipelineLayout(device, rawLayout);
}

/// The fragment stage's kRadianceOutput (constant 0 of patch.frag and sky.frag): 1 keeps the
/// radiance for the tone map after the last pass, 0 tone-maps in the stage.
struct RadianceConstant final {
  VkBool32 value = VK_FALSE;
  VkSpecializationMapEntry entry{0, 0, sizeof(VkBool32)};
  VkSpecializationInfo info{1, &entry, sizeof(VkBool32), &value};
  explicit RadianceConstant(bool radiance) noexcept : value(radiance ? VK_TRUE : VK_FALSE) {}
  RadianceConstant(const RadianceConstant&) = delete;
  RadianceConstant& operator=(const RadianceConstant&) = delete;
};

/// The graphics pipeline: the patch shaders and their fixed-function state (the depth test of
/// the pass's convention, back-face culling, the vertex layout of PatchGpuVertex) for the pass's
/// attachments.
Result<UniquePipeline> createPatchGraphicsPipeline(VkDevice device, VkPipelineLayout layout,
                                                   const HostPass& pass,
                                                   std::span<const uint32_t> vertexSpirv,
                                                   const char* vertexName, bool radiance) {
  const RadianceConstant constant(radiance);
  VkVertexInputBindingDescription binding{};
  binding.binding = 0;
  binding.stride = sizeof(PatchGpuVertex);
  binding.inputRate = VK_VERTEX_INPUT_RATE_VERTEX;
  std::array<VkVertexInputAttributeDescription, 3> attributes{};
  attributes[0].location = 0;
  attributes[0].binding = 0;
  attributes[0].format = VK_FORMAT_R16G16_UINT;
  attributes[0].offset = 0;
  attributes[1].location = 1;
  attributes[1].binding = 0;
  attributes[1].format = VK_FORMAT_R32G32_SFLOAT;
  attributes[1].offset = offsetof(PatchGpuVertex, heightMeters);
  attributes[2].location = 2;
  attributes[2].binding = 0;
  attributes[2].format = VK_FORMAT_R32G32B32_SFLOAT;
  attributes[2].offset = offsetof(PatchGpuVertex, offsetMeters);
  VkPipelineVertexInputStateCreateInfo vertexInput{};
  vertexInput.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  vertexInput.vertexBindingDescriptionCount = 1;
  vertexInput.pVertexBindingDescriptions = &binding;
  vertexInput.vertexAttributeDescriptionCount = static_cast<uint32_t>(attributes.size());
  vertexInput.pVertexAttributeDescriptions = attributes.data();

  GraphicsPipelineDesc desc;
  desc.vertexSpirv = vertexSpirv;
  desc.vertexName = vertexName;
  desc.fragmentSpirv = kPatchFrag;
  desc.fragmentName = "patch.frag";
  desc.fragmentSpecialization = &constant.info;
  desc.vertexInput = &vertexInput;
  // Patch triangles wind counter-clockwise seen from outside the planet (checked on the test
  // datasets: every triangle of every patch). The projection's y flip keeps them
  // counter-clockwise in Vulkan's framebuffer convention.
  desc.cullMode = VK_CULL_MODE_BACK_BIT;
  desc.depthTest = true;
  desc.depthWrite = true;
  desc.depthCompare = nearerPasses(pass.depth);
  desc.pass = pass;
  desc.what = "patch";
  return createGraphicsPipeline(device, layout, desc);
}

/// The sky's pipeline: the band of view directions that can see air (sky.vert, sky.frag), no
/// vertex input, no culling, no depth test or writes: drawn before the terrain, which covers it,
/// for the pass's attachments and the patch layout.
Result<UniquePipeline> createSkyPipeline(VkDevice device, VkPipelineLayout layout,
                                         const HostPass& pass, bool radiance) {
  const RadianceConstant constant(radiance);
  GraphicsPipelineDesc desc;
  desc.vertexSpirv = kSkyVert;
  desc.vertexName = "sky.vert";
  desc.fragmentSpirv = kSkyFrag;
  desc.fragmentName = "sky.frag";
  desc.fragmentSpecialization = &constant.info;
  desc.pass = pass;
  desc.what = "sky";
  return createGraphicsPipeline(device, layout, desc);
}

}  // namespace

Result<PatchPipeline> PatchPipeline::create(const VulkanContext& context, VkFormat colorFormat,
                                            VkFormat depthFormat) {
  VkDevice device = context.device();
  PatchPipeline result;
  {
    auto records = createSetLayout(device, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                   VK_SHADER_STAGE_VERTEX_BIT, "patch draw records");
    if (!records) return std::move(records).error();
    result.recordsSetLayout_ = std::move(*records);
    auto tiles = createTilesSetLayout(device);
    if (!tiles) return std::move(tiles).error();
    result.tilesSetLayout_ = std::move(*tiles);
  }
  // Tiles: bilinear within a page, clamped at its edges (tiles carry a filtering border).
  auto sampler = createSampler(device, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                               VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK, "tiles");
  if (!sampler) return std::move(sampler).error();
  result.sampler_ = std::move(*sampler);
  auto overlayLayout = createOverlaySetLayout(device);
  if (!overlayLayout) return std::move(overlayLayout).error();
  result.overlaySetLayout_ = std::move(*overlayLayout);
  // The overlay: nearest, transparent outside the image.
  auto overlaySampler =
      createSampler(device, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER,
                    VK_BORDER_COLOR_FLOAT_TRANSPARENT_BLACK, "surface overlay");
  if (!overlaySampler) return std::move(overlaySampler).error();
  result.overlaySampler_ = std::move(*overlaySampler);
  auto atmosphereLayout = createAtmosphereSetLayout(device);
  if (!atmosphereLayout) return std::move(atmosphereLayout).error();
  result.atmosphereSetLayout_ = std::move(*atmosphereLayout);
  auto layout =
      createPatchLayout(device, {result.recordsSetLayout_.get(), result.tilesSetLayout_.get(),
                                 result.tilesSetLayout_.get(), result.overlaySetLayout_.get(),
                                 result.atmosphereSetLayout_.get()});
  if (!layout) return std::move(layout).error();
  result.layout_ = std::move(*layout);
  HostPass own;
  own.colorFormat = colorFormat;
  own.depthFormat = depthFormat;
  auto pipeline = createPatchGraphicsPipeline(device, result.layout_.get(), own, kPatchVert,
                                              "patch.vert", false);
  if (!pipeline) return std::move(pipeline).error();
  result.pipeline_ = std::move(*pipeline);
  auto sky = createSkyPipeline(device, result.layout_.get(), own, false);
  if (!sky) return std::move(sky).error();
  result.skyPipeline_ = std::move(*sky);
  const DeviceCaps& caps = context.caps();
  if (caps.shaderDrawParameters && caps.drawIndirectCount && caps.multiDrawIndirect) {
    auto indirect = createPatchGraphicsPipeline(device, result.layout_.get(), own,
                                                kPatchIndirectVert, "patch_indirect.vert", false);
    if (!indirect) return std::move(indirect).error();
    result.indirectPipeline_ = std::move(*indirect);
  }
  return result;
}

Result<UniquePipeline> PatchPipeline::createForHostPass(const VulkanContext& context,
                                                        const HostPass& pass) const {
  return createPatchGraphicsPipeline(context.device(), layout_.get(), pass, kPatchVert,
                                     "patch.vert (host pass)", false);
}

Result<RadiancePipelines> PatchPipeline::createRadiancePipelines(const VulkanContext& context,
                                                                 VkFormat radianceFormat,
                                                                 VkFormat depthFormat) const {
  VkDevice device = context.device();
  HostPass pass;
  pass.colorFormat = radianceFormat;
  pass.depthFormat = depthFormat;
  RadiancePipelines out;
  auto patch = createPatchGraphicsPipeline(device, layout_.get(), pass, kPatchVert,
                                           "patch.vert (radiance)", true);
  if (!patch) return std::move(patch).error();
  out.patch = std::move(*patch);
  auto sky = createSkyPipeline(device, layout_.get(), pass, true);
  if (!sky) return std::move(sky).error();
  out.sky = std::move(*sky);
  if (indirectPipeline_) {
    auto indirect = createPatchGraphicsPipeline(device, layout_.get(), pass, kPatchIndirectVert,
                                                "patch_indirect.vert (radiance)", true);
    if (!indirect) return std::move(indirect).error();
    out.indirect = std::move(*indirect);
  }
  return out;
}

}  // namespace pbdam::gpu
