// Terrain: one P-BDAM dataset as a host program drives it, frame by frame (docs/embedding.md). It
// owns what a frame loop wires together — the mapped dataset, the memory plan, the renderer and
// its GPU cache, the cut source of the mode, the prefetcher and the coarse levels' page holds —
// and gives the host, per frame, update() with the camera (the cut and what it took), then either
// an offscreen frame (submit() and collect()) or draws into the host's own pass (drawInto()),
// with what the host needs to place its own objects in the same depth buffer: the camera-relative
// origin and the double-precision view rotation and projection. Height, line of sight and
// viewshed queries run on the same dataset and device.
//
// Synchronisation: everything runs on VulkanContext::queue(), through VulkanContext::submit (its
// queue lock). Uploads are recorded and submitted by the terrain in submit() and drawInto(); a
// host's command buffer from drawInto() must be submitted after that call through
// VulkanContext::submit, signalling HostFrame's timeline value. At most framesInFlight frames
// are outstanding; a further frame waits for the oldest (offscreen frames must be collected).
// Device loss shows as DeviceError from submit(), collect() or drawInto(); the terrain is then
// unusable (open a new context and terrain). Thread-safety: none — one thread drives a terrain;
// the prefetcher's worker and the decoding run inside it.
#pragma once

#include <vulkan/vulkan.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/CutSource.h"
#include "pbdam/gpu/FrameModes.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/runtime/Viewshed.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/Prefetcher.h"

namespace pbdam::gpu {

class VulkanContext;

/// What a frame does about data that is not resident (docs/architecture.md "Modes").
enum class TerrainMode {
  /// The complete cut, its pages read when touched: the same camera gives the same image.
  Exact,
  /// The complete cut as in Exact, with the prefetcher's predicted pages advised ahead.
  Paging,
  /// Never waits for the disk: the finest resident cut under a level cap that rises by at most
  /// one diamond level a frame, while a loader thread fetches what is missing; the coarse levels
  /// are preloaded and locked for the terrain's life.
  NoStall,
};

/// How a Terrain is opened. Defaults: exact mode, 3 px, the dataset's morph range, a 256 MiB GPU
/// cache, no memory plan, 1280 x 720 at 60°, one frame in flight.
struct TerrainOptions final {
  /// What a frame does about data that is not resident.
  TerrainMode mode = TerrainMode::Exact;
  /// Tolerance in pixels, morph range and level cap of every frame's cut, and the vertical
  /// exaggeration the terrain is drawn with (in (0, 100], fixed for the terrain's life).
  runtime::RefinementOptions refinement;
  /// Cuts selected on the host, or by the selection's compute passes on the device (Exact and
  /// Paging; the same cuts on lavapipe).
  CutSelection selection = CutSelection::Cpu;
  /// With device selection: the cut read back (Readback), or the draw list made on the device
  /// (Indirect: frames through renderer().renderSelected() with cutSource().selector(); the
  /// whole dataset resident, the cache sized for it in one pool chunk; no focus regions).
  DrawList draws = DrawList::Readback;
  /// Host selection without focus: keep the refinement tree from frame to frame (the same cuts,
  /// fewer decisions), or refine from the roots every frame.
  bool reuseRefinementTree = true;
  /// Regions drawn at full detail whatever the screen error (Exact and Paging, host selection
  /// or device selection): runtime/Selection.h.
  std::vector<runtime::FocusRegion> focus;
  /// Paging and NoStall: advise the pages of the cut predicted `lookaheadSeconds` ahead
  /// (update() with the frames' times). NoStall without it fetches the current camera's cut.
  bool prefetch = false;
  double lookaheadSeconds = 0.5;  ///< how far ahead the prefetcher predicts the camera
  /// Called on the prefetcher's worker for each range it advises (benchmarks count their use).
  std::function<void(const streaming::PrefetchRange&)> onPrefetchRange;
  /// The GPU cache's budget of patch and tile slots.
  std::uint64_t gpuCacheBytes = std::uint64_t{256} << 20;
  /// A cache shared with other terrains of the same context and dataset (a server's render
  /// contexts: what one uploads the others draw); unset, the terrain makes its own from
  /// gpuCacheBytes. The memory plan, if any, does not size a shared cache.
  std::shared_ptr<GpuCache> sharedCache;
  /// Print a warning on stderr the first time a frame's cut is drawn in several passes.
  bool warnWhenBudgetExceeded = true;
  /// The atmosphere's tables (TerrainRendererOptions::atmosphere); null: none.
  std::shared_ptr<const runtime::AtmosphereTables> atmosphere;
  /// The process's memory budget in MiB: unset, no plan (node tables paged under the cgroup's
  /// limit, if any); 0, the memory cgroup's limit; above 0, this many MiB. With a budget the
  /// GPU cache is lowered to fit, the prefetcher keeps within the page room left, and no-stall
  /// frames hold their pages until decoded (streaming/MemoryBudget.h).
  std::optional<double> memoryBudgetMiB;
  /// Print the memory plan on stderr when it lowered the cache or the budget was given.
  bool reportMemoryPlan = false;
  /// The image every frame is drawn at: the cameras given to update() must have this size.
  runtime::Viewport viewport;
  /// Frames submitted (or drawn into hosts' passes) and not yet done, 1 to
  /// TerrainRenderer::kMaxFramesInFlight.
  std::uint32_t framesInFlight = 1;
};

/// What update() made for a camera.
struct TerrainUpdate final {
  runtime::Cut cut;                ///< the patches to draw, in draw order
  double traversalMs = 0.0;        ///< selecting the cut, wall time
  int levelCap = -1;               ///< NoStall: the level cap of the cut; −1 otherwise
  runtime::CutMorphSummary morph;  ///< how many of its patches morph or blend
};

/// One dataset, its renderer and its frame loop's parts, driven by a host. Not copyable or
/// movable (its prefetcher's worker refers to it); held by unique_ptr.
class Terrain final {
 public:
  /// Opens the dataset directory `dataset` (MappedDataset::open, its node tables paged under
  /// the memory limit) and makes the rest on `context`, which must outlive the terrain. Errors:
  /// InvalidArgument for options out of range (each named: tolerance, frames in flight,
  /// viewport, prefetch in Exact mode, look-ahead outside [0, 60] s, a memory budget below what
  /// the frames need); the errors of MappedDataset::open, TerrainRenderer::create and the cut
  /// sources.
  static formats::Result<std::unique_ptr<Terrain>> open(VulkanContext& context,
                                                        const std::filesystem::path& dataset,
                                                        TerrainOptions options);
  /// The same for a dataset the host has opened already (to check it before making a device, or
  /// to keep using it beside the terrain).
  static formats::Result<std::unique_ptr<Terrain>> open(
      VulkanContext& context, std::shared_ptr<const streaming::MappedDataset> dataset,
      TerrainOptions options);

  Terrain(const Terrain&) = delete;
  Terrain& operator=(const Terrain&) = delete;
  ~Terrain();

  /// The frame's cut for `camera` (of the options' viewport size), selected by the mode's cut
  /// source; with a prefetcher the camera is first shown to it at `tSeconds` (the frame's time;
  /// NaN: not shown). The result stays valid until the next update(). Errors: InvalidArgument
  /// for a camera of another size; DeviceError from device selection.
  /// With `complete`, the cut is the host's refinement from the roots whatever the mode (a
  /// screenshot of a no-stall flight: every patch at the tolerance, pages read as touched).
  formats::Result<const TerrainUpdate*> update(const runtime::Camera& camera,
                                               double tSeconds = std::nan(""),
                                               bool complete = false);

  /// Draws the last update()'s cut offscreen (TerrainRenderer::submit) without waiting; collect()
  /// returns it. Errors as TerrainRenderer::submit, and InvalidArgument before any update().
  formats::Result<void> submit(const FrameSettings& settings = {});
  /// The oldest submitted frame (TerrainRenderer::collect).
  formats::Result<RenderedFrame> collect();
  /// Draws the last update()'s cut into the host's pass (TerrainRenderer::drawInto: the host
  /// submits `cmd` signalling the returned value). Errors as drawInto, and InvalidArgument
  /// before any update().
  formats::Result<HostFrame> drawInto(VkCommandBuffer cmd, const HostPass& pass,
                                      const FrameSettings& settings = {});

  /// Changes the tolerance, morph range or level cap of later frames' cuts (a host's controls);
  /// the prefetcher keeps predicting with the options' refinement. InvalidArgument for a
  /// tolerance that is not a positive number of pixels, or another exaggeration than the
  /// terrain's (fixed at open: the GPU cache's patches were decoded with it).
  formats::Result<void> setRefinement(const runtime::RefinementOptions& refinement);

  /// The image size every frame is drawn at (the cameras' viewport), and changes it: a new
  /// offscreen target while the cache keeps what is resident (TerrainRenderer::resize). Errors as
  /// that; InvalidArgument while frames are pending.
  formats::Result<void> resize(std::uint32_t widthPixels, std::uint32_t heightPixels);

  /// The camera of the last update() (call one first): the frame's camera-relative origin is
  /// its position().
  const runtime::Camera& camera() const noexcept { return *camera_; }
  /// The camera-relative origin of the last frame, planetocentric metres: the shaders see
  /// positions minus this, so a host draws its objects at (ECEF − origin) in double, then float.
  glm::dvec3 origin() const noexcept { return camera_->position(); }
  /// The last frame's world-to-view rotation, double precision (Camera::viewRotationDouble).
  glm::dmat4 viewRotation() const noexcept { return camera_->viewRotationDouble(); }
  /// The last frame's projection for the host's depth convention (hostProjection).
  glm::dmat4 projection(DepthConvention depth = DepthConvention::ReversedZ) const noexcept {
    return hostProjection(*camera_, depth);
  }

  /// The rendered surface's height at (lat, lon) in degrees (runtime::surfaceHeightAt).
  formats::Result<runtime::SurfaceHeight> heightAt(double latDegrees, double lonDegrees) const;
  /// Whether two points above the terrain see each other (gpu::sightlineOverTerrain).
  formats::Result<TerrainSightline> lineOfSight(const GroundPoint& from, const GroundPoint& to);
  /// The viewshed of `request` (gpu::viewshedOverTerrain).
  formats::Result<TerrainViewshed> viewshed(const runtime::ViewshedRequest& request);

  /// The parts, for hosts and commands that go further (benchmarks' figures).
  /// @{
  const runtime::DatasetView& view() const noexcept { return dataset_->view(); }
  const streaming::MappedDataset& dataset() const noexcept { return *dataset_; }
  TerrainRenderer& renderer() noexcept { return *renderer_; }
  CutSource& cutSource() noexcept { return *cuts_; }
  /// @}
  /// The memory plan the terrain was sized by; unset without a budget.
  const std::optional<streaming::MemoryPlan>& memoryPlan() const noexcept { return plan_; }
  /// The prefetcher (Paging with prefetch, NoStall); null otherwise.
  streaming::Prefetcher* prefetcher() noexcept { return prefetcher_ ? &*prefetcher_ : nullptr; }
  /// Stops the prefetcher's worker (its figures stay readable).
  void stopPrefetcher();
  /// NoStall: the coarse levels that could not be preloaded (the level cap keeps them out).
  const std::vector<formats::Error>& preloadSkipped() const noexcept { return preloadSkipped_; }
  /// NoStall: the pages of the preloaded coarse levels, locked for the terrain's life.
  const streaming::HeldPages& coarseLevels() const noexcept { return coarse_; }
  /// The GPU cache's budget: the options', or what the memory plan lowered it to, or (device
  /// draw lists) what the whole dataset takes.
  std::uint64_t gpuCacheBytes() const noexcept { return gpuCacheBytes_; }
  /// The options it was opened with (the memory plan may have lowered the cache since).
  const TerrainOptions& options() const noexcept { return options_; }
  /// The device it draws on.
  VulkanContext& context() noexcept { return *context_; }

 private:
  Terrain(VulkanContext& context, std::shared_ptr<const streaming::MappedDataset> dataset,
          TerrainOptions options);
  formats::Result<void> start();

  VulkanContext* context_;
  std::shared_ptr<const streaming::MappedDataset> dataset_;
  TerrainOptions options_;
  std::optional<streaming::MemoryPlan> plan_;
  std::optional<TerrainRenderer> renderer_;
  std::unique_ptr<CutSource> cuts_;
  std::unique_ptr<CutSource> completeCuts_;  ///< made on the first update(..., true)
  CutSource* lastSource_ = nullptr;          ///< the source of the last update()'s cut
  std::uint64_t gpuCacheBytes_ = 0;
  streaming::HeldPages coarse_;
  std::vector<formats::Error> preloadSkipped_;
  std::optional<streaming::Prefetcher> prefetcher_;
  std::optional<runtime::Camera> camera_;
  std::optional<TerrainUpdate> frame_;
};

}  // namespace pbdam::gpu
