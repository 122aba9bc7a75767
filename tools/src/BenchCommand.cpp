// `pbdam bench DIR --path FILE --out REPORTDIR …`: replays a recorded camera path through the
// renderer, cold or warm, with and without speculative prefetch, in paging or no-stall mode, and
// writes frames.csv, summary.json and report.png (BenchReport.h; docs/architecture.md "Streaming",
// [P-BDAM 2003] §6.2).
//
// The frame loop is the render thread: refinement, decode and upload, draw and readback all run
// on it (TBB is limited to one thread so that decoding — where missing pages fault in — happens
// on the thread whose major faults are counted, as in the paper's single render thread). After
// each frame the page-table entries of the face files' blobs are dropped (MADV_DONTNEED):
// decoded data lives in the GPU cache, so the process's RSS stays near the tables plus one
// frame's working set while the page cache keeps the bytes.
#include <sys/resource.h>
#include <unistd.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

#include "BenchReport.h"
#include "Commands.h"
#include "ExaggerationOption.h"
#include "LightOption.h"
#include "MorphOption.h"
#include "Progress.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/gpu/CutSource.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/PageCache.h"
#include "pbdam/streaming/Prefetcher.h"
#include "pbdam/streaming/ProcessMemory.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;
using namespace pbdam::gpu;

namespace pbdam::tools {
namespace {

/// The options as typed; the frame loop's modes among them are parsed once into BenchModes.
struct BenchCliOptions {
  std::string dir, path, out;
  std::uint32_t width = 640, height = 480;
  double tolerance = 3.0;
  bool cold = false;
  std::string prefetch = "both";
  double lookahead = 0.5;
  std::string mode = "paging";
  std::string cutReuse = "on";
  std::string selection = "cpu";
  std::string draws = "readback";
  bool popping = false;
  double fovDegrees = 60.0;
  double gpuCacheMiB = 64.0;
  std::string device;
  bool quiet = false;
  MorphCliOptions morph;
  double exaggeration = 1.0;
  LightCliOptions light;
  std::uint32_t framesInFlight = 2;
  std::string readback = "off";
  double memoryBudgetMiB = 0.0;
};

/// The frame loop's modes, parsed from BenchCliOptions when the options are checked.
struct BenchModes final {
  RunChoice prefetch = RunChoice::Both;
  RunChoice morph = RunChoice::On;
  StreamingMode mode = StreamingMode::Paging;
  bool cutReuse = true;
  CutSelection selection = CutSelection::Cpu;
  DrawList draws = DrawList::Readback;
  bool readback = false;  ///< --readback: pixels copied back for every frame
  Light light;            ///< --time, --sun, --time-scale, --ambient, --atmosphere, --exposure
  std::shared_ptr<const runtime::AtmosphereTables> atmosphere;  ///< made once, before the runs
};

/// RMS and largest difference over every R, G and B value of two images of one size (0–255).
std::pair<double, double> imageDifference(const gpu::RgbaImage& a, const gpu::RgbaImage& b) {
  double sum = 0.0;
  int largest = 0;
  std::size_t values = 0;
  for (std::size_t i = 0; i + 3 < a.rgba.size() && i + 3 < b.rgba.size(); i += 4) {
    for (std::size_t c = 0; c < 3; ++c) {
      const int d = std::abs(int{a.rgba[i + c]} - int{b.rgba[i + c]});
      sum += static_cast<double>(d * d);
      largest = std::max(largest, d);
      ++values;
    }
  }
  return {values > 0 ? std::sqrt(sum / static_cast<double>(values)) : 0.0,
          static_cast<double>(largest)};
}

/// With a previous cut (the previous frame's level of detail over the whole planet): draws it
/// with `camera` (its morph factors recomputed for this pose: the factor is a function of the
/// pose) and records its difference from `image` (this frame's) as the frame's popping; then
/// keeps this frame's level of detail in `previous` for the next frame.
Result<void> measurePopping(gpu::TerrainRenderer& renderer, const DatasetView& view,
                            const RefinementOptions& options, std::optional<Cut>& previous,
                            const Camera& camera, const gpu::FrameSettings& settings,
                            const gpu::RgbaImage& image, BenchFrame& f) {
  // For the next frame: this frame's level of detail, not culled. Culled against this frustum
  // it would lack what the next frame turns or moves into view, and the difference would count
  // those holes instead of the change of level of detail.
  RefinementOptions unculled = options;
  unculled.frustumCulling = false;
  if (f.drawnLevelCap >= 0) unculled.maxLevel = f.drawnLevelCap;
  Cut next = refine(view, camera, unculled);
  if (!previous) {
    previous = std::move(next);
    return {};
  }
  refreshMorph(view, camera, options, *previous);
  auto before = renderer.render(*previous, camera, settings);
  if (!before) return before.error();
  const auto [rms, max] = imageDifference(image, before->image);
  f.poppingRms = rms;
  f.poppingMax = max;
  previous = std::move(next);
  return {};
}

/// A cut selected on the device against the host's (untimed): whether they differ, and the
/// largest screen error over the tolerance of the device cut's drawn inner patches, on the host.
void checkDeviceCut(const DatasetView& view, const Camera& camera,
                    const RefinementOptions& refinement, const Cut& device, BenchRun& run) {
  const Cut host = refine(view, camera, refinement);
  const bool same =
      host.patches.size() == device.patches.size() &&
      std::equal(host.patches.begin(), host.patches.end(), device.patches.begin(),
                 [](const CutPatch& a, const CutPatch& b) { return a.node == b.node; });
  if (!same) ++run.selectionFramesDiffering;
  const int cap =
      refinement.maxLevel < 0 ? view.depth() : std::min(refinement.maxLevel, view.depth());
  for (const CutPatch& patch : device.patches) {
    if (patch.level >= cap) continue;  // leaves and capped levels are drawn whatever their error
    const NodeRecord record = view.node(patch.node);
    if (record.leaf()) continue;
    const RefinementBounds b = refinementBounds(view, record, patch.level,
                                                exaggerationBounds(view, refinement.exaggeration));
    const double screen = camera.screenError(b.errorMeters, b.centre, b.radiusMeters);
    run.selectionMaxScreenRatio =
        std::max(run.selectionMaxScreenRatio, screen / refinement.tolerancePixels);
  }
}

/// The camera of a path point.
Camera cameraOf(const DatasetView& view, const CameraPathPoint& p, const Viewport& viewport) {
  return Camera::fromPose(view.planet(),
                          {p.latDegrees, p.lonDegrees, p.altitudeMeters, p.headingDegrees,
                           p.pitchDegrees, p.rollDegrees},
                          viewport);
}

/// Untimed: a frame drawn from the device's draw list against the host's cut, by their patch and
/// triangle counts (the list itself is never read back).
void checkDeviceDraws(const DatasetView& view, const Camera& camera,
                      const RefinementOptions& refinement, const gpu::FrameStats& stats,
                      BenchRun& run) {
  const Cut host = refine(view, camera, refinement);
  if (host.patches.size() != stats.patches || host.triangles != stats.triangles) {
    ++run.selectionFramesDiffering;
  }
}

void copyRenderStats(const gpu::FrameStats& stats, BenchFrame& f) {
  f.decodeMs = stats.decodeMs;
  f.uploadMs = stats.uploadMs;
  f.drawMs = stats.drawMs;
  f.triangles = stats.triangles;
  f.patches = stats.patches;
  f.tiles = stats.tiles;
  f.gpuHits = stats.hits;
  f.gpuMisses = stats.misses;
  f.gpuEvictions = stats.evictions;
}

using Clock = std::chrono::steady_clock;
double msBetween(Clock::time_point t0, Clock::time_point t1) {
  return std::chrono::duration<double, std::milli>(t1 - t0).count();
}
double msSince(Clock::time_point t0) { return msBetween(t0, Clock::now()); }

std::uint64_t residentDatasetPages(const MappedDataset& dataset) {
  std::uint64_t pages = 0;
  for (int f = 0; f < 6; ++f) {
    if (auto r = dataset.faceFile(f).residentPages(); r) pages += *r;
  }
  return pages;
}

/// Evicts the dataset from the page cache before a cold run and records what stayed.
Result<void> evictForColdRun(const std::string& dir, BenchRun& run) {
  auto evicted = evictDataset(dir);
  if (!evicted) return evicted.error();
  run.residentAfterEvictPages = evicted->residentPages;
  run.datasetPages = evicted->totalPages;
  run.residentAfterEvictFraction = evicted->residentFraction();
  if (evicted->residentFraction() > 0.01) {
    std::fprintf(stderr, "pbdam: warning: %.2f%% of the dataset stayed in the page cache\n",
                 100.0 * evicted->residentFraction());
  }
  return {};
}

/// Drops the page-table entries of the face files' blobs after a frame, so that RSS follows the
/// working set. The node and texture tables (each file's head) stay mapped: refinement reads
/// them every frame, and unmapped they are the page cache's first victims under memory pressure.
void releaseBlobPages(const MappedDataset& dataset, const HeldPages& held) {
  for (int face = 0; face < 6; ++face) {
    const MappedFile& file = dataset.faceFile(face);
    const std::uint64_t blobs = dataset.view().face(face).header().blobsOffset;
    held.releaseResidentAround(file, blobs, file.size() - blobs);
  }
}

std::string progressLine(const BenchRun& run, std::size_t done, std::size_t frames,
                         const BenchFrame& f) {
  char line[160];
  std::snprintf(line, sizeof line, "morph %s, prefetch %s: frame %zu/%zu  %.1f ms  %llu triangles",
                onOff(run.morph), onOff(run.prefetch), done, frames, f.frameMs,
                static_cast<unsigned long long>(f.triangles));
  return line;
}

/// A run's settings (its figures are filled in as it goes).
BenchRun describeRun(const BenchCliOptions& o, const BenchModes& modes, bool prefetch, bool morph) {
  BenchRun run;
  run.prefetch = prefetch;
  run.morph = morph;
  run.mode = modes.mode;
  const bool paging = modes.mode == StreamingMode::Paging;
  run.selection = paging ? modes.selection : CutSelection::Cpu;
  run.cutReuse = modes.cutReuse && paging && run.selection == CutSelection::Cpu;
  run.draws = run.selection == CutSelection::Gpu ? modes.draws : DrawList::Readback;
  run.popping = o.popping;
  run.cold = o.cold;
  // --popping draws a frame again right after it (render() needs nothing in flight), and the
  // device-made draw list is one frame at a time: both run one frame in flight.
  run.framesInFlight = o.popping || run.draws == DrawList::Indirect ? 1 : o.framesInFlight;
  run.readback = modes.readback || o.popping;
  return run;
}

/// The timed frame loop of one run: the path's frames drawn with frames in flight (frame i is
/// refined, decoded and recorded while the device draws the frames before it; a frame is
/// collected, its device timings and cache figures filled in, once framesInFlight frames are
/// pending, so 1 in flight is the one-frame-at-a-time loop), each frame's figures in run.frames.
/// Prefetched ranges until a frame's cut uses them: sampled with mincore every 30 frames, a
/// range whose pages left the page cache before any cut used it was evicted before use (the
/// page room was too small for what the prefetcher asked). The prefetcher's worker adds
/// ranges; the frame loop takes them away.
struct PrefetchUse {
  std::mutex mutex;
  std::unordered_map<std::uint64_t, PrefetchRange> waiting;  ///< advised, not used yet
  std::uint64_t used = 0;
  std::uint64_t evictedBeforeUse = 0;

  void advised(const PrefetchRange& range) {
    if (range.wasResident) return;
    const std::lock_guard<std::mutex> lock(mutex);
    waiting.insert_or_assign(range.key.packed, range);
  }
  void usedBy(const Cut& cut) {
    const std::lock_guard<std::mutex> lock(mutex);
    for (const CutPatch& p : cut.patches) used += waiting.erase(packKey(p.node));
    for (const TileKey& t : cut.tiles) used += waiting.erase(packKey(t));
  }
  void sample(const MappedDataset& dataset) {
    const std::lock_guard<std::mutex> lock(mutex);
    std::erase_if(waiting, [&](const auto& entry) {
      const PrefetchRange& r = entry.second;
      if (NoStallPolicy::rangeResident(dataset.faceFile(r.face), r.offset, r.bytes)) return false;
      ++evictedBeforeUse;
      return true;
    });
  }
};

struct PathReplay {
  PathReplay(const BenchCliOptions& options, const std::vector<CameraPathPoint>& cameraPath,
             gpu::Terrain& runTerrain, const SelectionOptions& selection, BenchRun& into)
      : o(options),
        path(cameraPath),
        terrain(runTerrain),
        dataset(runTerrain.dataset()),
        renderer(runTerrain.renderer()),
        source(runTerrain.cutSource()),
        refinement(runTerrain.options().refinement),
        deviceSelection(selection),
        run(into) {}

  const BenchCliOptions& o;
  const std::vector<CameraPathPoint>& path;
  gpu::Terrain& terrain;
  const MappedDataset& dataset;
  gpu::TerrainRenderer& renderer;
  CutSource& source;
  const RefinementOptions& refinement;
  const SelectionOptions& deviceSelection;
  BenchRun& run;

  Viewport viewport{o.width, o.height, o.fovDegrees};
  std::optional<Cut> previousCut;   // --popping
  std::deque<std::size_t> pending;  // indices in run.frames of the frames in flight
  std::uint64_t residentBefore = 0;
  std::uint64_t page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  Clock::time_point runEnd{};          // the end of the last frame so far
  PrefetchUse* prefetchUse = nullptr;  // with prefetch on
  Light light;                         // the frames' light
  std::optional<Camera> lightTarget;   // the path's first camera: a placed sun stands over it

  /// The light of frame i.
  gpu::FrameSettings settingsOf(std::size_t i) {
    if (!lightTarget) lightTarget = cameraOf(dataset.view(), path.front(), viewport);
    gpu::FrameSettings settings;
    settings.readback = run.readback;
    applyLight(light, dataset.view().planet(), *lightTarget, path[i].tSeconds, settings);
    return settings;
  }

  Result<void> replay(Prefetcher* prefetcher) {
    const DatasetView& view = dataset.view();
    Progress progress(o.quiet);
    residentBefore = residentDatasetPages(dataset);
    Clock::time_point runStart{};  // the first frame's start
    for (std::size_t i = 0; i < path.size(); ++i) {
      const Camera camera = cameraOf(view, path[i], viewport);
      if (prefetcher) prefetcher->observe(path[i].tSeconds, camera);
      const auto t0 = Clock::now();
      if (i == 0) runStart = t0;
      if (auto r = frame(i, camera, t0); !r) return r;
      progress.status(progressLine(run, i + 1, path.size(), run.frames.back()),
                      i + 1 == path.size());
    }
    // The frames still in flight: their wait belongs to the last frame's time.
    if (!pending.empty()) {
      const auto drainStart = Clock::now();
      while (!pending.empty()) {
        if (auto r = collectOne(); !r) return r;
      }
      runEnd = Clock::now();
      run.frames.back().frameMs += msBetween(drainStart, runEnd);
    }
    progress.finish();
    run.wallMs = msBetween(runStart, runEnd);
    return {};
  }

  /// Frame i: its cut, its submission (or the device-made draw list's frame), the frames
  /// collected meanwhile, and its own figures.
  Result<void> frame(std::size_t i, const Camera& camera, Clock::time_point t0) {
    const DatasetView& view = dataset.view();
    const bool deviceList = source.drawsDeviceList();
    BenchFrame f;
    f.frame = static_cast<std::uint32_t>(i);
    f.pathSeconds = path[i].tSeconds;
    const std::uint64_t faults0 = threadMajorFaults();
    // The device's draw list: an empty cut, the selection runs inside the frame's submission.
    auto selected = terrain.update(camera);
    if (!selected) return selected.error();
    const Cut& cut = (*selected)->cut;
    f.drawnLevelCap = (*selected)->levelCap;
    f.traversalMs = msSince(t0);
    f.decisions = deviceList ? source.selector()->index().nodes.size() : cut.nodesVisited;
    f.morphingPatches = (*selected)->morph.morphingPatches;
    f.triangles = cut.triangles;
    f.patches = cut.patches.size();
    if (deviceList) {
      auto drawn =
          renderer.renderSelected(*source.selector(), camera, deviceSelection, settingsOf(i));
      if (!drawn) return drawn.error();
      copyRenderStats(drawn->stats, f);
      f.gpuPoolBytes = drawn->stats.poolBytes;
      checkDeviceDraws(view, camera, refinement, drawn->stats, run);
      run.frames.push_back(f);
    } else {
      if (auto submitted = terrain.submit(settingsOf(i)); !submitted) return submitted.error();
      run.frames.push_back(f);
      pending.push_back(i);
      while (pending.size() >= run.framesInFlight) {
        if (auto r = collectOne(); !r) return r;
      }
    }
    BenchFrame& done = run.frames.back();
    done.rssFileBytes = residentFileBytes();
    releaseBlobPages(dataset, terrain.coarseLevels());
    runEnd = Clock::now();
    done.frameMs = msBetween(t0, runEnd);
    done.renderThreadMajorFaults = threadMajorFaults() - faults0;
    if (!deviceList && run.selection == CutSelection::Gpu) {
      checkDeviceCut(view, camera, refinement, cut, run);
    }
    if (prefetchUse) {
      prefetchUse->usedBy(cut);
      if (i % 30 == 29) prefetchUse->sample(dataset);
    }
    const std::uint64_t residentAfter = residentDatasetPages(dataset);
    done.bytesPagedIn =
        residentAfter > residentBefore ? (residentAfter - residentBefore) * page : 0;
    residentBefore = residentAfter;
    done.rssBytes = residentSetBytes();
    return {};
  }

  /// Collects the oldest frame in flight into its record (and with --popping, one frame in
  /// flight, measures it against the previous cut).
  Result<void> collectOne() {
    auto drawn = terrain.collect();
    if (!drawn) return drawn.error();
    BenchFrame& f = run.frames[pending.front()];
    pending.pop_front();
    copyRenderStats(drawn->stats, f);
    f.gpuPoolBytes = drawn->stats.poolBytes;
    if (!o.popping) return {};
    // After the frame's own figures: the previous cut drawn with this camera, compared (one
    // frame in flight: this is the frame just submitted).
    const Camera camera = cameraOf(dataset.view(), path[f.frame], viewport);
    return measurePopping(renderer, dataset.view(), refinement, previousCut, camera,
                          settingsOf(f.frame), drawn->image, f);
  }
};

Result<BenchRun> runOnce(gpu::VulkanContext& context, const BenchCliOptions& o,
                         const BenchModes& modes, const std::vector<CameraPathPoint>& path,
                         bool prefetch, bool morph) {
  BenchRun run = describeRun(o, modes, prefetch, morph);
  if (o.cold) {
    if (auto r = evictForColdRun(o.dir, run); !r) return r.error();
  }
  // No-stall mode: the coarse levels preloaded and locked for the run (the kernel would
  // otherwise evict them, under a budget or other processes' memory pressure, and a frame could
  // have nothing to draw); each cut's pages held until its frame has decoded them under a
  // budget. Paging mode: the device's selection passes (the cut read back or the draw list made
  // on the device), or the host's refinement with the tree kept from frame to frame or from the
  // roots. No-stall always has a loader thread; without prefetch it fetches the current
  // camera's cut (look-ahead 0) instead of the predicted one.
  const bool noStall = run.mode == StreamingMode::NoStall;
  gpu::TerrainOptions options;
  options.mode = noStall ? gpu::TerrainMode::NoStall
                         : (prefetch ? gpu::TerrainMode::Paging : gpu::TerrainMode::Exact);
  options.refinement.tolerancePixels = o.tolerance;
  options.refinement.morphRange = morphRangeOf(o.morph, morph);
  options.refinement.exaggeration = o.exaggeration;
  options.selection = run.selection;
  options.draws = run.draws;
  options.reuseRefinementTree = run.cutReuse;
  options.prefetch = prefetch;
  options.lookaheadSeconds = o.lookahead;
  PrefetchUse prefetchUse;  // outlives the terrain's prefetcher, whose worker adds to it
  if (prefetch) {
    options.onPrefetchRange = [&prefetchUse](const PrefetchRange& r) { prefetchUse.advised(r); };
  }
  options.gpuCacheBytes = static_cast<std::uint64_t>(o.gpuCacheMiB * 1048576.0);
  options.memoryBudgetMiB = o.memoryBudgetMiB;
  options.reportMemoryPlan = !o.quiet;
  options.viewport = Viewport{o.width, o.height, o.fovDegrees};
  options.framesInFlight = run.framesInFlight;
  options.atmosphere = modes.atmosphere;
  auto opened = gpu::Terrain::open(context, o.dir, std::move(options));
  if (!opened) return opened.error();
  gpu::Terrain& terrain = **opened;
  const DatasetView& view = terrain.view();
  run.gpuCacheBytes = static_cast<std::uint64_t>(o.gpuCacheMiB * 1048576.0);
  if (const auto& plan = terrain.memoryPlan()) {
    run.gpuCacheBytes = plan->gpuCacheBytes;
    run.memoryBudgetBytes = plan->budgetBytes;
    run.memoryBudgetSource = plan->source;
  }
  // What cannot be read is skipped (the level cap keeps it out of the frames) and reported.
  for (const Error& e : terrain.preloadSkipped()) {
    std::fprintf(stderr, "pbdam: warning: preload skipped: %s\n", e.message.c_str());
  }
  CutSource& source = terrain.cutSource();
  SelectionOptions deviceSelection;
  deviceSelection.refinement = terrain.options().refinement;
  if (source.drawsDeviceList() && !path.empty()) {
    // Untimed: the first call makes every patch and tile resident.
    auto primed = terrain.renderer().renderSelected(
        *source.selector(), cameraOf(view, path.front(), terrain.options().viewport),
        deviceSelection);
    if (!primed) return primed.error();
  }
  run.baselineRssFileBytes = residentFileBytes();
  PathReplay replay(o, path, terrain, deviceSelection, run);
  if (prefetch) replay.prefetchUse = &prefetchUse;
  replay.light = modes.light;
  if (auto r = replay.replay(terrain.prefetcher()); !r) return r.error();
  if (Prefetcher* prefetcher = terrain.prefetcher()) {
    terrain.stopPrefetcher();
    run.prefetchRangesAdvised = prefetcher->stats().rangesAdvised;
    run.prefetchBytesAdvised = prefetcher->stats().bytesAdvised;
    run.prefetchRangesDeferred = prefetcher->stats().rangesDeferred;
    prefetchUse.sample(terrain.dataset());
    run.prefetchRangesUsed = prefetchUse.used;
    run.prefetchRangesEvictedBeforeUse = prefetchUse.evictedBeforeUse;
  }
  for (int f = 0; f < 6; ++f) run.nodeTablesPaged |= view.face(f).nodeTablePaged();
  run.datasetDepth = view.depth();
  run.nodeChunkReads = view.nodeChunkReads();
  return run;
}

/// The frame loop's modes of `o`, parsed once; kExitOk, or the exit status of the first bad
/// option (checked in the order the options' messages have always come in).
int parseBenchModes(const BenchCliOptions& o, BenchModes& modes) {
  auto prefetch = parseRunChoice("--prefetch", o.prefetch);
  if (!prefetch) return reportError(prefetch.error());
  auto cutReuse = parseOnOff("--cut-reuse", o.cutReuse);
  if (!cutReuse) return reportError(cutReuse.error());
  auto selection = parseCutSelection(o.selection);
  if (!selection) return reportError(selection.error());
  auto draws = parseDrawList(o.draws);
  if (!draws) return reportError(draws.error());
  auto mode = parseStreamingMode(o.mode);  // reported after the check of --draws indirect
  if (*draws == DrawList::Indirect &&
      (*selection != CutSelection::Gpu || !mode || *mode != StreamingMode::Paging || o.popping)) {
    return reportError(invalidArgument(
        "--draws indirect needs --selection gpu in paging mode, without --popping"));
  }
  if (!mode) return reportError(mode.error());
  auto readback = parseOnOff("--readback", o.readback);
  if (!readback) return reportError(readback.error());
  modes.readback = *readback;
  auto light = parseLight(o.light);
  if (!light) return reportError(light.error());
  modes.light = *light;
  modes.prefetch = *prefetch;
  modes.cutReuse = *cutReuse;
  modes.selection = *selection;
  modes.draws = *draws;
  modes.mode = *mode;
  return kExitOk;
}

int runBench(const BenchCliOptions& o) {
  const auto bad = [](const std::string& what) { return reportError(invalidArgument(what)); };
  BenchModes modes;
  if (const int status = parseBenchModes(o, modes); status != kExitOk) return status;
  if (!std::isfinite(o.lookahead) || o.lookahead < 0.0 || o.lookahead > 60.0) {
    return bad("--lookahead-s must be in [0, 60]");
  }
  if (!std::isfinite(o.tolerance) || o.tolerance <= 0.0) return bad("--tolerance-px must be > 0");
  if (o.framesInFlight < 1 || o.framesInFlight > gpu::TerrainRenderer::kMaxFramesInFlight) {
    return bad("--frames-in-flight must be in 1.." +
               std::to_string(gpu::TerrainRenderer::kMaxFramesInFlight));
  }
  if (!std::isfinite(o.memoryBudgetMiB) || o.memoryBudgetMiB < 0.0 ||
      o.memoryBudgetMiB > 16777216.0) {
    return bad("--memory-budget-mib must be a number of MiB >= 0 (0: the cgroup's limit)");
  }
  if (!std::isfinite(o.gpuCacheMiB) || o.gpuCacheMiB <= 0.0 || o.gpuCacheMiB > 65536.0) {
    return bad("--gpu-cache-mib (--gpu-cache-mb) must be in (0, 65536]");
  }
  if (auto r = checkExaggeration(o.exaggeration); !r) return reportError(r.error());
  if (auto v = validateViewport({o.width, o.height, o.fovDegrees}); !v) {
    return reportError(v.error());
  }
  auto path = readCameraPath(o.path);
  if (!path) return reportError(path.error());
  // Under a memory limit the probe pages its node tables too: copied whole, the paper-scale
  // dataset's are 1.2 GB.
  auto probe = MappedDataset::open(o.dir, faceOptionsFor(memoryLimitOf(o.memoryBudgetMiB)));
  if (!probe) return reportError(probe.error());
  if (auto r = checkMorphOptions(o.morph, (*probe)->view(), true); !r)
    return reportError(r.error());
  modes.morph = parseRunChoice("--morph", o.morph.morph).value();  // checked just above
  if (auto r = checkLightFor(modes.light, (*probe)->view().planet()); !r) {
    return reportError(r.error());
  }
  modes.atmosphere = atmosphereTablesFor(modes.light, (*probe)->view().planet(), o.quiet);
  for (const CameraPathPoint& p : *path) {
    if (auto v = validateCameraPose({p.latDegrees, p.lonDegrees, p.altitudeMeters, p.headingDegrees,
                                     p.pitchDegrees, p.rollDegrees},
                                    (*probe)->view().planet());
        !v) {
      return reportError(invalidArgument(o.path + " at t=" + std::to_string(p.tSeconds) + ": " +
                                         v.error().message));
    }
  }
  BenchSetup setup;
  setup.dataset = o.dir;
  setup.path = o.path;
  setup.width = o.width;
  setup.height = o.height;
  setup.tolerancePixels = o.tolerance;
  setup.morphRange = o.morph.range;
  setup.lookaheadSeconds = o.lookahead;
  setup.gpuCacheBytes = static_cast<std::uint64_t>(o.gpuCacheMiB * 1048576.0);
  setup.datasetBytes = (*probe)->bytes();
  setup.exaggeration = o.exaggeration;
  setup.light = summarizeLight(modes.light, (*probe)->view().planet());
  probe->reset();  // unmapped, so a cold run can evict every page

  gpu::ContextOptions co;
  co.device = o.device;
  co.enableValidation = false;
  auto context = gpu::VulkanContext::create(co);
  if (!context) return reportError(context.error());
  tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
  std::vector<BenchRun> runs;
  for (const bool morph : {false, true}) {
    if (!includes(modes.morph, morph)) continue;
    for (const bool prefetch : {false, true}) {
      if (!includes(modes.prefetch, prefetch)) continue;
      auto run = runOnce(*context, o, modes, *path, prefetch, morph);
      if (!run) return reportError(run.error());
      runs.push_back(std::move(run).value());
    }
  }
  auto text = writeBenchReport(o.out, setup, runs);
  if (!text) return reportError(text.error());
  std::cout << *text;
  return kExitOk;
}

}  // namespace

void addBenchCommand(CLI::App& app, CommandStatus& status) {
  auto o = std::make_shared<BenchCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Replay a camera path: frame times, faults, cache figures; CSV, JSON and plots");
  cmd->add_option("DIR", o->dir, "Dataset directory")->required();
  cmd->add_option("--path", o->path, "Camera path CSV (pbdam path …)")->required();
  cmd->add_option("--out", o->out, "Report directory (frames.csv, summary.json, report.png)")
      ->required();
  cmd->add_option("--width", o->width, "Frame width")->capture_default_str();
  cmd->add_option("--height", o->height, "Frame height")->capture_default_str();
  cmd->add_option("--tolerance-px", o->tolerance, "Screen-space error tolerance")
      ->capture_default_str();
  cmd->add_flag("--cold", o->cold, "Evict the dataset from the page cache before each run");
  cmd->add_option("--prefetch", o->prefetch, "on, off or both (one run each)")
      ->capture_default_str();
  cmd->add_option("--lookahead-s", o->lookahead, "Prefetch look-ahead in path seconds")
      ->capture_default_str();
  cmd->add_option("--mode", o->mode,
                  "paging: missing pages fault in on the render thread; no-stall: draw the "
                  "finest resident conforming cut")
      ->capture_default_str();
  cmd->add_option("--cut-reuse", o->cutReuse,
                  "on: keep the refinement tree from frame to frame and re-evaluate only the "
                  "decisions the camera's movement may have changed (paging mode; the same "
                  "cuts); off: refine every frame from the roots")
      ->capture_default_str();
  cmd->add_flag("--popping", o->popping,
                "Also draw each frame with the previous frame's cut and report the difference "
                "(RMS and largest, 0-255): the popping the change of cut causes (doubles the "
                "rendering; its timings are not comparable with a run without it)");
  cmd->add_option("--fov-deg", o->fovDegrees, "Vertical field of view in degrees")
      ->capture_default_str();
  cmd->add_option("--memory-budget-mib", o->memoryBudgetMiB,
                  "Memory the run may use in MiB (0: the memory cgroup's limit, if any): the GPU "
                  "cache (on a CPU device) is lowered to leave room for the dataset's pages; "
                  "below what the run needs it refuses to start")
      ->capture_default_str();
  cmd->add_option("--gpu-cache-mib,--gpu-cache-mb", o->gpuCacheMiB,
                  "GPU cache budget in MiB (patch and tile slots; --gpu-cache-mb is its former "
                  "spelling, also MiB)")
      ->capture_default_str();
  cmd->add_option("--device", o->device, kDeviceOptionHelp);
  cmd->add_option("--selection", o->selection,
                  "cpu: the refinement on the host; gpu: the selection's compute passes on the "
                  "device (paging mode; the same cuts on lavapipe)")
      ->capture_default_str();
  cmd->add_option("--draws", o->draws,
                  "With --selection gpu: readback: the host lists the device's cut and computes "
                  "each draw's record; indirect: the device makes the draw list and records and "
                  "draws it with one indirect draw, nothing read back (the whole dataset is made "
                  "resident first, and the GPU cache sized for it)")
      ->capture_default_str();
  addMorphOptions(*cmd, o->morph, true);
  addExaggerationOption(*cmd, o->exaggeration);
  cmd->add_option("--frames-in-flight", o->framesInFlight,
                  std::string(kFramesInFlightHelp) +
                      " (--popping and --draws indirect run one frame in flight)")
      ->capture_default_str();
  cmd->add_option("--readback", o->readback,
                  "on: copy every frame's pixels back to the host, as render and serve do; off: "
                  "the frame stays on the device (implied on by --popping)")
      ->capture_default_str();
  addLightOptions(*cmd, o->light, true);
  cmd->add_flag("--quiet", o->quiet, "No per-frame progress");
  cmd->callback([o, &status] { status.exitCode = runBench(*o); });
}

}  // namespace pbdam::tools
