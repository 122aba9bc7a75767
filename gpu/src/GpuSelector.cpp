// The cut selected on the device (GpuSelector.h).
#include "pbdam/gpu/GpuSelector.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <unordered_set>
#include <vector>

#include "ComputeProgram.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/VulkanContext.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

const uint32_t kSelectComp[] =
#include "select.comp.inc"
    ;

constexpr std::uint32_t kGroupSize = 64;

/// One node as select.comp reads it (std430).
struct SelectNode final {
  std::array<double, 4> sphere;
  double error;
  double geometryError;
  std::uint32_t parent;
  std::uint32_t partner;
  std::uint32_t flags;
  std::uint32_t pad1;
};
static_assert(sizeof(SelectNode) == 64);

/// The frame's camera and options (std430).
struct SelectFrame final {
  std::array<double, 4> position;
  std::array<std::array<double, 4>, 5> planes;
  double tolerance;
  double radiusGrowth;  ///< ExaggerationBounds::radiusGrowthMeters, added to every radius
  std::uint32_t maxLevel;
  std::uint32_t culling;
  std::uint32_t count;
  std::uint32_t regionCount;
  double errorScale;  ///< ExaggerationBounds::errorScale, times every refinement error
  double pad;
};
static_assert(sizeof(SelectFrame) == 240);

/// A focus region as select.comp reads it (std430): its points are in the point buffer.
struct SelectRegion final {
  double width;
  double error;
  std::uint32_t firstPoint;
  std::uint32_t pointCount;
};
static_assert(sizeof(SelectRegion) == 24);

constexpr std::uint32_t kMaxRegions = 64;
constexpr std::uint32_t kMaxPoints = 4096;

}  // namespace

struct GpuSelector::Impl {
  VulkanContext* context = nullptr;
  const DatasetView* dataset = nullptr;
  std::optional<DiamondIndex> index;
  std::optional<ComputeProgram> program;
  GpuBuffer nodes;
  GpuBuffer frame;
  GpuBuffer screen;
  GpuBuffer state;
  GpuBuffer regions;
  GpuBuffer points;
  GpuBuffer wanted;
  std::uint32_t groupsPerRow = 65535;

  /// The focus regions' and the caller's predicate's inputs of one selection.
  Result<void> upload(const SelectionOptions& selection);
};

Result<void> GpuSelector::Impl::upload(const SelectionOptions& selection) {
  if (selection.focus.size() > kMaxRegions) {
    return makeError(ErrorCode::InvalidArgument,
                     "GPU selection: at most " + std::to_string(kMaxRegions) + " focus regions");
  }
  std::vector<SelectRegion> r;
  std::vector<std::array<double, 4>> p;
  for (const FocusRegion& region : selection.focus) {
    if (region.line.empty()) continue;
    r.push_back({region.widthMeters, region.errorMeters, static_cast<std::uint32_t>(p.size()),
                 static_cast<std::uint32_t>(region.line.size())});
    for (const glm::dvec3& x : region.line) p.push_back({x.x, x.y, x.z, 0.0});
  }
  if (p.size() > kMaxPoints) {
    return makeError(ErrorCode::InvalidArgument, "GPU selection: focus paths of at most " +
                                                     std::to_string(kMaxPoints) + " points in all");
  }
  if (!r.empty()) {  // memcpy from an empty vector's null data is undefined
    std::memcpy(regions.mappedBytes().data(), r.data(), r.size() * sizeof(SelectRegion));
    std::memcpy(points.mappedBytes().data(), p.data(), p.size() * sizeof(p[0]));
  }
  std::vector<std::uint32_t> w(index->nodes.size(), 0);
  if (selection.split) {
    for (std::size_t i = 0; i < w.size(); ++i) {
      const NodeKey& key = index->nodes[i].key;
      w[i] = selection.split(key, dataset->node(key)) ? 1U : 0U;
    }
  }
  std::memcpy(wanted.mappedBytes().data(), w.data(), w.size() * sizeof(std::uint32_t));
  for (const GpuBuffer* b : {&regions, &points, &wanted}) {
    if (auto flushed = b->flushHostWrites(); !flushed) return flushed;
  }
  return {};
}

Result<GpuSelector> GpuSelector::create(VulkanContext& context, const DatasetView& dataset,
                                        std::uint64_t tableBudgetBytes,
                                        std::uint32_t groupsPerRow) {
  if (!context.caps().shaderFloat64) {
    return makeError(ErrorCode::InvalidArgument,
                     "GPU selection needs 64-bit floats in shaders; the device has none");
  }
  auto impl = std::make_unique<Impl>();
  impl->context = &context;
  impl->dataset = &dataset;
  impl->groupsPerRow = std::max(groupsPerRow, 1U);
  // The node tables in the index space of DiamondIndex (parents and diamond partners shared
  // with the host's selection).
  impl->index.emplace(dataset);
  std::vector<SelectNode> table;
  table.reserve(impl->index->nodes.size());
  for (const DiamondIndex::Node& place : impl->index->nodes) {
    const NodeRecord r = dataset.node(place.key);
    SelectNode n{};
    n.sphere = {r.sphereCenter[0], r.sphereCenter[1], r.sphereCenter[2],
                static_cast<double>(r.sphereRadiusMeters)};
    n.error = refinementErrorMeters(dataset, place.level, static_cast<double>(r.errorMeters));
    n.geometryError = static_cast<double>(r.errorMeters);
    n.parent = place.parent;
    n.partner = place.partner;
    n.flags = (place.leaf ? 1U : 0U) | (static_cast<std::uint32_t>(place.level) << 8);
    table.push_back(n);
  }
  const std::uint64_t bytes = table.size() * sizeof(SelectNode);
  if (bytes > tableBudgetBytes) {
    return makeError(ErrorCode::InvalidArgument,
                     "the node tables need " + std::to_string(bytes) +
                         " bytes on the device, more than the budget of " +
                         std::to_string(tableBudgetBytes));
  }
  auto nodes =
      createBuffer(context, std::max<std::uint64_t>(bytes, 64), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                   MemoryUse::HostUpload, "selection nodes");
  if (!nodes) return std::move(nodes).error();
  std::memcpy(nodes->mappedBytes().data(), table.data(), bytes);
  if (auto r = nodes->flushHostWrites(); !r) return std::move(r).error();
  impl->nodes = std::move(*nodes);
  auto frame = createBuffer(context, sizeof(SelectFrame), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                            MemoryUse::HostUpload, "selection frame");
  if (!frame) return std::move(frame).error();
  impl->frame = std::move(*frame);
  auto screen = createBuffer(context, std::max<std::uint64_t>(table.size() * 8, 8),
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::HostReadback,
                             "selection screen errors");
  if (!screen) return std::move(screen).error();
  impl->screen = std::move(*screen);
  auto state =
      createBuffer(context, std::max<std::uint64_t>(table.size() * 4, 4),
                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUse::HostReadback, "selection state");
  if (!state) return std::move(state).error();
  impl->state = std::move(*state);
  const auto hostBuffer = [&](std::uint64_t size, const char* name,
                              GpuBuffer& out) -> Result<void> {
    auto made = createBuffer(context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             MemoryUse::HostUpload, name);
    if (!made) return std::move(made).error();
    out = std::move(*made);
    return {};
  };
  if (auto r =
          hostBuffer(sizeof(SelectRegion) * kMaxRegions, "selection focus regions", impl->regions);
      !r) {
    return std::move(r).error();
  }
  if (auto r = hostBuffer(std::uint64_t{32} * kMaxPoints, "selection focus points", impl->points);
      !r) {
    return std::move(r).error();
  }
  if (auto r = hostBuffer(std::max<std::uint64_t>(table.size() * 4, 4), "selection wanted",
                          impl->wanted);
      !r) {
    return std::move(r).error();
  }
  auto program = ComputeProgram::create(context, kSelectComp, "select.comp",
                                        {&impl->nodes, &impl->frame, &impl->screen, &impl->state,
                                         &impl->regions, &impl->points, &impl->wanted},
                                        sizeof(std::uint32_t));
  if (!program) return std::move(program).error();
  impl->program.emplace(std::move(*program));
  return GpuSelector(std::move(impl));
}

Result<void> GpuSelector::recordSelection(VkCommandBuffer cmd, const Camera& camera,
                                          const SelectionOptions& selection) {
  Impl& m = *impl_;
  const RefinementOptions& options = selection.refinement;
  if (auto r = m.upload(selection); !r) return r;
  const DatasetView& dataset = *m.dataset;
  const auto count = static_cast<std::uint32_t>(m.index->nodes.size());
  SelectFrame f{};
  const glm::dvec3 eye = camera.position();
  f.position = {eye.x, eye.y, eye.z, camera.pixelsPerRadian()};
  for (std::size_t k = 0; k < 5; ++k) {
    const glm::dvec4& p = camera.frustumPlanes()[k];
    f.planes[k] = {p.x, p.y, p.z, p.w};
  }
  f.tolerance = options.tolerancePixels;
  const ExaggerationBounds bounds = exaggerationBounds(dataset, options.exaggeration);
  f.radiusGrowth = bounds.radiusGrowthMeters;
  f.errorScale = bounds.errorScale;
  f.maxLevel = static_cast<std::uint32_t>(
      options.maxLevel < 0 ? dataset.depth() : std::min(options.maxLevel, dataset.depth()));
  f.culling = options.frustumCulling ? 1U : 0U;
  f.count = count;
  f.regionCount = static_cast<std::uint32_t>(selection.focus.size());
  std::memcpy(m.frame.mappedBytes().data(), &f, sizeof f);
  if (auto r = m.frame.flushHostWrites(); !r) return r;

  const std::uint32_t closureSteps = 2 * (static_cast<std::uint32_t>(dataset.depth()) + 1);
  m.program->bind(cmd);
  const auto dispatch = [&](std::uint32_t mode) {
    m.program->push(cmd, std::as_bytes(std::span(&mode, 1)));
    dispatchLinear(cmd, count, kGroupSize, m.groupsPerRow);
    computeBarrier(cmd);
  };
  dispatch(0);
  for (std::uint32_t s = 0; s < closureSteps; ++s) dispatch(1);
  dispatch(2);
  return {};
}

const DiamondIndex& GpuSelector::index() const noexcept { return *impl_->index; }
std::uint32_t GpuSelector::groupsPerRow() const noexcept { return impl_->groupsPerRow; }
const GpuBuffer& GpuSelector::screenErrors() const noexcept { return impl_->screen; }
const GpuBuffer& GpuSelector::nodeStates() const noexcept { return impl_->state; }

Result<Cut> GpuSelector::select(const Camera& camera, const SelectionOptions& selection) {
  Impl& m = *impl_;
  const RefinementOptions& options = selection.refinement;
  const DatasetView& dataset = *m.dataset;
  const auto count = static_cast<std::uint32_t>(m.index->nodes.size());
  Result<void> recorded;
  const Result<void> done = m.context->submitAndWait(
      [&](VkCommandBuffer cmd) {
        recorded = recordSelection(cmd, camera, selection);
        computeBarrier(cmd, true);
      },
      "GPU selection");
  if (!recorded) return recorded.error();
  if (!done) return done.error();
  if (auto r = m.screen.invalidateForHostRead(); !r) return std::move(r).error();
  if (auto r = m.state.invalidateForHostRead(); !r) return std::move(r).error();
  std::vector<double> screen(count);
  std::vector<std::uint32_t> state(count);
  std::memcpy(screen.data(), m.screen.mappedBytes().data(), count * sizeof(double));
  std::memcpy(state.data(), m.state.mappedBytes().data(), count * sizeof(std::uint32_t));

  // The cut in refine()'s depth-first order, from the flags.
  Cut cut;
  std::unordered_set<std::uint64_t> seen;
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const auto visit = [&](auto&& self, std::uint32_t i, std::array<double, 2> up) -> void {
    const DiamondIndex::Node& p = m.index->nodes[i];
    if ((state[i] & 1U) != 0U) {
      // A morph window only for a split by screen error (Selection.h).
      const std::array<double, 2> down{(state[i] & 4U) != 0U ? screen[i] : kNone, up[0]};
      self(self, p.firstChild, down);
      self(self, p.firstChild + 1, down);
      return;
    }
    if ((state[i] & 2U) == 0U) return;  // culled
    const NodeRecord record = dataset.node(p.key);
    CutPatch patch;
    patch.node = p.key;
    patch.level = p.level;
    patch.tile = dataset.tileOf(p.key);
    patch.screenErrorPixels = static_cast<float>(screen[i]);
    setPatchMorph(dataset, options, up[0], up[1], patch);
    addCutPatch(cut, patch, record.triangleCount, record.vertexCount, seen);
  };
  for (const std::uint32_t root : m.index->roots) visit(visit, root, {kNone, kNone});
  cut.nodesVisited = count;
  return cut;
}

GpuSelector::GpuSelector(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
GpuSelector::GpuSelector(GpuSelector&&) noexcept = default;
GpuSelector& GpuSelector::operator=(GpuSelector&&) noexcept = default;
GpuSelector::~GpuSelector() = default;

}  // namespace pbdam::gpu
