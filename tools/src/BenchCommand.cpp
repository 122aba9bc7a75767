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
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "BenchReport.h"
#include "Commands.h"
#include "MorphOption.h"
#include "ProcessMemory.h"
#include "Progress.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/PageCache.h"
#include "pbdam/streaming/Prefetcher.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::tools {
namespace {

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
                            const Camera& camera, const gpu::RgbaImage& image, BenchFrame& f) {
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
  auto before = renderer.render(*previous, camera);
  if (!before) return before.error();
  const auto [rms, max] = imageDifference(image, before->image);
  f.poppingRms = rms;
  f.poppingMax = max;
  previous = std::move(next);
  return {};
}

/// No-stall mode's cut, its cap recorded in `f` and `previousCap`: the cap rises by at most one
/// diamond level (two bintree levels) over the previous frame's, so that when a level's data
/// arrives its patches are decoded over a few frames instead of all in one (NoStallPolicy's
/// cutAfter, which takes a finer resident cut at once when none within that rise is).
Cut noStallCut(const NoStallPolicy& policy, const Camera& camera, const RefinementOptions& options,
               int& previousCap, BenchFrame& f) {
  NoStallCut capped = policy.cutAfter(camera, options, previousCap);
  previousCap = capped.levelCap;
  f.drawnLevelCap = capped.levelCap;
  return std::move(capped.cut);
}

/// Where a paging-mode frame's cut comes from: the device's selection passes, the refinement
/// tree kept from frame to frame, or the stateless refinement.
class PagingCuts final {
 public:
  PagingCuts(const DatasetView& view, bool reuse)
      : view_(view), incremental_(view), reuse_(reuse) {}
  gpu::GpuSelector* selector() { return gpu_ ? &*gpu_ : nullptr; }
  Result<void> useGpu(gpu::VulkanContext& context) {
    auto selector = gpu::GpuSelector::create(context, view_);
    if (!selector) return std::move(selector).error();
    gpu_.emplace(std::move(*selector));
    return {};
  }
  Result<Cut> cut(const Camera& camera, const RefinementOptions& refinement) {
    if (gpu_) {
      SelectionOptions selection;
      selection.refinement = refinement;
      return gpu_->select(camera, selection);
    }
    return reuse_ ? incremental_.update(camera, refinement) : refine(view_, camera, refinement);
  }
  /// The device's cut against the host's (untimed): whether they differ, and the largest
  /// screen error over the tolerance of the device cut's drawn inner patches, on the host.
  void checkAgainstHost(const Camera& camera, const RefinementOptions& refinement,
                        const Cut& device, BenchRun& run) const {
    if (!gpu_) return;
    const Cut host = refine(view_, camera, refinement);
    const bool same =
        host.patches.size() == device.patches.size() &&
        std::equal(host.patches.begin(), host.patches.end(), device.patches.begin(),
                   [](const CutPatch& a, const CutPatch& b) { return a.node == b.node; });
    if (!same) ++run.selectionFramesDiffering;
    const int cap =
        refinement.maxLevel < 0 ? view_.depth() : std::min(refinement.maxLevel, view_.depth());
    for (const CutPatch& patch : device.patches) {
      if (patch.level >= cap) continue;  // leaves and capped levels are drawn whatever their error
      const NodeRecord record = view_.node(patch.node);
      if (record.leaf()) continue;
      const glm::dvec3 centre(record.sphereCenter[0], record.sphereCenter[1],
                              record.sphereCenter[2]);
      const double screen = camera.screenError(
          refinementErrorMeters(view_, patch.level, static_cast<double>(record.errorMeters)),
          centre, static_cast<double>(record.sphereRadiusMeters));
      run.selectionMaxScreenRatio =
          std::max(run.selectionMaxScreenRatio, screen / refinement.tolerancePixels);
    }
  }

 private:
  const DatasetView& view_;
  IncrementalRefiner incremental_;
  bool reuse_;
  std::optional<gpu::GpuSelector> gpu_;
};

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
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::uint64_t threadMajorFaults() {
  rusage usage{};
  ::getrusage(RUSAGE_THREAD, &usage);
  return static_cast<std::uint64_t>(usage.ru_majflt);
}

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
void releaseBlobPages(const MappedDataset& dataset) {
  for (int face = 0; face < 6; ++face) {
    const MappedFile& file = dataset.faceFile(face);
    const std::uint64_t blobs = dataset.view().face(face).header().blobsOffset;
    (void)file.releaseResident(blobs, file.size() - blobs);
  }
}

std::string progressLine(const BenchRun& run, std::size_t done, std::size_t frames,
                         const BenchFrame& f) {
  char line[160];
  std::snprintf(line, sizeof line, "morph %s, prefetch %s: frame %zu/%zu  %.1f ms  %llu triangles",
                run.morph.c_str(), run.prefetch.c_str(), done, frames, f.frameMs,
                static_cast<unsigned long long>(f.triangles));
  return line;
}

/// A run's settings (its figures are filled in as it goes).
BenchRun describeRun(const BenchCliOptions& o, bool prefetch, bool morph) {
  BenchRun run;
  run.prefetch = prefetch ? "on" : "off";
  run.morph = morph ? "on" : "off";
  run.mode = o.mode;
  run.selection = o.mode == "paging" ? o.selection : "cpu";
  run.cutReuse = o.cutReuse == "on" && o.mode == "paging" && run.selection == "cpu";
  run.draws = run.selection == "gpu" ? o.draws : "readback";
  run.popping = o.popping;
  run.cold = o.cold;
  return run;
}

gpu::TerrainRendererOptions rendererOptions(const gpu::VulkanContext& context,
                                            const DatasetView& view, const BenchCliOptions& o) {
  gpu::TerrainRendererOptions ro;
  ro.widthPixels = o.width;
  ro.heightPixels = o.height;
  ro.gpuCacheBytes = static_cast<std::uint64_t>(o.gpuCacheMiB * 1048576.0);
  if (o.selection == "gpu" && o.mode == "paging" && o.draws == "indirect") {
    // The device's draw list needs the whole dataset resident, in one pool chunk.
    ro.gpuCacheBytes = gpu::GpuCache::bytesForEverything(context, view);
    ro.poolChunkBytes = ro.gpuCacheBytes;
  }
  return ro;
}

Result<BenchRun> runOnce(gpu::VulkanContext& context, const BenchCliOptions& o,
                         const std::vector<CameraPathPoint>& path, bool prefetch, bool morph) {
  BenchRun run = describeRun(o, prefetch, morph);
  const bool indirect = run.draws == "indirect";
  if (o.cold) {
    if (auto r = evictForColdRun(o.dir, run); !r) return r.error();
  }
  auto dataset = MappedDataset::open(o.dir);
  if (!dataset) return dataset.error();
  const DatasetView& view = (*dataset)->view();
  auto renderer = gpu::TerrainRenderer::create(context, view, rendererOptions(context, view, o));
  if (!renderer) return renderer.error();
  const bool noStall = o.mode == "no-stall";
  const NoStallPolicy noStallPolicy(**dataset);
  if (noStall) {
    // What cannot be read is skipped (the level cap keeps it out of the frames) and reported.
    for (const Error& e : noStallPolicy.preloadCoarseLevels()) {
      std::fprintf(stderr, "pbdam: warning: preload skipped: %s\n", e.message.c_str());
    }
  }
  RefinementOptions refinement;
  refinement.tolerancePixels = o.tolerance;
  refinement.morphRange = morphRangeOf(o.morph, morph);
  // Paging mode keeps the refinement tree from frame to frame (the same cuts, fewer decisions)
  // or selects on the device; no-stall mode's level cap changes from frame to frame and
  // refines from the roots.
  PagingCuts pagingCuts(view, run.cutReuse);
  if (run.selection == "gpu") {
    if (auto r = pagingCuts.useGpu(context); !r) return r.error();
  }
  SelectionOptions deviceSelection;
  deviceSelection.refinement = refinement;
  if (indirect && !path.empty()) {
    // Untimed: the first call makes every patch and tile resident.
    auto primed = renderer->renderSelected(
        *pagingCuts.selector(), cameraOf(view, path.front(), {o.width, o.height, o.fovDegrees}),
        deviceSelection);
    if (!primed) return primed.error();
  }
  std::optional<Prefetcher> prefetcher;
  if (prefetch || noStall) {
    // No-stall always has a loader thread; without prefetch it fetches the current camera's cut
    // (look-ahead 0) instead of the predicted one.
    PrefetchOptions po;
    po.lookaheadSeconds = prefetch ? o.lookahead : 0.0;
    po.refinement = refinement;
    prefetcher.emplace(**dataset, po);
  }
  const Viewport viewport{o.width, o.height, o.fovDegrees};
  std::optional<Cut> previousCut;  // --popping
  int lastCap = -1;                // no-stall: the previous frame's level cap
  run.baselineRssFileBytes = residentFileBytes();
  Progress progress(o.quiet);
  std::uint64_t residentBefore = residentDatasetPages(**dataset);
  const auto page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  for (std::size_t i = 0; i < path.size(); ++i) {
    const CameraPathPoint& p = path[i];
    const Camera camera = cameraOf(view, p, viewport);
    if (prefetcher) prefetcher->observe(p.tSeconds, camera);
    BenchFrame f;
    f.frame = static_cast<std::uint32_t>(i);
    f.pathSeconds = p.tSeconds;
    const std::uint64_t faults0 = threadMajorFaults();
    const auto t0 = Clock::now();
    Cut cut;
    if (noStall) {
      cut = noStallCut(noStallPolicy, camera, refinement, lastCap, f);
    } else if (!indirect) {
      auto paged = pagingCuts.cut(camera, refinement);
      if (!paged) return paged.error();
      cut = std::move(*paged);
    }
    // Indirect: the selection runs inside the frame's one submission.
    f.traversalMs = msSince(t0);
    f.decisions = indirect ? pagingCuts.selector()->index().nodes.size() : cut.nodesVisited;
    f.morphingPatches = summarizeMorph(cut).morphingPatches;
    auto frame = indirect
                     ? renderer->renderSelected(*pagingCuts.selector(), camera, deviceSelection)
                     : renderer->render(cut, camera);
    if (!frame) return frame.error();
    f.rssFileBytes = residentFileBytes();
    releaseBlobPages(**dataset);
    f.frameMs = msSince(t0);
    f.renderThreadMajorFaults = threadMajorFaults() - faults0;
    if (indirect) {
      checkDeviceDraws(view, camera, refinement, frame->stats, run);
    } else if (!noStall) {
      pagingCuts.checkAgainstHost(camera, refinement, cut, run);
    }
    if (o.popping) {
      // After the frame's own figures: the previous cut drawn with this camera, compared.
      if (auto measured =
              measurePopping(*renderer, view, refinement, previousCut, camera, frame->image, f);
          !measured) {
        return measured.error();
      }
    }
    copyRenderStats(frame->stats, f);
    const std::uint64_t residentAfter = residentDatasetPages(**dataset);
    f.bytesPagedIn = residentAfter > residentBefore ? (residentAfter - residentBefore) * page : 0;
    residentBefore = residentAfter;
    f.rssBytes = residentSetBytes();
    f.gpuPoolBytes = frame->stats.poolBytes;
    run.frames.push_back(f);
    progress.status(progressLine(run, i + 1, path.size(), f), i + 1 == path.size());
  }
  progress.finish();
  if (prefetcher) {
    prefetcher->stop();
    run.prefetchRangesAdvised = prefetcher->stats().rangesAdvised;
    run.prefetchBytesAdvised = prefetcher->stats().bytesAdvised;
  }
  return run;
}

int runBench(const BenchCliOptions& o) {
  const auto bad = [](const std::string& what) { return reportError(invalidArgument(what)); };
  if (o.prefetch != "on" && o.prefetch != "off" && o.prefetch != "both") {
    return bad("--prefetch '" + o.prefetch + "': expected on, off or both");
  }
  if (o.cutReuse != "on" && o.cutReuse != "off") {
    return bad("--cut-reuse '" + o.cutReuse + "': expected on or off");
  }
  if (o.selection != "cpu" && o.selection != "gpu") {
    return bad("--selection '" + o.selection + "': expected cpu or gpu");
  }
  if (o.draws != "readback" && o.draws != "indirect") {
    return bad("--draws '" + o.draws + "': expected readback or indirect");
  }
  if (o.draws == "indirect" && (o.selection != "gpu" || o.mode != "paging" || o.popping)) {
    return bad("--draws indirect needs --selection gpu in paging mode, without --popping");
  }
  if (o.mode != "paging" && o.mode != "no-stall") {
    return bad("--mode '" + o.mode + "': expected paging or no-stall");
  }
  if (!std::isfinite(o.lookahead) || o.lookahead < 0.0 || o.lookahead > 60.0) {
    return bad("--lookahead-s must be in [0, 60]");
  }
  if (!std::isfinite(o.tolerance) || o.tolerance <= 0.0) return bad("--tolerance-px must be > 0");
  if (!std::isfinite(o.gpuCacheMiB) || o.gpuCacheMiB <= 0.0 || o.gpuCacheMiB > 65536.0) {
    return bad("--gpu-cache-mib (--gpu-cache-mb) must be in (0, 65536]");
  }
  if (auto v = validateViewport({o.width, o.height, o.fovDegrees}); !v) {
    return reportError(v.error());
  }
  auto path = readCameraPath(o.path);
  if (!path) return reportError(path.error());
  auto probe = MappedDataset::open(o.dir);
  if (!probe) return reportError(probe.error());
  if (auto r = checkMorphOptions(o.morph, (*probe)->view(), true); !r)
    return reportError(r.error());
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
  probe->reset();  // unmapped, so a cold run can evict every page

  gpu::ContextOptions co;
  co.device = o.device;
  co.enableValidation = false;
  auto context = gpu::VulkanContext::create(co);
  if (!context) return reportError(context.error());
  tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
  std::vector<BenchRun> runs;
  for (const bool morph : {false, true}) {
    if ((morph && o.morph.morph == "off") || (!morph && o.morph.morph == "on")) continue;
    for (const bool prefetch : {false, true}) {
      if ((prefetch && o.prefetch == "off") || (!prefetch && o.prefetch == "on")) continue;
      auto run = runOnce(*context, o, *path, prefetch, morph);
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
  cmd->add_flag("--quiet", o->quiet, "No per-frame progress");
  cmd->callback([o, &status] { status.exitCode = runBench(*o); });
}

}  // namespace pbdam::tools
