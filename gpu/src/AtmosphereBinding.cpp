// The atmosphere's tables as textures: descriptor set 4 of the patch pipeline
// (AtmosphereBinding.h).
#include "AtmosphereBinding.h"

#include <array>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/gtc/packing.hpp>
#include <string>
#include <vector>

#include "ComputeProgram.h"
#include "GraphicsPipeline.h"
#include "ImageUpload.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

/// RGBA32F where the device filters it linearly, else RGBA16F (always filterable).
VkFormat tableFormat(const VulkanContext& context) {
  VkFormatProperties properties{};
  vkGetPhysicalDeviceFormatProperties(context.physicalDevice(), VK_FORMAT_R32G32B32A32_SFLOAT,
                                      &properties);
  return (properties.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) != 0
             ? VK_FORMAT_R32G32B32A32_SFLOAT
             : VK_FORMAT_R16G16B16A16_SFLOAT;
}

/// A table (width × height, `layers` layers of it one after the other) uploaded as an image.
Result<GpuImage> uploadTable(VulkanContext& context, const runtime::AtmosphereTable& table,
                             std::uint32_t layers, bool array, const std::string& name) {
  const VkFormat format = tableFormat(context);
  ImageDesc desc;
  desc.format = format;
  desc.widthPixels = table.width;
  desc.heightPixels = table.height;
  desc.arrayLayers = layers;
  desc.arrayView = array;
  desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  auto image = createImage2D(context, desc, name);
  if (!image) return std::move(image).error();
  const std::size_t texels = table.rgb.size() / 3;
  const bool full = format == VK_FORMAT_R32G32B32A32_SFLOAT;
  const std::size_t bytes = texels * (full ? 16 : 8);
  auto staging = createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              MemoryUse::HostUpload, name + " staging");
  if (!staging) return std::move(staging).error();
  std::byte* out = staging->mappedBytes().data();
  for (std::size_t i = 0; i < texels; ++i) {
    const std::array<float, 4> rgba = {table.rgb[i * 3], table.rgb[i * 3 + 1], table.rgb[i * 3 + 2],
                                       1.0f};
    if (full) {
      std::memcpy(out + i * 16, rgba.data(), 16);
    } else {
      const std::array<std::uint16_t, 4> half = {
          glm::packHalf1x16(rgba[0]), glm::packHalf1x16(rgba[1]), glm::packHalf1x16(rgba[2]),
          glm::packHalf1x16(rgba[3])};
      std::memcpy(out + i * 8, half.data(), 8);
    }
  }
  if (auto r = staging->flushHostWrites(); !r) return std::move(r).error();
  VkImage target = image->image();
  Result<void> copied = context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        recordBarrier(cmd, uploadLayoutBarrier(target, VK_IMAGE_LAYOUT_UNDEFINED,
                                               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL));
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
        region.imageExtent = {table.width, table.height, 1};
        vkCmdCopyBufferToImage(cmd, staging->buffer(), target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               1, &region);
        recordBarrier(cmd, uploadLayoutBarrier(target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL));
      },
      name + " upload");
  if (!copied) return std::move(copied).error();
  return image;
}

// glslc -mfmt=c writes a braced initializer list, braces included.
const uint32_t kSkyViewComp[] =
#include "sky_view.comp.inc"
    ;

/// The sky-view table's size: azimuth × zenith angle (atmosphere.glsl).
constexpr std::uint32_t kSkyViewWidth = 256;
constexpr std::uint32_t kSkyViewHeight = 128;

/// Mirrors `SkyViewPush` in sky_view.comp.
struct SkyViewPush final {
  float camera[4];
  float sun[4];
};

runtime::AtmosphereTable emptyTable() {
  runtime::AtmosphereTable t;
  t.width = 1;
  t.height = 1;
  t.rgb.assign(3, 0.0f);
  return t;
}

void copy4(float* to, double x, double y, double z, double w) {
  to[0] = static_cast<float>(x);
  to[1] = static_cast<float>(y);
  to[2] = static_cast<float>(z);
  to[3] = static_cast<float>(w);
}

}  // namespace

Result<AtmosphereBinding> AtmosphereBinding::create(
    VulkanContext& context, const PatchPipeline& pipeline,
    const std::shared_ptr<const runtime::AtmosphereTables>& tables, const runtime::Planet& planet) {
  AtmosphereBinding b;
  b.context_ = &context;
  b.tables_ = tables;
  b.zStretch_ = planet.equatorialRadiusMeters() / planet.polarRadiusMeters();
  VkDevice device = context.device();
  const std::array<VkDescriptorPoolSize, 3> sizes = {
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 5},
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
      VkDescriptorPoolSize{VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1}};
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = static_cast<std::uint32_t>(sizes.size());
  poolInfo.pPoolSizes = sizes.data();
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(device, &poolInfo, nullptr, &rawPool); r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (atmosphere)");
  }
  b.pool_ = UniqueDescriptorPool(device, rawPool);
  VkDescriptorSetLayout layout = pipeline.atmosphereSetLayout();
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &layout;
  if (VkResult r = vkAllocateDescriptorSets(device, &allocate, &b.set_); r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (atmosphere)");
  }

  const runtime::AtmosphereTable empty = emptyTable();
  const runtime::AtmosphereTable& transmittance = tables ? tables->transmittance() : empty;
  const runtime::AtmosphereTable& scattering = tables ? tables->scattering() : empty;
  const runtime::AtmosphereTable& singleMie = tables ? tables->singleMieScattering() : empty;
  const runtime::AtmosphereTable& irradiance = tables ? tables->irradiance() : empty;
  auto t = uploadTable(context, transmittance, 1, false, "atmosphere transmittance");
  if (!t) return std::move(t).error();
  b.transmittance_ = std::move(*t);
  auto s = uploadTable(context, scattering, scattering.depth, true, "atmosphere scattering");
  if (!s) return std::move(s).error();
  b.scattering_ = std::move(*s);
  auto m = uploadTable(context, singleMie, singleMie.depth, true, "atmosphere single Mie");
  if (!m) return std::move(m).error();
  b.singleMie_ = std::move(*m);
  auto e = uploadTable(context, irradiance, 1, false, "atmosphere irradiance");
  if (!e) return std::move(e).error();
  b.irradiance_ = std::move(*e);

  AtmosphereBlock block{};
  if (tables) {
    const runtime::AtmosphereParameters& p = tables->parameters();
    const runtime::AtmosphereTableSizes& z = tables->sizes();
    copy4(block.solarIrradiance, p.solarIrradiance.x, p.solarIrradiance.y, p.solarIrradiance.z,
          p.sunAngularRadius);
    copy4(block.miePhaseG, p.miePhaseG.x, p.miePhaseG.y, p.miePhaseG.z, p.muSMin);
    copy4(block.radii, p.bottomRadius * 1e-3, p.topRadius * 1e-3, z.scatteringNu, z.scatteringMuS);
    copy4(block.sizes, z.scatteringMu, z.scatteringR, 1.0, b.zStretch_);
  } else {
    copy4(block.radii, 1.0, 2.0, 2.0, 2.0);
    copy4(block.sizes, 2.0, 1.0, 0.0, 1.0);
  }
  auto buffer = createBuffer(context, sizeof block, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                             MemoryUse::HostUpload, "atmosphere block");
  if (!buffer) return std::move(buffer).error();
  b.block_ = std::move(*buffer);
  std::memcpy(b.block_.mappedBytes().data(), &block, sizeof block);
  if (auto r = b.block_.flushHostWrites(); !r) return std::move(r).error();

  if (auto r = b.createSkyView(pipeline); !r) return std::move(r).error();

  const std::array<const GpuImage*, 4> images = {&b.transmittance_, &b.scattering_, &b.singleMie_,
                                                 &b.irradiance_};
  std::array<VkDescriptorImageInfo, 5> imageInfos{};
  std::array<VkWriteDescriptorSet, 6> writes{};
  for (std::size_t i = 0; i < images.size(); ++i) {
    imageInfos[i] = {pipeline.sampler(), images[i]->view(),
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = b.set_;
    writes[i].dstBinding = static_cast<std::uint32_t>(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &imageInfos[i];
  }
  const VkDescriptorBufferInfo blockInfo{b.block_.buffer(), 0, sizeof(AtmosphereBlock)};
  writes[4].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  writes[4].dstSet = b.set_;
  writes[4].dstBinding = 4;
  writes[4].descriptorCount = 1;
  writes[4].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  writes[4].pBufferInfo = &blockInfo;
  imageInfos[4] = {pipeline.sampler(), b.skyView_.view(), VK_IMAGE_LAYOUT_GENERAL};
  writes[5].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  writes[5].dstSet = b.set_;
  writes[5].dstBinding = 5;
  writes[5].descriptorCount = 1;
  writes[5].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[5].pImageInfo = &imageInfos[4];
  vkUpdateDescriptorSets(device, static_cast<std::uint32_t>(writes.size()), writes.data(), 0,
                         nullptr);
  return b;
}

Result<void> AtmosphereBinding::createSkyView(const PatchPipeline& pipeline) {
  VulkanContext& context = *context_;
  VkDevice device = context.device();
  ImageDesc desc;
  desc.format = VK_FORMAT_R16G16B16A16_SFLOAT;
  desc.widthPixels = tables_ ? kSkyViewWidth : 1;
  desc.heightPixels = tables_ ? kSkyViewHeight : 1;
  desc.usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
  auto image = createImage2D(context, desc, "atmosphere sky view");
  if (!image) return std::move(image).error();
  skyView_ = std::move(*image);
  VkImage raw = skyView_.image();
  Result<void> ready = context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        recordBarrier(cmd,
                      uploadLayoutBarrier(raw, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL));
      },
      "atmosphere sky view layout");
  if (!ready) return ready;

  auto setLayout = createSetLayout(device, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                                   VK_SHADER_STAGE_COMPUTE_BIT, "sky view");
  if (!setLayout) return std::move(setLayout).error();
  skyViewSetLayout_ = std::move(*setLayout);
  VkDescriptorSetLayout rawSet = skyViewSetLayout_.get();
  const std::array<VkDescriptorSetLayout, 2> setLayouts = {pipeline.atmosphereSetLayout(), rawSet};
  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(SkyViewPush)};
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.setLayoutCount = static_cast<std::uint32_t>(setLayouts.size());
  layoutInfo.pSetLayouts = setLayouts.data();
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreatePipelineLayout (sky view)");
  }
  skyViewLayout_ = UniquePipelineLayout(device, rawLayout);
  auto computePipeline = createComputePipeline(device, rawLayout, kSkyViewComp, "sky_view.comp");
  if (!computePipeline) return std::move(computePipeline).error();
  skyViewPipeline_ = std::move(*computePipeline);

  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = pool_.get();
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &rawSet;
  if (VkResult r = vkAllocateDescriptorSets(device, &allocate, &skyViewSet_); r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (sky view)");
  }
  const VkDescriptorImageInfo imageInfo{VK_NULL_HANDLE, skyView_.view(), VK_IMAGE_LAYOUT_GENERAL};
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = skyViewSet_;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  write.pImageInfo = &imageInfo;
  vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);
  return {};
}

void AtmosphereBinding::recordSkyView(VkCommandBuffer cmd, const PatchPush& frame) const {
  if (!tables_ || frame.camera[3] <= 0.0f) return;
  // After earlier frames' reads of the table (write-after-read: an execution dependency).
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, skyViewPipeline_.get());
  const std::array<VkDescriptorSet, 2> sets = {set_, skyViewSet_};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, skyViewLayout_.get(), 0,
                          static_cast<std::uint32_t>(sets.size()), sets.data(), 0, nullptr);
  SkyViewPush push{};
  std::memcpy(push.camera, frame.camera, 3 * sizeof(float));
  // The sun in the atmosphere's space, as toAtmosphereDirection does in the shaders.
  const glm::dvec3 sun =
      glm::normalize(glm::dvec3(frame.sunAmbient[0], frame.sunAmbient[1],
                                static_cast<double>(frame.sunAmbient[2]) * zStretch_));
  copy4(push.sun, sun.x, sun.y, sun.z, 0.0);
  vkCmdPushConstants(cmd, skyViewLayout_.get(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
  vkCmdDispatch(cmd, (kSkyViewWidth + 7) / 8, (kSkyViewHeight + 7) / 8, 1);
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT);
}

glm::dvec3 AtmosphereBinding::toAtmosphere(const glm::dvec3& ecefMeters) const noexcept {
  return glm::dvec3(ecefMeters.x, ecefMeters.y, ecefMeters.z * zStretch_) * 1e-3;
}

}  // namespace pbdam::gpu
