// The patch vertex shader's arithmetic on lavapipe, checked bit for bit: every vertex of every
// patch of real cuts (MOLA, ETOPO5; cameras from orbit down to 100 m, across face edges and
// corners) is run through the shader's position code (patch_position.glsl, captured by
// shaders/patch_capture.vert) and compared with pbdam::runtime::shaderVertexPosition, and vertices
// that several patches share (the same lattice point) must get identical floats from every patch —
// the property that makes the drawn surface crack-free (docs/architecture.md "Precision"). The same
// run captures each vertex's tile texture coordinates (patch_texcoord.glsl) and compares them with
// pbdam::runtime::shaderTexCoord, the CPU copy of that formula (not bit-exact: atan and inversesqrt
// are the device's), within 1e-3 texel.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <unordered_map>
#include <vector>

#include <glm/geometric.hpp>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/ShaderModule.h"
#include "pbdam/gpu/VulkanError.h"
#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

const uint32_t kCaptureVert[] =
#include "patch_capture.vert.inc"
    ;

struct CaptureVertex {
  std::uint16_t b1;
  std::uint16_t b2;
  float heightMeters;
  float targetHeightMeters;
  std::array<float, 3> offsetMeters;
};
static_assert(sizeof(CaptureVertex) == 24);

/// A point-list pipeline with rasterization discarded that runs patch_capture.vert.
class CapturePipeline {
 public:
  static Result<CapturePipeline> create(const VulkanContext& context) {
    VkDevice device = context.device();
    CapturePipeline p;
    std::array<VkDescriptorSetLayoutBinding, 2> bindings{};
    for (std::uint32_t b = 0; b < 2; ++b) {
      bindings[b].binding = b;
      bindings[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      bindings[b].descriptorCount = 1;
      bindings[b].stageFlags = VK_SHADER_STAGE_VERTEX_BIT;
    }
    VkDescriptorSetLayoutCreateInfo setInfo{};
    setInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    setInfo.bindingCount = 2;
    setInfo.pBindings = bindings.data();
    VkDescriptorSetLayout rawSet = VK_NULL_HANDLE;
    if (VkResult r = vkCreateDescriptorSetLayout(device, &setInfo, nullptr, &rawSet);
        r != VK_SUCCESS) {
      return vulkanError(r, "capture set layout");
    }
    p.setLayout = UniqueDescriptorSetLayout(device, rawSet);
    const VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(std::uint32_t)};
    VkPipelineLayoutCreateInfo layoutInfo{};
    layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &rawSet;
    layoutInfo.pushConstantRangeCount = 1;
    layoutInfo.pPushConstantRanges = &range;
    VkPipelineLayout rawLayout = VK_NULL_HANDLE;
    if (VkResult r = vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout);
        r != VK_SUCCESS) {
      return vulkanError(r, "capture pipeline layout");
    }
    p.layout = UniquePipelineLayout(device, rawLayout);

    auto module = createShaderModule(device, kCaptureVert, "patch_capture.vert");
    if (!module) return std::move(module).error();
    VkPipelineShaderStageCreateInfo stage{};
    stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = module->get();
    stage.pName = "main";
    VkVertexInputBindingDescription binding{0, sizeof(CaptureVertex), VK_VERTEX_INPUT_RATE_VERTEX};
    std::array<VkVertexInputAttributeDescription, 3> attributes{};
    attributes[0] = {0, 0, VK_FORMAT_R16G16_UINT, 0};
    attributes[1] = {1, 0, VK_FORMAT_R32G32_SFLOAT, 4};
    attributes[2] = {2, 0, VK_FORMAT_R32G32B32_SFLOAT, 12};
    VkPipelineVertexInputStateCreateInfo vertexInput{};
    vertexInput.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    vertexInput.vertexBindingDescriptionCount = 1;
    vertexInput.pVertexBindingDescriptions = &binding;
    vertexInput.vertexAttributeDescriptionCount = static_cast<std::uint32_t>(attributes.size());
    vertexInput.pVertexAttributeDescriptions = attributes.data();
    VkPipelineInputAssemblyStateCreateInfo assembly{};
    assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    VkPipelineRasterizationStateCreateInfo raster{};
    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.rasterizerDiscardEnable = VK_TRUE;
    raster.lineWidth = 1.0f;
    const VkFormat color = OffscreenTarget::kColorFormat;
    VkPipelineRenderingCreateInfo rendering{};
    rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachmentFormats = &color;
    rendering.depthAttachmentFormat = OffscreenTarget::kDepthFormat;
    VkGraphicsPipelineCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.pNext = &rendering;
    info.stageCount = 1;
    info.pStages = &stage;
    info.pVertexInputState = &vertexInput;
    info.pInputAssemblyState = &assembly;
    info.pRasterizationState = &raster;
    info.layout = rawLayout;
    VkPipeline rawPipeline = VK_NULL_HANDLE;
    if (VkResult r =
            vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &rawPipeline);
        r != VK_SUCCESS) {
      return vulkanError(r, "capture pipeline");
    }
    p.pipeline = UniquePipeline(device, rawPipeline);
    return p;
  }

  UniqueDescriptorSetLayout setLayout;
  UniquePipelineLayout layout;
  UniquePipeline pipeline;
};

/// The patches of one cut with their decoded vertices, laid out one after another.
struct CapturedCut {
  std::vector<NodeKey> nodes;
  std::vector<PatchDrawRecord> records;
  std::vector<std::uint32_t> firstVertex;  ///< per patch, into vertices
  std::vector<PatchVertex> vertices;
  std::vector<PatchVertexDisplacement> decoded;    ///< decoded h, target h and offset
  std::vector<std::int32_t> targets;               ///< each vertex's morph target
  std::vector<std::array<float, 4>> gpu;           ///< captured positions
  std::vector<std::array<float, 2>> gpuTexCoords;  ///< captured texture coordinates
};

/// One captured vertex, as patch_capture.vert writes it (std430).
struct CapturedVertex {
  std::array<float, 4> position;
  std::array<float, 4> texCoord;
};
static_assert(sizeof(CapturedVertex) == 32);

/// The longest edge of a record's corner triangle.
double recordSpan(const PatchDrawRecord& r) {
  double span = 0.0;
  for (const std::array<float, 4>& e : r.edgeVector) {
    span = std::max(span, glm::length(glm::dvec3(e[0], e[1], e[2])));
  }
  return span;
}

class PatchShader : public test::GpuTest {
 protected:
  // Decodes every patch of `cut`, with its morph targets, and makes its record for `camera`.
  static void decodeCut(const DatasetView& view, const Cut& cut, const Camera& camera,
                        CapturedCut& out) {
    PatchMesh mesh;
    std::vector<std::int32_t> targets;
    std::vector<std::byte> blob;
    for (const CutPatch& patch : cut.patches) {
      const NodeRecord record = view.node(patch.node);
      const auto bytes = view.face(patch.node.face).readPatchBlobs(record, blob);
      ASSERT_TRUE(bytes.ok());
      ASSERT_TRUE(decodePatch(bytes->patch, mesh, "test").ok());
      ASSERT_TRUE(decodeMorphTargets(bytes->morph, mesh, targets, "test").ok());
      out.nodes.push_back(patch.node);
      PatchDrawInput input{.node = patch.node, .record = record};
      input.morph = patch.morph;
      out.records.push_back(makePatchDrawRecord(view, input, camera.position()));
      out.firstVertex.push_back(static_cast<std::uint32_t>(out.vertices.size()));
      const PatchVertexPlacement placement(view, patch.node, record);
      for (std::size_t k = 0; k < mesh.vertices.size(); ++k) {
        const PatchVertex& v = mesh.vertices[k];
        PatchVertexDisplacement d, t;
        ASSERT_TRUE(placement.displacement(v, d));
        ASSERT_TRUE(placement.displacement(PatchVertex{v.b1, v.b2, targets[k]}, t));
        d.targetHeightMeters = t.heightMeters;
        out.vertices.push_back(v);
        out.decoded.push_back(d);
        out.targets.push_back(targets[k]);
      }
    }
    out.firstVertex.push_back(static_cast<std::uint32_t>(out.vertices.size()));
    ASSERT_GT(out.vertices.size(), 0u);
  }

  // Runs every vertex of `cut` through the capture shader for `camera`.
  void capture(const DatasetView& view, const Cut& cut, const Camera& camera, CapturedCut& out) {
    decodeCut(view, cut, camera, out);
    if (HasFatalFailure()) return;

    auto pipeline = CapturePipeline::create(context());
    ASSERT_TRUE(pipeline.ok()) << pipeline.error().message;
    auto target = OffscreenTarget::create(context(), 8, 8);
    ASSERT_TRUE(target.ok()) << target.error().message;
    const VkDeviceSize vertexBytes = sizeof(CaptureVertex) * out.vertices.size();
    auto vertexBuffer = createBuffer(context(), vertexBytes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                     MemoryUse::HostUpload, "capture vertices");
    ASSERT_TRUE(vertexBuffer.ok());
    for (std::size_t i = 0; i < out.vertices.size(); ++i) {
      const glm::vec3& o = out.decoded[i].offsetMeters;
      const CaptureVertex v{out.vertices[i].b1,
                            out.vertices[i].b2,
                            out.decoded[i].heightMeters,
                            out.decoded[i].targetHeightMeters,
                            {o.x, o.y, o.z}};
      std::memcpy(vertexBuffer->mappedBytes().data() + i * sizeof v, &v, sizeof v);
    }
    const VkDeviceSize recordBytes = sizeof(PatchDrawRecord) * out.records.size();
    auto recordBuffer = createBuffer(context(), recordBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                     MemoryUse::HostUpload, "capture records");
    ASSERT_TRUE(recordBuffer.ok());
    std::memcpy(recordBuffer->mappedBytes().data(), out.records.data(), recordBytes);
    const VkDeviceSize capturedBytes = sizeof(CapturedVertex) * out.vertices.size();
    auto captured = createBuffer(context(), capturedBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                 MemoryUse::HostReadback, "captured positions");
    ASSERT_TRUE(captured.ok());
    ASSERT_TRUE(vertexBuffer->flushHostWrites().ok());
    ASSERT_TRUE(recordBuffer->flushHostWrites().ok());

    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    VkDescriptorPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    poolInfo.maxSets = 1;
    poolInfo.poolSizeCount = 1;
    poolInfo.pPoolSizes = &size;
    VkDescriptorPool rawPool = VK_NULL_HANDLE;
    ASSERT_EQ(vkCreateDescriptorPool(context().device(), &poolInfo, nullptr, &rawPool), VK_SUCCESS);
    UniqueDescriptorPool pool(context().device(), rawPool);
    VkDescriptorSetLayout setLayout = pipeline->setLayout.get();
    VkDescriptorSetAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    allocate.descriptorPool = rawPool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &setLayout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    ASSERT_EQ(vkAllocateDescriptorSets(context().device(), &allocate, &set), VK_SUCCESS);
    const std::array<VkDescriptorBufferInfo, 2> infos = {
        VkDescriptorBufferInfo{recordBuffer->buffer(), 0, VK_WHOLE_SIZE},
        VkDescriptorBufferInfo{captured->buffer(), 0, VK_WHOLE_SIZE}};
    std::array<VkWriteDescriptorSet, 2> writes{};
    for (std::uint32_t b = 0; b < 2; ++b) {
      writes[b].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[b].dstSet = set;
      writes[b].dstBinding = b;
      writes[b].descriptorCount = 1;
      writes[b].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[b].pBufferInfo = &infos[b];
    }
    vkUpdateDescriptorSets(context().device(), 2, writes.data(), 0, nullptr);

    const Result<void> done = context().submitAndWait(
        [&](VkCommandBuffer cmd) {
          target->recordBeginRendering(cmd, {0.0f, 0.0f, 0.0f, 1.0f});
          vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline->pipeline.get());
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline->layout.get(), 0,
                                  1, &set, 0, nullptr);
          VkBuffer vb = vertexBuffer->buffer();
          const VkDeviceSize zero = 0;
          vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
          for (std::size_t p = 0; p < out.records.size(); ++p) {
            const auto recordIndex = static_cast<std::uint32_t>(p);
            vkCmdPushConstants(cmd, pipeline->layout.get(), VK_SHADER_STAGE_VERTEX_BIT, 0,
                               sizeof recordIndex, &recordIndex);
            vkCmdDraw(cmd, out.firstVertex[p + 1] - out.firstVertex[p], 1, out.firstVertex[p], 0);
          }
          vkCmdEndRendering(cmd);
          VkMemoryBarrier2 toHost{};
          toHost.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
          toHost.srcStageMask = VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
          toHost.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
          toHost.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
          toHost.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
          VkDependencyInfo dependency{};
          dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
          dependency.memoryBarrierCount = 1;
          dependency.pMemoryBarriers = &toHost;
          vkCmdPipelineBarrier2(cmd, &dependency);
        },
        "capture patch positions");
    ASSERT_TRUE(done.ok()) << done.error().message;
    ASSERT_TRUE(captured->invalidateForHostRead().ok());
    std::vector<CapturedVertex> vertices(out.vertices.size());
    std::memcpy(vertices.data(), captured->mappedBytes().data(), capturedBytes);
    for (const CapturedVertex& v : vertices) {
      out.gpu.push_back(v.position);
      out.gpuTexCoords.push_back({v.texCoord[0], v.texCoord[1]});
    }
  }

  void checkCameras(const std::filesystem::path& dir, const std::vector<CameraPose>& poses) {
    if (!context().caps().vertexPipelineStoresAndAtomics) {
      GTEST_SKIP() << "device lacks vertexPipelineStoresAndAtomics (position capture)";
    }
    const auto dataset = test::openDataset(dir);
    ASSERT_NE(dataset, nullptr);
    const DatasetView& view = dataset->view();
    for (const CameraPose& pose : poses) {
      SCOPED_TRACE(test::describe(pose));
      const Camera camera = test::cameraAt(view, pose, 640, 360);
      RefinementOptions options;
      options.tolerancePixels = 2.0;
      const Cut cut = refine(view, camera, options);
      ASSERT_FALSE(cut.patches.empty());
      CapturedCut captured;
      capture(view, cut, camera, captured);
      if (HasFatalFailure()) return;

      std::vector<PatchVertexPlacement> placements;
      for (const NodeKey& node : captured.nodes)
        placements.emplace_back(view, node, view.node(node));
      double worstDrawnError = -1.0;
      std::uint64_t mismatches = 0;
      std::uint64_t texCoordMismatches = 0;
      double worstTexels = 0.0;
      const double tileTexels = view.manifest().textureTileTexels;
      std::uint64_t shared = 0;
      std::uint64_t sharedMismatches = 0;
      // Lattice point → the first GPU position seen there.
      std::unordered_map<PointKey, std::array<float, 3>> atPoint;
      for (std::size_t p = 0; p < captured.records.size(); ++p) {
        const BinTriangle tri = view.triangle(captured.nodes[p]);
        for (std::uint32_t i = captured.firstVertex[p]; i < captured.firstVertex[p + 1]; ++i) {
          const PatchVertex& v = captured.vertices[i];
          const glm::vec3 cpu =
              shaderVertexPosition(captured.records[p], v.b1, v.b2, captured.decoded[i]);
          const std::array<float, 3> gpu = {captured.gpu[i][0], captured.gpu[i][1],
                                            captured.gpu[i][2]};
          if (std::bit_cast<std::uint32_t>(cpu.x) != std::bit_cast<std::uint32_t>(gpu[0]) ||
              std::bit_cast<std::uint32_t>(cpu.y) != std::bit_cast<std::uint32_t>(gpu[1]) ||
              std::bit_cast<std::uint32_t>(cpu.z) != std::bit_cast<std::uint32_t>(gpu[2])) {
            if (mismatches++ < 5) {
              ADD_FAILURE() << "patch face " << int{captured.nodes[p].face} << " tree "
                            << int{captured.nodes[p].tree} << " heap " << captured.nodes[p].heap
                            << " vertex (" << v.b1 << "," << v.b2 << "," << v.heightSteps
                            << "): GPU " << gpu[0] << "," << gpu[1] << "," << gpu[2] << " CPU "
                            << cpu.x << "," << cpu.y << "," << cpu.z;
            }
          }
          // A vertex the geomorph does not move is drawn at its terrain point.
          worstDrawnError = std::max(worstDrawnError,
                                     drawnError(captured, p, i, placements[p], camera.position()));
          // Texture coordinates: the CPU mirror of the same formula, from the same position.
          const glm::vec2 tc =
              shaderTexCoord(captured.records[p], glm::vec3(gpu[0], gpu[1], gpu[2]));
          const std::array<float, 2>& gpuTc = captured.gpuTexCoords[i];
          const double texels =
              std::max(std::fabs(static_cast<double>(tc.x) - static_cast<double>(gpuTc[0])),
                       std::fabs(static_cast<double>(tc.y) - static_cast<double>(gpuTc[1]))) *
              tileTexels;
          worstTexels = std::max(worstTexels, texels);
          if (!(texels <= 1e-3) && texCoordMismatches++ < 5) {
            ADD_FAILURE() << "patch heap " << captured.nodes[p].heap << " vertex (" << v.b1 << ","
                          << v.b2 << "): GPU texture coordinates " << gpuTc[0] << "," << gpuTc[1]
                          << " CPU " << tc.x << "," << tc.y << " (" << texels << " texels)";
          }
          // The vertex's lattice point: exact, every patch vertex is one.
          const std::int64_t one = kPatchBarycentricOne;
          const std::int64_t x = tri.apex.x * one + v.b1 * std::int64_t{tri.left.x - tri.apex.x} +
                                 v.b2 * std::int64_t{tri.right.x - tri.apex.x};
          const std::int64_t y = tri.apex.y * one + v.b1 * std::int64_t{tri.left.y - tri.apex.y} +
                                 v.b2 * std::int64_t{tri.right.y - tri.apex.y};
          ASSERT_EQ(x % one, 0) << "vertex off the lattice";
          ASSERT_EQ(y % one, 0) << "vertex off the lattice";
          const PointKey key = latticePointKey(
              view.latticeCells(), tri.face,
              LatticeXY{static_cast<std::int32_t>(x / one), static_cast<std::int32_t>(y / one)});
          const auto [it, inserted] = atPoint.try_emplace(key, gpu);
          if (!inserted) {
            ++shared;
            // Bit-identical on purpose: a shared lattice point must get the very same float bits
            // from every patch (watertightness), not merely equal values.
            // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison)
            const bool sameBits = std::memcmp(it->second.data(), gpu.data(), sizeof gpu) == 0;
            if (!sameBits && sharedMismatches++ < 5) {
              ADD_FAILURE() << "lattice point " << key << " drawn at " << it->second[0] << ","
                            << it->second[1] << "," << it->second[2] << " and at " << gpu[0] << ","
                            << gpu[1] << "," << gpu[2] << " (patch heap " << captured.nodes[p].heap
                            << ")";
            }
          }
        }
      }
      EXPECT_EQ(mismatches, 0u) << "of " << captured.vertices.size() << " vertices";
      EXPECT_EQ(texCoordMismatches, 0u)
          << "of " << captured.vertices.size() << " vertices; worst " << worstTexels << " texels";
      // Every vertex is drawn at its terrain point, so its texture coordinates lie in its tile's
      // inner square (the patch's part of the face), to float rounding (0.05 texel). A wrong
      // face or tile, or a vertex drawn beside its lattice point, is outside.
      const double border = view.manifest().textureBorderTexels / tileTexels;
      for (const std::array<float, 2>& tc : captured.gpuTexCoords) {
        ASSERT_TRUE(std::isfinite(tc[0]) && std::isfinite(tc[1]));
        ASSERT_GE(std::min(tc[0], tc[1]), border - 0.05 / tileTexels);
        ASSERT_LE(std::max(tc[0], tc[1]), 1.0 - border + 0.05 / tileTexels);
      }
      EXPECT_LE(worstDrawnError, 0.0) << "vertices drawn off their terrain points (relative)";
      EXPECT_EQ(sharedMismatches, 0u) << "of " << shared << " shared vertices";
      EXPECT_GT(shared, captured.records.size()) << "patches share edge vertices";
    }
    // The cuts morph (RefinementOptions' default range): vertices strictly between their two
    // heights were drawn, and shared ones still bit-identical from every patch.
    EXPECT_GT(morphing_, 0u);
  }

  // How far vertex i of patch p was drawn from its terrain point beyond a few roundings of the
  // sizes summed (the distance, the patch's corner triangle, the displacement and the offset):
  // ≤ 0 expected. A vertex the geomorph moves is not at its terrain point: it counts in
  // morphing_ instead (-1).
  double drawnError(const CapturedCut& captured, std::size_t p, std::size_t i,
                    const PatchVertexPlacement& placement, const glm::dvec3& eye) {
    const PatchVertex& v = captured.vertices[i];
    const float g = std::uint32_t{v.b1} + v.b2 == kPatchBarycentricOne
                        ? captured.records[p].morph[1]
                        : captured.records[p].morph[0];
    if (g > 0.0f && captured.targets[i] != v.heightSteps) {
      morphing_ += static_cast<std::uint64_t>(g < 1.0f);
      return -1.0;
    }
    const glm::dvec3 truth = exactVertexPosition(placement, v, eye);
    const double scale = glm::length(truth) + recordSpan(captured.records[p]) +
                         std::fabs(static_cast<double>(captured.decoded[i].heightMeters)) +
                         glm::length(glm::dvec3(captured.decoded[i].offsetMeters));
    const std::array<float, 4>& gpu = captured.gpu[i];
    return glm::length(glm::dvec3(gpu[0], gpu[1], gpu[2]) - truth) - std::ldexp(scale, -20);
  }

  std::uint64_t morphing_ = 0;
};

TEST_F(PatchShader, GpuPositionsAreBitIdenticalToTheCpuMirrorOnMars) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  checkCameras(dir, {
                        {0.0, 0.0, 8e6, 0.0, -90.0, 0.0},             // whole planet
                        {35.2644, 45.0, 4e5, 30.0, -60.0, 0.0},       // cube corner
                        {0.0, 45.0, 5e4, 90.0, -20.0, 0.0},           // face edge, oblique
                        {89.9, 10.0, 2e5, 0.0, -90.0, 0.0},           // north pole
                        {18.65, 226.2, 22000.0, 45.0, -10.0, 5.0},    // Olympus Mons flank
                        {-35.2644, -135.0, 100.0, 200.0, -5.0, 0.0},  // 100 m, corner
                    });
}

TEST_F(PatchShader, GpuPositionsAreBitIdenticalToTheCpuMirrorOnEarth) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  checkCameras(dir, {
                        {0.0, 0.0, 2e7, 0.0, -90.0, 0.0},
                        {35.2644, 135.0, 3e5, 0.0, -45.0, 0.0},
                        {-89.95, 0.0, 5e4, 0.0, -30.0, 0.0},
                        {27.99, 86.93, 12000.0, 180.0, -8.0, 0.0},  // Everest
                    });
}

}  // namespace
}  // namespace pbdam::gpu
