// pbdam_marker: a host program that draws pbdam's terrain and an object of its own — a marker at a
// latitude, longitude and height above the ground — into its own render pass and one depth
// buffer, so that the terrain hides the marker where a ridge is in front of it
// (docs/embedding.md "Drawing into your own pass"). The host owns the attachments, the command
// buffer and the submission; gpu::Terrain records its uploads and draws into them and gives the
// camera-relative origin and the double-precision matrices the marker is placed with. Without a
// marker in view the frame is `pbdam render`'s, byte for byte.
//   pbdam_marker DATASET LAT,LON,ALT[,HEADING,PITCH,ROLL] OUT.png WIDTH HEIGHT
//                [MLAT,MLON,HEIGHT_ABOVE_GROUND_M[,SIZE_M] [reversed-z|zero-near]]
#include <vulkan/vulkan.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/formats/ImageCodec.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"

namespace {

namespace gpu = pbdam::gpu;

// glslc -mfmt=c writes a braced initializer list.
const std::uint32_t kMarkerVert[] =
#include "marker.vert.inc"
    ;
const std::uint32_t kMarkerFrag[] =
#include "marker.frag.inc"
    ;

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;  // pbdam render's
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

/// Stops the program with a message (the helpers below return through it).
struct Failure {
  std::string message;
};

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS)
    throw Failure{std::string(what) + " failed (VkResult " + std::to_string(r) + ")"};
}
template <class T>
T take(pbdam::formats::Result<T> result) {
  if (!result) throw Failure{result.error().message};
  return std::move(*result);
}
void take(const pbdam::formats::Result<void>& result) {
  if (!result) throw Failure{result.error().message};
}

bool parseNumber(std::string_view text, std::uint32_t& value) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size() && value > 0;
}

/// The marker: where it is and how big.
struct Marker {
  double latDegrees = 0.0, lonDegrees = 0.0, heightAboveGroundMeters = 0.0;
  double sizeMeters = 20000.0;
};

std::optional<Marker> parseMarker(const std::string& text) {
  Marker m;
  double* fields[] = {&m.latDegrees, &m.lonDegrees, &m.heightAboveGroundMeters, &m.sizeMeters};
  std::size_t count = 0, start = 0;
  while (count < 4 && start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string field = text.substr(start, comma - start);
    const auto [end, ec] =
        std::from_chars(field.data(), field.data() + field.size(), *fields[count]);
    if (ec != std::errc() || end != field.data() + field.size()) return std::nullopt;
    ++count;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (count < 3 || m.sizeMeters <= 0.0) return std::nullopt;
  return m;
}

/// An image with its own memory, as a host makes its attachments.
struct Attachment {
  gpu::UniqueImage image;
  gpu::UniqueDeviceMemory memory;
  gpu::UniqueImageView view;
};

Attachment makeAttachment(const gpu::VulkanContext& context, VkFormat format,
                          VkImageUsageFlags usage, VkImageAspectFlags aspect, std::uint32_t width,
                          std::uint32_t height) {
  VkDevice device = context.device();
  VkImageCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  VkImage image = VK_NULL_HANDLE;
  check(vkCreateImage(device, &info, nullptr, &image), "vkCreateImage");
  Attachment a;
  a.image = gpu::UniqueImage(device, image);
  VkMemoryRequirements needs{};
  vkGetImageMemoryRequirements(device, image, &needs);
  const auto type = gpu::findMemoryType(context.memoryProperties(), needs.memoryTypeBits,
                                        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (!type) throw Failure{"no device-local memory for an attachment"};
  VkMemoryAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
  alloc.allocationSize = needs.size;
  alloc.memoryTypeIndex = *type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  check(vkAllocateMemory(device, &alloc, nullptr, &memory), "vkAllocateMemory");
  a.memory = gpu::UniqueDeviceMemory(device, memory);
  check(vkBindImageMemory(device, image, memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo viewInfo{};
  viewInfo.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
  viewInfo.image = image;
  viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
  viewInfo.format = format;
  viewInfo.subresourceRange = {aspect, 0, 1, 0, 1};
  VkImageView view = VK_NULL_HANDLE;
  check(vkCreateImageView(device, &viewInfo, nullptr, &view), "vkCreateImageView");
  a.view = gpu::UniqueImageView(device, view);
  return a;
}

gpu::UniqueShaderModule shaderModule(VkDevice device, const std::uint32_t* code,
                                     std::size_t bytes) {
  VkShaderModuleCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  info.codeSize = bytes;
  info.pCode = code;
  VkShaderModule module = VK_NULL_HANDLE;
  check(vkCreateShaderModule(device, &info, nullptr, &module), "vkCreateShaderModule");
  return gpu::UniqueShaderModule(device, module);
}

/// The marker's pipeline: the host's own, for the same attachments and depth convention as the
/// terrain's (depth tested and written), no culling.
struct MarkerPipeline {
  gpu::UniquePipelineLayout layout;
  gpu::UniquePipeline pipeline;
};

MarkerPipeline makeMarkerPipeline(VkDevice device, gpu::DepthConvention depth) {
  MarkerPipeline p;
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(float) * 16};
  VkPipelineLayoutCreateInfo layoutInfo{};
  layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  check(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &layout), "vkCreatePipelineLayout");
  p.layout = gpu::UniquePipelineLayout(device, layout);

  const auto vert = shaderModule(device, kMarkerVert, sizeof kMarkerVert);
  const auto frag = shaderModule(device, kMarkerFrag, sizeof kMarkerFrag);
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  for (auto& s : stages) {
    s.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    s.pName = "main";
  }
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert.get();
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag.get();
  VkVertexInputBindingDescription binding{0, sizeof(float) * 3, VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attribute{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0};
  VkPipelineVertexInputStateCreateInfo vertexInput{};
  vertexInput.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  vertexInput.vertexBindingDescriptionCount = 1;
  vertexInput.pVertexBindingDescriptions = &binding;
  vertexInput.vertexAttributeDescriptionCount = 1;
  vertexInput.pVertexAttributeDescriptions = &attribute;
  VkPipelineInputAssemblyStateCreateInfo assembly{};
  assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{};
  viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{};
  raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{};
  multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depthState{};
  depthState.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depthState.depthTestEnable = VK_TRUE;
  depthState.depthWriteEnable = VK_TRUE;
  depthState.depthCompareOp = gpu::nearerPasses(depth);
  VkPipelineColorBlendAttachmentState blendAttachment{};
  blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                   VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo blend{};
  blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  const std::array<VkDynamicState, 2> dynamicStates = {VK_DYNAMIC_STATE_VIEWPORT,
                                                       VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = static_cast<std::uint32_t>(dynamicStates.size());
  dynamic.pDynamicStates = dynamicStates.data();
  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &kColorFormat;
  rendering.depthAttachmentFormat = kDepthFormat;
  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  info.pNext = &rendering;
  info.stageCount = static_cast<std::uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &vertexInput;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depthState;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
        "vkCreateGraphicsPipelines (marker)");
  p.pipeline = gpu::UniquePipeline(device, pipeline);
  return p;
}

/// An octahedron `size` across around the marker's point, in float metres relative to the
/// terrain's camera-relative origin: positions subtracted in double, then rounded.
std::vector<float> markerTriangles(const pbdam::runtime::Planet& planet, const Marker& m,
                                   double groundMeters, const glm::dvec3& origin) {
  const glm::dvec3 centre = planet.geodeticToEcef(
      m.latDegrees, m.lonDegrees, groundMeters + m.heightAboveGroundMeters + m.sizeMeters / 2);
  const double r = m.sizeMeters / 2;
  const std::array<glm::dvec3, 6> corner = {glm::dvec3(r, 0, 0), glm::dvec3(-r, 0, 0),
                                            glm::dvec3(0, r, 0), glm::dvec3(0, -r, 0),
                                            glm::dvec3(0, 0, r), glm::dvec3(0, 0, -r)};
  const int faces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                           {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  std::vector<float> out;
  for (const auto& face : faces) {
    for (const int v : face) {
      const glm::dvec3 p = centre + corner[static_cast<std::size_t>(v)] - origin;
      out.insert(out.end(),
                 {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
    }
  }
  return out;
}

/// A layout transition of a whole image (one level, one layer).
void transition(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkImageLayout from,
                VkImageLayout to, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkImageMemoryBarrier2 barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  barrier.srcStageMask = srcStage;
  barrier.srcAccessMask = srcAccess;
  barrier.dstStageMask = dstStage;
  barrier.dstAccessMask = dstAccess;
  barrier.oldLayout = from;
  barrier.newLayout = to;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.image = image;
  barrier.subresourceRange = {aspect, 0, 1, 0, 1};
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.imageMemoryBarrierCount = 1;
  dependency.pImageMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dependency);
}

/// What the command line asks for.
struct Request {
  pbdam::runtime::Viewport viewport;
  std::optional<Marker> marker;
  gpu::DepthConvention depth = gpu::DepthConvention::ReversedZ;
};

std::optional<Request> parseRequest(int argc, char** argv) {
  Request r;
  if (argc < 6 || argc > 8 || !parseNumber(argv[4], r.viewport.width) ||
      !parseNumber(argv[5], r.viewport.height)) {
    return std::nullopt;
  }
  if (argc >= 7) {
    r.marker = parseMarker(argv[6]);
    if (!r.marker) return std::nullopt;
  }
  if (argc == 8) {
    const std::string_view d = argv[7];
    if (d == "zero-near") {
      r.depth = gpu::DepthConvention::ZeroNearOneFar;
    } else if (d != "reversed-z") {
      return std::nullopt;
    }
  }
  return r;
}

/// The host's side of one frame: its attachments, readback buffer, marker and command buffer.
class MarkerFrame {
 public:
  MarkerFrame(gpu::VulkanContext& context, const Request& request)
      : context_(context),
        request_(request),
        width_(request.viewport.width),
        height_(request.viewport.height),
        colour_(
            makeAttachment(context, kColorFormat,
                           VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                           VK_IMAGE_ASPECT_COLOR_BIT, width_, height_)),
        depth_(makeAttachment(context, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                              VK_IMAGE_ASPECT_DEPTH_BIT, width_, height_)),
        readback_(take(gpu::createBuffer(context, std::uint64_t{width_} * height_ * 4,
                                         VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         gpu::MemoryUse::HostReadback, "marker readback"))),
        pipeline_(makeMarkerPipeline(context.device(), request.depth)) {
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.queueFamilyIndex = context.queueFamilyIndex();
    VkCommandPool pool = VK_NULL_HANDLE;
    check(vkCreateCommandPool(context.device(), &poolInfo, nullptr, &pool), "vkCreateCommandPool");
    pool_ = gpu::UniqueCommandPool(context.device(), pool);
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(context.device(), &allocate, &cmd_), "vkAllocateCommandBuffers");
  }

  /// The marker's triangles relative to the terrain's origin, in a vertex buffer.
  void placeMarker(const std::vector<float>& triangles) {
    markerVertices_ = static_cast<std::uint32_t>(triangles.size() / 3);
    vertices_ = take(gpu::createBuffer(
        context_, std::max<std::uint64_t>(triangles.size() * sizeof(float), 16),
        VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, gpu::MemoryUse::HostUpload, "marker vertices"));
    if (triangles.empty()) return;
    std::memcpy(vertices_.mappedBytes().data(), triangles.data(), triangles.size() * sizeof(float));
    take(vertices_.flushHostWrites());
  }

  /// Records the frame: attachments cleared, the terrain (its uploads submitted now), the marker
  /// depth-tested against it, the colour image copied for the host. Returns the terrain's
  /// timeline value the submission must signal.
  gpu::HostFrame record(gpu::Terrain& terrain) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd_, &begin), "vkBeginCommandBuffer");
    beginRendering();
    gpu::HostPass pass;
    pass.colorFormat = kColorFormat;
    pass.depthFormat = kDepthFormat;
    pass.depth = request_.depth;
    const gpu::HostFrame drawn = take(terrain.drawInto(cmd_, pass));
    if (markerVertices_ > 0) drawMarker(terrain);
    vkCmdEndRendering(cmd_);
    recordReadback();
    check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
    return drawn;
  }

  /// One submission on the context's queue, signalling the terrain's timeline value; waited for.
  void submit(const gpu::HostFrame& drawn) {
    VkCommandBufferSubmitInfo buffers{};
    buffers.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
    buffers.commandBuffer = cmd_;
    VkSemaphoreSubmitInfo signal{};
    signal.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
    signal.semaphore = drawn.semaphore;
    signal.value = drawn.signalValue;
    signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    VkSubmitInfo2 submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
    submit.commandBufferInfoCount = 1;
    submit.pCommandBufferInfos = &buffers;
    submit.signalSemaphoreInfoCount = 1;
    submit.pSignalSemaphoreInfos = &signal;
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence = VK_NULL_HANDLE;
    check(vkCreateFence(context_.device(), &fenceInfo, nullptr, &fence), "vkCreateFence");
    const gpu::UniqueFence owner(context_.device(), fence);
    take(context_.submit(submit, fence, "marker frame"));
    check(vkWaitForFences(context_.device(), 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    take(readback_.invalidateForHostRead());
  }

  /// The frame's RGBA bytes (after submit()).
  std::span<const std::byte> pixels() const { return readback_.mappedBytes(); }

 private:
  void beginRendering() {
    transition(cmd_, colour_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
               VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    transition(cmd_, depth_.image.get(), VK_IMAGE_ASPECT_DEPTH_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
               VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE, 0,
               VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT,
               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT);
    VkRenderingAttachmentInfo colourAttachment{};
    colourAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
    colourAttachment.imageView = colour_.view.get();
    colourAttachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    colourAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    colourAttachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    colourAttachment.clearValue.color = {{0.0f, 0.0f, 0.0f, 1.0f}};  // pbdam render's --clear
    VkRenderingAttachmentInfo depthAttachment{};
    depthAttachment.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
    depthAttachment.imageView = depth_.view.get();
    depthAttachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depthAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depthAttachment.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    depthAttachment.clearValue.depthStencil = {gpu::farDepth(request_.depth), 0};
    VkRenderingInfo rendering{};
    rendering.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
    rendering.renderArea = {{0, 0}, {width_, height_}};
    rendering.layerCount = 1;
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachments = &colourAttachment;
    rendering.pDepthAttachment = &depthAttachment;
    vkCmdBeginRendering(cmd_, &rendering);
  }

  void drawMarker(const gpu::Terrain& terrain) {
    // The marker's view-projection: the terrain's double matrices, multiplied, then rounded.
    const glm::mat4 viewProjection =
        glm::mat4(terrain.projection(request_.depth) * terrain.viewRotation());
    vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.pipeline.get());
    const VkViewport view{0.0f, 0.0f, static_cast<float>(width_), static_cast<float>(height_),
                          0.0f, 1.0f};
    const VkRect2D scissor{{0, 0}, {width_, height_}};
    vkCmdSetViewport(cmd_, 0, 1, &view);
    vkCmdSetScissor(cmd_, 0, 1, &scissor);
    vkCmdPushConstants(cmd_, pipeline_.layout.get(), VK_SHADER_STAGE_VERTEX_BIT, 0,
                       sizeof(float) * 16, glm::value_ptr(viewProjection));
    VkBuffer buffer = vertices_.buffer();
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(cmd_, 0, 1, &buffer, &zero);
    vkCmdDraw(cmd_, markerVertices_, 1, 0, 0);
  }

  void recordReadback() {
    transition(cmd_, colour_.image.get(), VK_IMAGE_ASPECT_COLOR_BIT,
               VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
               VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {width_, height_, 1};
    vkCmdCopyImageToBuffer(cmd_, colour_.image.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           readback_.buffer(), 1, &copy);
    VkBufferMemoryBarrier2 toHost{};
    toHost.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2;
    toHost.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    toHost.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    toHost.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
    toHost.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
    toHost.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toHost.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toHost.buffer = readback_.buffer();
    toHost.size = VK_WHOLE_SIZE;
    VkDependencyInfo dependency{};
    dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
    dependency.bufferMemoryBarrierCount = 1;
    dependency.pBufferMemoryBarriers = &toHost;
    vkCmdPipelineBarrier2(cmd_, &dependency);
  }

  gpu::VulkanContext& context_;
  const Request& request_;
  std::uint32_t width_, height_;
  Attachment colour_;
  Attachment depth_;
  gpu::GpuBuffer readback_;
  MarkerPipeline pipeline_;
  gpu::GpuBuffer vertices_;
  std::uint32_t markerVertices_ = 0;
  gpu::UniqueCommandPool pool_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
};

int run(int argc, char** argv) {
  const std::optional<Request> request = parseRequest(argc, argv);
  if (!request) {
    std::fprintf(stderr,
                 "usage: pbdam_marker DATASET LAT,LON,ALT[,HEADING,PITCH,ROLL] OUT.png WIDTH "
                 "HEIGHT [MLAT,MLON,HEIGHT_ABOVE_GROUND_M[,SIZE_M] [reversed-z|zero-near]]\n");
    return 2;
  }
  // The device: PBDAM_DEVICE if set (e.g. "lavapipe"), else the machine's best.
  gpu::VulkanContext context = take(gpu::VulkanContext::create());
  gpu::TerrainOptions options;  // exact mode, 3 px, 256 MiB of GPU cache
  options.viewport = request->viewport;
  auto terrain = take(gpu::Terrain::open(context, argv[1], options));
  const auto& planet = terrain->view().planet();
  const auto pose = take(pbdam::runtime::parseCameraPose(argv[2]));
  take(pbdam::runtime::validateCameraPose(pose, planet));
  const gpu::TerrainUpdate* frame =
      take(terrain->update(pbdam::runtime::Camera::fromPose(planet, pose, request->viewport)));

  MarkerFrame host(context, *request);
  const char* sight = "no marker";
  std::vector<float> triangles;
  if (const std::optional<Marker>& m = request->marker) {
    const double ground = take(terrain->heightAt(m->latDegrees, m->lonDegrees)).heightMeters;
    triangles = markerTriangles(planet, *m, ground, terrain->origin());
    // What the terrain's own line-of-sight query says of the marker's centre from the eye.
    const double eyeGround = take(terrain->heightAt(pose.latDegrees, pose.lonDegrees)).heightMeters;
    const auto line = take(terrain->lineOfSight(
        {pose.latDegrees, pose.lonDegrees, pose.altitudeMeters - eyeGround},
        {m->latDegrees, m->lonDegrees, m->heightAboveGroundMeters + m->sizeMeters / 2}));
    sight = line.result.visible ? "visible" : "hidden";
  }
  host.placeMarker(triangles);
  host.submit(host.record(*terrain));

  const std::span<const std::byte> bytes = host.pixels();
  std::uint64_t markerPixels = 0;
  for (std::size_t i = 0; i + 3 < bytes.size(); i += 4) {
    markerPixels += bytes[i] == std::byte{255} && bytes[i + 1] == std::byte{0} &&
                    bytes[i + 2] == std::byte{255};
  }
  const auto* codec = take(pbdam::formats::imageCodec());
  const std::uint32_t width = request->viewport.width, height = request->viewport.height;
  const pbdam::formats::RgbaPixels pixels{reinterpret_cast<const std::uint8_t*>(bytes.data()),
                                          width, height};
  take(codec->write(argv[3], pixels, 3, false));
  std::printf(
      "%s: %u x %u on %s: %llu patches, %llu triangles; marker %s (line of sight), %llu pixels "
      "drawn\n",
      argv[3], width, height, context.deviceInfo().name.c_str(),
      static_cast<unsigned long long>(frame->cut.patches.size()),
      static_cast<unsigned long long>(frame->cut.triangles), sight,
      static_cast<unsigned long long>(markerPixels));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // pbdam reports bad input as results; what it throws is a bug or exhausted memory.
  try {
    return run(argc, argv);
  } catch (const Failure& f) {
    std::fprintf(stderr, "pbdam_marker: %s\n", f.message.c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_marker: %s\n", e.what());
    return 1;
  }
}
