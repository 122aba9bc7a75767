// The terrain a host drives (Terrain.h): the frame loop's parts made once, in the order their
// sizes depend on each other — the dataset, then the memory plan (which needs the node tables
// and the driver in memory), the renderer with the planned cache, the cut source of the mode and,
// last, the prefetcher, whose worker reads the dataset from its start.
#include "pbdam/gpu/Terrain.h"

#include <chrono>
#include <string>
#include <utility>

#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/streaming/NoStallPolicy.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::gpu {
namespace {

Error invalid(const std::string& message) { return makeError(ErrorCode::InvalidArgument, message); }

Result<void> checkTolerance(const RefinementOptions& refinement) {
  if (!std::isfinite(refinement.tolerancePixels) || refinement.tolerancePixels <= 0.0) {
    return invalid("terrain tolerance must be a positive number of pixels");
  }
  if (!(refinement.exaggeration > 0.0 && refinement.exaggeration <= 100.0)) {
    return invalid("terrain exaggeration must be in (0, 100]");
  }
  return {};
}

/// The options that need no dataset, checked before anything is opened.
Result<void> checkOptions(const TerrainOptions& o) {
  if (auto r = checkTolerance(o.refinement); !r) return r;
  if (o.framesInFlight < 1 || o.framesInFlight > TerrainRenderer::kMaxFramesInFlight) {
    return invalid("terrain frames in flight must be in 1.." +
                   std::to_string(TerrainRenderer::kMaxFramesInFlight));
  }
  if (auto r = validateViewport(o.viewport); !r) return r;
  if (o.prefetch && o.mode == TerrainMode::Exact) {
    return invalid("terrain prefetch is for the paging and no-stall modes, not exact");
  }
  if (!std::isfinite(o.lookaheadSeconds) || o.lookaheadSeconds < 0.0 || o.lookaheadSeconds > 60.0) {
    return invalid("terrain prefetch look-ahead must be in [0, 60] s");
  }
  if (o.memoryBudgetMiB && (!std::isfinite(*o.memoryBudgetMiB) || *o.memoryBudgetMiB < 0.0 ||
                            *o.memoryBudgetMiB > 16777216.0)) {
    return invalid("terrain memory budget must be a number of MiB >= 0 (0: the cgroup's limit)");
  }
  if (o.mode == TerrainMode::NoStall && (o.selection != CutSelection::Cpu || !o.focus.empty())) {
    return invalid("no-stall terrain selects its cuts on the host, without focus regions");
  }
  if (o.draws == DrawList::Indirect && (o.selection != CutSelection::Gpu || !o.focus.empty())) {
    return invalid("terrain draw lists made on the device need device selection, no focus");
  }
  return {};
}

}  // namespace

Terrain::Terrain(VulkanContext& context, std::shared_ptr<const MappedDataset> dataset,
                 TerrainOptions options)
    : context_(&context), dataset_(std::move(dataset)), options_(std::move(options)) {}

Terrain::~Terrain() { stopPrefetcher(); }

Result<std::unique_ptr<Terrain>> Terrain::open(VulkanContext& context,
                                               const std::filesystem::path& dataset,
                                               TerrainOptions options) {
  if (auto r = checkOptions(options); !r) return std::move(r).error();
  const std::optional<MemoryLimit> limit =
      options.memoryBudgetMiB ? memoryLimitOf(*options.memoryBudgetMiB) : cgroupMemoryLimit();
  auto opened = MappedDataset::open(dataset, faceOptionsFor(limit));
  if (!opened) return std::move(opened).error();
  return open(context, std::shared_ptr<const MappedDataset>(std::move(*opened)),
              std::move(options));
}

Result<std::unique_ptr<Terrain>> Terrain::open(VulkanContext& context,
                                               std::shared_ptr<const MappedDataset> dataset,
                                               TerrainOptions options) {
  if (auto r = checkOptions(options); !r) return std::move(r).error();
  std::unique_ptr<Terrain> terrain(new Terrain(context, std::move(dataset), std::move(options)));
  if (auto r = terrain->start(); !r) return std::move(r).error();
  return terrain;
}

Result<void> Terrain::start() {
  const TerrainOptions& o = options_;
  const DatasetView& view = dataset_->view();
  std::uint64_t gpuCacheBytes = o.gpuCacheBytes;
  if (o.memoryBudgetMiB) {
    // Sized once the dataset's node tables and the driver are in memory.
    MemoryDemand demand;
    demand.widthPixels = o.viewport.width;
    demand.heightPixels = o.viewport.height;
    demand.framesInFlight = o.framesInFlight;
    demand.gpuCacheBytes = gpuCacheBytes;
    demand.cacheInHostMemory = context_->deviceInfo().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    auto plan = planRunMemory(*o.memoryBudgetMiB, demand, o.reportMemoryPlan);
    if (!plan) return std::move(plan).error();
    plan_ = std::move(*plan);
    if (plan_) gpuCacheBytes = plan_->gpuCacheBytes;
  }
  TerrainRendererOptions rendererOptions;
  rendererOptions.widthPixels = o.viewport.width;
  rendererOptions.heightPixels = o.viewport.height;
  if (o.draws == DrawList::Indirect) {
    // The device's draw list needs the whole dataset resident, in one pool chunk.
    gpuCacheBytes = GpuCache::bytesForEverything(*context_, view);
    rendererOptions.poolChunkBytes = gpuCacheBytes;
  }
  rendererOptions.gpuCacheBytes = gpuCacheBytes;
  rendererOptions.sharedCache = o.sharedCache;
  rendererOptions.warnWhenBudgetExceeded = o.warnWhenBudgetExceeded;
  rendererOptions.atmosphere = o.atmosphere;
  rendererOptions.exaggeration = o.refinement.exaggeration;
  if (o.sharedCache) gpuCacheBytes = o.sharedCache->budgetBytes();
  gpuCacheBytes_ = gpuCacheBytes;
  rendererOptions.framesInFlight = o.framesInFlight;
  auto renderer = TerrainRenderer::create(*context_, view, rendererOptions);
  if (!renderer) return std::move(renderer).error();
  renderer_.emplace(std::move(*renderer));

  const bool noStall = o.mode == TerrainMode::NoStall;
  if (noStall) {
    // Under a budget each cut's pages are held until its frame has decoded them; what the GPU
    // cache holds needs no page. The coarse levels are preloaded and locked for the terrain's
    // life: the kernel would otherwise evict them and a frame could have nothing to draw.
    cuts_ = noStallCuts(*dataset_, plan_.has_value(), renderer_->cache());
    preloadSkipped_ = NoStallPolicy(*dataset_).preloadCoarseLevels(&coarse_);
  } else if (o.selection == CutSelection::Gpu) {
    auto device = o.draws == DrawList::Indirect ? deviceDrawListCuts(*context_, view)
                                                : deviceSelectionCuts(*context_, view, o.focus);
    if (!device) return std::move(device).error();
    cuts_ = std::move(*device);
  } else if (!o.focus.empty()) {
    cuts_ = focusCuts(view, o.focus);
  } else {
    cuts_ = hostRefinementCuts(view, o.reuseRefinementTree);
  }
  if (o.prefetch || noStall) {
    // No-stall always has a loader thread; without prefetch it fetches the current camera's cut
    // (look-ahead 0) instead of the predicted one.
    PrefetchOptions po;
    po.lookaheadSeconds = o.prefetch ? o.lookaheadSeconds : 0.0;
    po.refinement = o.refinement;
    if (plan_) po.pageRoomBytes = plan_->pageRoomBytes;
    if (o.prefetch) po.onRange = o.onPrefetchRange;
    prefetcher_.emplace(*dataset_, po);
  }
  return {};
}

void Terrain::stopPrefetcher() {
  if (prefetcher_) prefetcher_->stop();
}

Result<void> Terrain::setRefinement(const RefinementOptions& refinement) {
  if (auto r = checkTolerance(refinement); !r) return r;
  if (refinement.exaggeration != options_.refinement.exaggeration) {
    // The GPU cache's patches were decoded under the terrain's exaggeration.
    return invalid("a terrain's exaggeration is fixed when it is opened");
  }
  options_.refinement = refinement;
  return {};
}

Result<void> Terrain::resize(std::uint32_t widthPixels, std::uint32_t heightPixels) {
  if (auto r = renderer_->resize(widthPixels, heightPixels); !r) return r;
  options_.viewport.width = widthPixels;
  options_.viewport.height = heightPixels;
  return {};
}

Result<const TerrainUpdate*> Terrain::update(const Camera& camera, double tSeconds, bool complete) {
  const Viewport& want = options_.viewport;
  if (camera.viewport().width != want.width || camera.viewport().height != want.height) {
    return invalid("terrain update: the camera is " + std::to_string(camera.viewport().width) +
                   " x " + std::to_string(camera.viewport().height) +
                   " pixels, the terrain draws " + std::to_string(want.width) + " x " +
                   std::to_string(want.height));
  }
  if (prefetcher_ && std::isfinite(tSeconds)) prefetcher_->observe(tSeconds, camera);
  const auto start = std::chrono::steady_clock::now();
  if (complete && !completeCuts_) completeCuts_ = hostRefinementCuts(dataset_->view(), false);
  CutSource& source = complete ? *completeCuts_ : *cuts_;
  auto cut = source.cut(camera, options_.refinement);
  if (!cut) return std::move(cut).error();
  TerrainUpdate frame;
  frame.cut = std::move(*cut);
  frame.traversalMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  frame.levelCap = source.levelCap();
  lastSource_ = &source;
  frame.morph = summarizeMorph(frame.cut);
  camera_ = camera;
  frame_ = std::move(frame);
  return &*frame_;
}

Result<void> Terrain::submit(const FrameSettings& settings) {
  if (!frame_) return invalid("terrain submit: update() with a camera first");
  if (auto r = renderer_->submit(frame_->cut, *camera_, settings); !r) return r;
  lastSource_->cutDecoded();
  return {};
}

Result<RenderedFrame> Terrain::collect() { return renderer_->collect(); }

Result<HostFrame> Terrain::drawInto(VkCommandBuffer cmd, const HostPass& pass,
                                    const FrameSettings& settings) {
  if (!frame_) return invalid("terrain drawInto: update() with a camera first");
  auto frame = renderer_->drawInto(cmd, pass, frame_->cut, *camera_, settings);
  if (frame) lastSource_->cutDecoded();
  return frame;
}

Result<SurfaceHeight> Terrain::heightAt(double latDegrees, double lonDegrees) const {
  return surfaceHeightAt(dataset_->view(), latDegrees, lonDegrees);
}

Result<TerrainSightline> Terrain::lineOfSight(const GroundPoint& from, const GroundPoint& to) {
  return sightlineOverTerrain(*context_, dataset_->view(), from, to);
}

Result<TerrainViewshed> Terrain::viewshed(const ViewshedRequest& request) {
  return viewshedOverTerrain(*context_, dataset_->view(), request);
}

}  // namespace pbdam::gpu
