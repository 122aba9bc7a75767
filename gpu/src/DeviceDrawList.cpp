// The draw list made on the device (DeviceDrawList.h). Built with -ffp-contract=off like
// runtime/src/PatchDraw.cpp, whose templates it uploads.
#include "DeviceDrawList.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Selection.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

const uint32_t kDrawListComp[] =
#include "draw_list.comp.inc"
    ;

constexpr std::uint32_t kGroupSize = 256;  // draw_list.comp's local size and scan width

using Double4 = std::array<double, 4>;

/// One node as draw_list.comp reads it (std430): see DrawNode there.
struct DrawNode final {
  std::array<Double4, 3> corner;
  std::array<Double4, 3> edgeStart;
  std::array<Double4, 3> edgeDir;
  std::array<Double4, 3> edgeNormal;
  std::array<Double4, 3> edgeDelta;
  Double4 axis1;
  Double4 axis2;
  Double4 normal0;
  Double4 delta1;
  Double4 delta2;
  Double4 texQ;
  PatchDrawRecord record;
  std::array<float, 4> blendTexture;
  std::array<std::uint32_t, 4> draw;  ///< index count, first index, vertex offset, flags
  std::array<float, 4> aux;           ///< x: the parent tile's layer
};
static_assert(sizeof(DrawNode) == 1152);

/// The frame (std430): see Frame in draw_list.comp.
struct DrawFrame final {
  Double4 camera;
  double tolerance;
  double morphRange;
  double heightStep;
  double span;
  double pad0;
  double pad;
  std::uint32_t count;
  std::uint32_t groups;
  std::uint32_t pad1;
  std::uint32_t pad2;
};
static_assert(sizeof(DrawFrame) == 96);

Double4 d4(const glm::dvec3& v, double w = 0.0) { return {v.x, v.y, v.z, w}; }

DrawNode drawNode(const PatchDrawTemplate& t, const ResidentDraw& where, int level) {
  DrawNode n{};
  for (std::size_t k = 0; k < 3; ++k) {
    const PatchDrawTemplate::Edge& e = t.edges[k];
    n.corner[k] = d4(t.corner[k]);
    n.edgeStart[k] = d4(e.start, e.sag);
    n.edgeDir[k] = d4(e.direction, e.lengthSquared);
    n.edgeNormal[k] = d4(e.normal);
    n.edgeDelta[k] = d4(e.normalDelta);
  }
  n.axis1 = d4(t.axis1, t.a11);
  n.axis2 = d4(t.axis2, t.a22);
  n.normal0 = d4(t.normal0, t.a12);
  n.delta1 = d4(t.normalDelta1, t.det);
  n.delta2 = d4(t.normalDelta2, t.minHeightMeters);
  n.texQ = d4(t.texCenter, t.maxHeightMeters);
  n.record = t.record;
  n.blendTexture = t.blendTexture;
  n.draw = {where.indexCount, where.firstIndex, where.vertexOffset,
            (where.parentTile ? 1U : 0U) | (static_cast<std::uint32_t>(level) << 8)};
  n.aux = {t.blendLayer, 0.0f, 0.0f, 0.0f};
  return n;
}

/// The nodes in refine()'s depth-first order: roots in order, first child before second.
std::vector<std::uint32_t> depthFirstOrder(const DiamondIndex& index) {
  std::vector<std::uint32_t> order;
  order.reserve(index.nodes.size());
  std::vector<std::uint32_t> stack;
  for (const std::uint32_t root : index.roots) {
    stack.push_back(root);
    while (!stack.empty()) {
      const std::uint32_t i = stack.back();
      stack.pop_back();
      order.push_back(i);
      if (!index.nodes[i].leaf) {
        stack.push_back(index.nodes[i].firstChild + 1);
        stack.push_back(index.nodes[i].firstChild);
      }
    }
  }
  return order;
}

}  // namespace

Result<DeviceDrawList> DeviceDrawList::create(VulkanContext& context, const DatasetView& dataset,
                                              const GpuSelector& selector,
                                              std::span<const ResidentDraw> residency,
                                              bool readableRecords, double exaggeration) {
  const DiamondIndex& index = selector.index();
  if (residency.size() != index.nodes.size()) {
    return makeError(ErrorCode::InvalidArgument,
                     "device draw list: " + std::to_string(residency.size()) +
                         " residency entries for " + std::to_string(index.nodes.size()) + " nodes");
  }
  DeviceDrawList list;
  list.constants_ = patchDrawConstants(dataset, exaggeration);
  list.nodeCount_ = static_cast<std::uint32_t>(index.nodes.size());
  list.groups_ = (list.nodeCount_ + kGroupSize - 1) / kGroupSize;
  list.groupsPerRow_ = selector.groupsPerRow();

  std::vector<DrawNode> table(index.nodes.size());
  std::vector<std::uint32_t> parents(index.nodes.size());
  for (std::size_t i = 0; i < index.nodes.size(); ++i) {
    const DiamondIndex::Node& place = index.nodes[i];
    parents[i] = place.parent;
    const ResidentDraw& where = residency[i];
    if (where.indexCount == 0) continue;
    ++list.capacity_;
    const PatchDrawTemplate t =
        makePatchDrawTemplate(dataset, place.key, dataset.node(place.key), where.textureLayer,
                              where.parentTile, where.parentTextureLayer, exaggeration);
    table[i] = drawNode(t, where, place.level);
  }
  const std::vector<std::uint32_t> order = depthFirstOrder(index);

  const auto make = [&](GpuBuffer& out, std::uint64_t bytes, VkBufferUsageFlags usage,
                        MemoryUse use, const char* name) -> Result<void> {
    auto made = createBuffer(context, std::max<std::uint64_t>(bytes, 16),
                             usage | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, use, name);
    if (!made) return std::move(made).error();
    out = std::move(*made);
    return {};
  };
  const auto upload = [&](GpuBuffer& out, const void* data, std::uint64_t bytes,
                          const char* name) -> Result<void> {
    if (auto r = make(out, bytes, 0, MemoryUse::HostUpload, name); !r) return r;
    if (bytes > 0) std::memcpy(out.mappedBytes().data(), data, bytes);
    return out.flushHostWrites();
  };
  const std::uint64_t draws = std::max<std::uint32_t>(list.capacity_, 1);
  Result<void> made =
      upload(list.nodes_, table.data(), table.size() * sizeof(DrawNode), "draw list nodes");
  if (made) made = upload(list.order_, order.data(), order.size() * 4, "draw list order");
  if (made) made = upload(list.parents_, parents.data(), parents.size() * 4, "draw list parents");
  if (made)
    made = make(list.frame_, sizeof(DrawFrame), 0, MemoryUse::HostUpload, "draw list frame");
  if (made) {
    made = make(list.records_, draws * sizeof(PatchDrawRecord), 0,
                readableRecords ? MemoryUse::HostReadback : MemoryUse::DeviceLocal,
                "draw list records");
  }
  if (made) {
    made = make(list.slots_, std::uint64_t{list.nodeCount_} * 4, 0, MemoryUse::DeviceLocal,
                "draw list slots");
  }
  if (made) {
    made = make(list.groupSums_, std::uint64_t{list.groups_} * 4, 0, MemoryUse::DeviceLocal,
                "draw list group sums");
  }
  if (made) {
    made = make(list.commands_, draws * sizeof(VkDrawIndexedIndirectCommand),
                VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, MemoryUse::DeviceLocal, "draw list commands");
  }
  if (made) {
    made = make(list.count_, 16,
                VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                MemoryUse::HostReadback, "draw list count");
  }
  if (!made) return made.error();
  auto program = ComputeProgram::create(
      context, kDrawListComp, "draw_list.comp",
      {&list.records_, &list.nodes_, &list.frame_, &selector.screenErrors(), &selector.nodeStates(),
       &list.order_, &list.slots_, &list.groupSums_, &list.commands_, &list.count_, &list.parents_},
      sizeof(std::uint32_t));
  if (!program) return std::move(program).error();
  list.program_.emplace(std::move(*program));
  return list;
}

Result<void> DeviceDrawList::record(VkCommandBuffer cmd, const Camera& camera,
                                    const RefinementOptions& refinement) {
  DrawFrame f{};
  const glm::dvec3 eye = camera.position();
  f.camera = {eye.x, eye.y, eye.z, 0.0};
  f.tolerance = refinement.tolerancePixels;
  f.morphRange = refinement.morphRange;
  f.heightStep = constants_.heightStepMeters;
  f.span = constants_.heightSpanMeters;
  f.count = nodeCount_;
  f.groups = groups_;
  std::memcpy(frame_.mappedBytes().data(), &f, sizeof f);
  if (auto r = frame_.flushHostWrites(); !r) return r;

  vkCmdFillBuffer(cmd, count_.buffer(), 0, VK_WHOLE_SIZE, 0);
  transferToComputeBarrier(cmd);
  program_->bind(cmd);
  for (std::uint32_t mode = 0; mode < 3; ++mode) {
    program_->push(cmd, std::as_bytes(std::span(&mode, 1)));
    if (mode == 1) {
      vkCmdDispatch(cmd, 1, 1, 1);
    } else {
      dispatchLinear(cmd, nodeCount_, kGroupSize, groupsPerRow_);
    }
    if (mode < 2) computeBarrier(cmd);
  }
  // The list feeds the indirect draw, its records the vertex shader, its count the host.
  memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                    VK_PIPELINE_STAGE_2_HOST_BIT,
                VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                    VK_ACCESS_2_HOST_READ_BIT);
  return {};
}

Result<DrawListTotals> DeviceDrawList::totals() const {
  if (auto r = count_.invalidateForHostRead(); !r) return std::move(r).error();
  std::array<std::uint32_t, 2> words{};
  std::memcpy(words.data(), count_.mappedBytes().data(), sizeof words);
  return DrawListTotals{words[0], words[1]};
}

Result<std::vector<PatchDrawRecord>> DeviceDrawList::readRecords() const {
  auto totalsNow = totals();
  if (!totalsNow) return std::move(totalsNow).error();
  if (!records_.mappedBytes().data()) {
    return makeError(ErrorCode::InvalidArgument, "device draw list: records are not readable");
  }
  if (auto r = records_.invalidateForHostRead(); !r) return std::move(r).error();
  std::vector<PatchDrawRecord> out(totalsNow->draws);
  std::memcpy(out.data(), records_.mappedBytes().data(), out.size() * sizeof(PatchDrawRecord));
  return out;
}

}  // namespace pbdam::gpu
