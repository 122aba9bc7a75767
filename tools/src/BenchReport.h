// The report of `pbdam bench`: per-frame figures (frames.csv), the summary of each run
// (summary.json) and plots like [P-BDAM 2003] Fig. 8 (report.png, drawn with PLplot's cairo PNG
// driver). Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "LightOption.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/FrameModes.h"

namespace pbdam::tools {

/// One frame of one run.
struct BenchFrame final {
  std::uint32_t frame = 0;
  double pathSeconds = 0.0;  ///< the camera path's t
  /// The render loop's time for the frame: traversal, then submitting it (decode, upload,
  /// recording) and collecting the frame from framesInFlight frames before (waiting for the
  /// device, readback): with one in flight traversal + render, with more the time between
  /// frames. The last frame's includes collecting the frames still in flight.
  double frameMs = 0.0;
  double traversalMs = 0.0;
  double decodeMs = 0.0;
  double uploadMs = 0.0;
  double drawMs = 0.0;
  std::uint64_t triangles = 0;
  std::uint64_t patches = 0;
  std::uint64_t tiles = 0;
  int drawnLevelCap = -1;  ///< no-stall: the level cap used (−1: none)
  std::uint64_t renderThreadMajorFaults = 0;
  std::uint64_t bytesPagedIn = 0;  ///< growth of the dataset's page-cache residency
  std::uint64_t gpuHits = 0, gpuMisses = 0, gpuEvictions = 0;
  std::uint64_t rssBytes = 0;
  std::uint64_t gpuPoolBytes = 0;  ///< device memory of the GPU cache (host memory on lavapipe)
  /// File-backed resident bytes of the process at the end of the frame, before the dataset
  /// mappings are released: shared libraries (constant) plus the dataset pages the frame touched.
  std::uint64_t rssFileBytes = 0;
  /// Split and cull decisions the refinement evaluated (Cut::nodesVisited).
  std::uint64_t decisions = 0;
  /// With --popping: this frame's image against the previous frame's cut drawn with this
  /// frame's camera, over every RGB value of every pixel (0–255): the popping the change of
  /// cut alone causes. −1 when not measured (no --popping, or the first frame).
  double poppingRms = -1.0;
  double poppingMax = -1.0;
  /// Patches whose parent's or grandparent's morph weight is strictly between 0 and 1.
  std::uint64_t morphingPatches = 0;
};

/// One replay of the path with one prefetch setting.
struct BenchRun final {
  bool prefetch = false;
  bool morph = false;  ///< the geomorph (docs/architecture.md "Geomorphing")
  gpu::StreamingMode mode = gpu::StreamingMode::Paging;
  bool cutReuse = false;  ///< the refinement tree kept from frame to frame (IncrementalRefiner)
  gpu::CutSelection selection =
      gpu::CutSelection::Cpu;  ///< Gpu: the cut from the device's selection passes
  /// With selection Gpu: frames whose device cut is not the host's (the same patches in the
  /// same order), and the largest screen error over the tolerance among the device cut's drawn
  /// inner patches, computed on the host in double (at most 1 + 1e-6 where the device's double
  /// arithmetic differs from the host's; exactly ≤ 1 on lavapipe).
  std::uint64_t selectionFramesDiffering = 0;
  double selectionMaxScreenRatio = 0.0;
  /// With selection Gpu: Readback (the host lists the cut and its records) or Indirect (the draw
  /// list made on the device, TerrainRenderer::renderSelected; then the host cut is compared by
  /// its patch and triangle counts, and the screen ratio is not measured).
  gpu::DrawList draws = gpu::DrawList::Readback;
  bool popping = false;  ///< frames drawn twice for the popping measure
  /// Frames submitted and not yet collected (TerrainRendererOptions::framesInFlight): 1 with
  /// --popping and with the device-made draw list.
  std::uint32_t framesInFlight = 1;
  bool readback = false;  ///< every frame's pixels copied back to the host
  /// The memory budget the run was sized for (MemoryBudget.h): 0 without one; its source, and
  /// the GPU cache budget the run used.
  std::uint64_t memoryBudgetBytes = 0;
  std::string memoryBudgetSource;
  /// Whether the node tables were paged (FaceViewOptions, under a memory budget) and how many
  /// of their chunks were read back from the files.
  bool nodeTablesPaged = false;
  int datasetDepth = 0;  ///< the deepest bintree level (frames_below_full_depth)
  std::uint64_t nodeChunkReads = 0;
  std::uint64_t gpuCacheBytes = 0;
  bool cold = false;
  double residentAfterEvictFraction = 0.0;  ///< pages left in the page cache after eviction
  std::uint64_t residentAfterEvictPages = 0;
  std::uint64_t datasetPages = 0;
  std::uint64_t prefetchRangesAdvised = 0;
  std::uint64_t prefetchRangesDeferred = 0;  ///< left to a later prediction (page room)
  /// Advised ranges a frame's cut used, and advised ranges found (mincore, every 30 frames and
  /// at the end) to have left the page cache before any cut used them.
  std::uint64_t prefetchRangesUsed = 0;
  std::uint64_t prefetchRangesEvictedBeforeUse = 0;
  std::uint64_t prefetchBytesAdvised = 0;
  /// File-backed RSS just before the first frame (shared libraries; no dataset page mapped yet).
  std::uint64_t baselineRssFileBytes = 0;
  /// Wall time from the start of the first frame to the end of the last (the end of its
  /// frameMs): the frames' own times, and between them what the loop does untimed (the checks
  /// of a device cut against the host's, --popping's second draw, the residency figures).
  double wallMs = 0.0;
  std::vector<BenchFrame> frames;
};

struct BenchSetup final {
  std::string dataset;
  std::string path;
  std::uint32_t width = 0, height = 0;
  double tolerancePixels = 0.0;
  double morphRange = 0.0;  ///< --morph-range (runs with morph on)
  double lookaheadSeconds = 0.0;
  std::uint64_t gpuCacheBytes = 0;
  std::uint64_t datasetBytes = 0;
  double exaggeration = 1.0;  ///< --exaggeration
  LightSummary light;         ///< --time, --sun, --ambient, --atmosphere, --exposure
};

/// The p-quantile (0..1) of `v`, linear between ranks; 0 for an empty vector (bench's and
/// fly's frame-time figures).
double percentile(std::vector<double> v, double p);

/// Writes frames.csv, summary.json and report.png into `dir` and returns the summary text
/// printed by the command.
formats::Result<std::string> writeBenchReport(const std::filesystem::path& dir,
                                              const BenchSetup& setup,
                                              const std::vector<BenchRun>& runs);

}  // namespace pbdam::tools
