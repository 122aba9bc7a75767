// TerrainRenderer: draws a cut (runtime/Refinement.h) of a P-BDAM dataset offscreen in exact mode
// (docs/architecture.md "Modes": every patch of the cut, each with its texture tile; the same
// camera gives the same image) and reads the frame back. Patches and tiles live in GPU-resident
// pools under one byte budget with LRU eviction (GpuCache.h, streaming/ResidencyLru.h); misses are
// decoded on TBB workers (streaming/DecodeScheduler.h) and uploaded through a staging buffer
// (docs/architecture.md "Streaming"). Objects it replaces are destroyed only after the submissions
// that used them. Implements [P-BDAM 2003] §4.2 (camera-relative vertices, patch.vert) and §4.4
// (the GPU cache). Frames in flight (TerrainRendererOptions::framesInFlight): submit() records
// and submits a frame without waiting for it, collect() waits for the oldest and reads it back,
// so the host prepares frame k+1 while the device draws frame k; render() is the two at once.
// Thread-safety: none — one thread renders; the decoding it starts runs in parallel inside
// submit(). Several renderers, each used by one thread, may share a VulkanContext
// (it serialises queue submissions) and one GpuCache (TerrainRendererOptions::sharedCache).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/RgbaImage.h"
#include "pbdam/runtime/Atmosphere.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/Selection.h"

namespace pbdam::gpu {

class VulkanContext;
class GpuSelector;

/// How a TerrainRenderer is set up.
struct TerrainRendererOptions final {
  std::uint32_t widthPixels = 1280;  ///< the frames' size
  std::uint32_t heightPixels = 720;  ///< the frames' size
  /// Budget of the renderer's private GPU cache (GpuCacheOptions::budgetBytes). Unused with a
  /// shared cache.
  std::uint64_t gpuCacheBytes = std::uint64_t{256} << 20;
  /// Upload BC1 tiles expanded to RGBA8 even when the device samples BC1 (tests, comparisons).
  /// Unused with a shared cache (GpuCacheOptions has its own).
  bool forceRgba8Textures = false;
  /// A cache shared with other renderers of the same context and dataset; unset: the renderer
  /// makes a private one from the two options above.
  std::shared_ptr<GpuCache> sharedCache;
  /// Bytes of one pool chunk (patch vertex and index buffers) and one texture page of a private
  /// cache; renderSelected() needs the whole dataset in one of each.
  std::uint64_t poolChunkBytes = std::uint64_t{16} << 20;
  /// Frames that may be submitted and not yet collected (1 to kMaxFramesInFlight): each has
  /// its own command buffers, fence, staging, records, offscreen target and readback buffer.
  std::uint32_t framesInFlight = 1;
  /// Print a warning on stderr, once per renderer, the first time a frame's cut does not fit
  /// the budget and is drawn in several passes.
  bool warnWhenBudgetExceeded = true;
  /// The atmosphere's precomputed tables (runtime::AtmosphereTables, for this dataset's planet),
  /// uploaded once: frames with FrameSettings::atmosphereExposure > 0 draw the sky behind the
  /// terrain and light the terrain through the air. Null: no atmosphere. Such frames are drawn
  /// as radiance into a floating-point target (RGBA16F) and tone-mapped into the RGBA8 frame
  /// after their last pass; RenderedFrame::radiance gives the radiance itself when asked.
  std::shared_ptr<const runtime::AtmosphereTables> atmosphere;
  /// Vertical exaggeration F of the patches drawn (GpuCacheOptions::exaggeration): a private
  /// cache is made with it, and a shared cache must have been made with it. Cuts for such a
  /// renderer must be refined with the same F (runtime::RefinementOptions::exaggeration).
  double exaggeration = 1.0;
};

/// A raster draped over the terrain (a viewshed: `pbdam render --viewshed`, `/frame?viewshed=`):
/// RGBA cells of an azimuthal equidistant grid centred on (lat, lon) on the reference surface,
/// row 0 north, blended over the terrain's texels by their alpha before lighting. The image is
/// uploaded when a frame first uses this object, so keep one object per overlay.
struct SurfaceOverlay final {
  RgbaImage image;          ///< cells × cells, square
  double latDegrees = 0.0;  ///< the grid's centre
  double lonDegrees = 0.0;  ///< the grid's centre
  double cellMeters = 0.0;  ///< the side of a cell
};

/// Per-frame settings that do not change what is resident.
struct FrameSettings final {
  /// Background colour (RGB, 0..255); tests use magenta to find holes.
  std::array<std::uint8_t, 3> clearRgb{0, 0, 0};
  /// Unit direction towards the sun in planetocentric (ECEF) axes. Unset: a light from above
  /// and behind the camera's upper right, so that the visible side is lit (defaultSunDirection).
  std::optional<glm::dvec3> sunDirectionEcef;
  /// With sunDirectionEcef, the sun's angular radius in radians (runtime::sunAngularRadiusRadians)
  /// when that is the real sun: direct light is then the share of the sun's disc above the
  /// reference surface's horizon, so the night side gets the ambient term alone. 0: a light with
  /// no horizon (every surface facing it is lit).
  float sunAngularRadiusRadians = 0.0f;
  /// > 0: the renderer's atmosphere (TerrainRendererOptions::atmosphere) drawn with this
  /// exposure (radiance × exposure through a 1 − e⁻ˣ curve): the sky and sun behind the terrain,
  /// the terrain lit by the sun and sky through the air and seen through it (aerial
  /// perspective); the ambient term is then the night side's floor. 0 (or no atmosphere): none.
  float atmosphereExposure = 0.0f;
  /// Fraction of the texel colour that faces away from the sun keep (0..1).
  float ambient = 0.35f;
  /// Under a real sun (sunAngularRadiusRadians > 0), simplified patches are shaded by their
  /// tiles' normal maps (the lattice's relief, made by the build); false: by the facets of the
  /// drawn triangles, as leaves and every patch under the camera light are.
  bool normalMaps = true;
  /// Draped over the terrain when set.
  std::shared_ptr<const SurfaceOverlay> overlay;
  /// Whether collect() reads the frame's pixels back; false gives its stats only (a benchmark
  /// that keeps no frames). render() and renderSelected() always read back.
  bool readback = true;
  /// With readback, also read back the frame's linear radiance (RenderedFrame::radiance): a
  /// frame with the atmosphere only (atmosphereExposure > 0); others have none.
  bool readRadiance = false;
  /// A window's image the frame is also copied into by the same submission
  /// (OffscreenTarget::recordPresent; the target's semaphores waited for and signalled); none
  /// for an offscreen frame. submit() only.
  std::optional<PresentTarget> present;
};

/// What one frame did. Times are milliseconds; uploadMs and drawMs are GPU time from timestamp
/// queries (on lavapipe, the CPU time the driver spent on them).
struct FrameStats final {
  std::uint64_t patches = 0;    ///< patches drawn
  std::uint64_t triangles = 0;  ///< triangles drawn
  std::uint64_t tiles = 0;      ///< texture tiles the patches used
  double decodeMs = 0.0;  ///< decoding misses into the staging buffer (TBB-parallel), wall time
  double uploadMs = 0.0;  ///< staging → pool copies
  double drawMs = 0.0;    ///< the render pass(es)
  /// Wall time from submit() to the end of its collect() (all of render(), readback included):
  /// with frames in flight a frame's latency, not the time between frames.
  double frameMs = 0.0;
  std::uint64_t residentBytes = 0;      ///< slot bytes resident in the cache after submitting it
  std::uint64_t peakResidentBytes = 0;  ///< the most resident at any time during the frame
  std::uint64_t poolBytes = 0;          ///< device memory the cache's pools hold (capacity)
  std::uint64_t hits = 0;               ///< patches + tiles found resident
  std::uint64_t misses = 0;             ///< patches + tiles decoded and uploaded
  std::uint64_t evictions = 0;          ///< patches + tiles evicted to make room
  std::uint64_t bytesUploaded = 0;      ///< bytes copied to the pools (vertices, indices, texels)
  std::uint32_t passes = 1;             ///< render passes the frame took (> 1: over budget)
  bool budgetExceeded = false;          ///< the cut did not fit the budget (passes > 1)
};

/// A frame read back: tightly packed RGBA8, top row first.
struct RenderedFrame final {
  RgbaImage image;   ///< empty for a frame submitted without readback
  FrameStats stats;  ///< what the frame did
  /// With FrameSettings::readRadiance on a frame with the atmosphere: its linear radiance (the
  /// sky's and the terrain's, before the exposure and tone curve), RGB floats, width · height ·
  /// 3, rows top-down, as image; else empty.
  std::vector<float> radiance;
};

/// A frame drawn into a host's pass (TerrainRenderer::drawInto): the host's submission of the
/// command buffer must signal `semaphore` (a timeline semaphore the renderer owns) with
/// `signalValue`, so that the renderer knows when the draws are done and may reuse their slot
/// and cache entries.
struct HostFrame final {
  VkSemaphore semaphore = VK_NULL_HANDLE;  ///< the renderer's timeline semaphore
  std::uint64_t signalValue = 0;           ///< the value the host's submission signals
  /// The cut's patches, triangles and tiles, decode time, cache hits, misses, evictions and
  /// bytes uploaded; no device timings (the host submits the draws).
  FrameStats stats;
};

/// Draws cuts of one dataset. Move-only. The VulkanContext and the DatasetView (and the bytes
/// under it) must outlive the renderer.
///
/// Over budget: when a frame's cut needs more slot bytes than the budget, the frame is drawn in
/// several passes into the same attachments (depth kept): the longest prefix of the cut (in cut
/// order) whose patches and tiles fit is made resident and drawn, then the next, and so on. The
/// draw order is the cut order either way, so the image is identical to the one-pass image;
/// FrameStats::budgetExceeded is set.
class TerrainRenderer final {
 public:
  /// The most frames in flight a renderer takes.
  static constexpr std::uint32_t kMaxFramesInFlight = 8;

  /// Creates a frame slot per frame in flight (offscreen target, command buffers, fence…) and
  /// (without options.sharedCache) a private GpuCache. Errors: InvalidArgument for a zero or
  /// too-large image size, frames in flight outside 1..kMaxFramesInFlight, a budget below
  /// minimumCacheBytes (the message names both), or a shared cache made for another context or
  /// dataset; DeviceError for Vulkan failures.
  static formats::Result<TerrainRenderer> create(VulkanContext& context,
                                                 const runtime::DatasetView& dataset,
                                                 const TerrainRendererOptions& options);

  /// The smallest budget that can draw any frame: one patch slot plus one tile slot, for the
  /// texel format this renderer would use on `context`'s device.
  static std::uint64_t minimumCacheBytes(const VulkanContext& context,
                                         const runtime::DatasetView& dataset,
                                         bool forceRgba8Textures = false);

  /// The default sun: from above the camera (planet centre → camera), a little to its right
  /// and up, so views are lit with visible relief.
  static glm::dvec3 defaultSunDirection(const runtime::Camera& camera);

  /// Takes over another renderer, leaving it empty.
  /// @{
  TerrainRenderer(TerrainRenderer&&) noexcept;
  TerrainRenderer& operator=(TerrainRenderer&&) noexcept;
  /// @}
  TerrainRenderer(const TerrainRenderer&) = delete;
  TerrainRenderer& operator=(const TerrainRenderer&) = delete;
  ~TerrainRenderer();

  /// Draws `cut` (computed for `camera` from this renderer's dataset) and reads it back:
  /// submit() then collect(). InvalidArgument while frames are pending; the others as submit().
  formats::Result<RenderedFrame> render(const runtime::Cut& cut, const runtime::Camera& camera,
                                        const FrameSettings& settings = {});

  /// Decodes and uploads what `cut` misses, records its frame into the next frame slot and
  /// submits it without waiting for the device; with settings.readback the frame's pixels are
  /// copied for collect(), with settings.present into a window's image too. It waits only
  /// where the cache cannot hold the frame beside the entries frames in flight draw (then for
  /// this renderer's oldest frame). The image is the one render() gives for the same cut,
  /// camera and settings whatever else is in flight. The camera's viewport must have the
  /// renderer's size. Errors: InvalidArgument for another
  /// size or when framesInFlight() frames are pending (collect one first); CorruptData when a
  /// patch or tile does not decode (the message names file and offset; nothing of the failed
  /// upload stays resident); DeviceError for Vulkan failures. After an error no frame was
  /// added.
  formats::Result<void> submit(const runtime::Cut& cut, const runtime::Camera& camera,
                               const FrameSettings& settings = {});
  /// Draws `cut` into the host's rendering: `cmd` is the host's primary command buffer, recording,
  /// inside a render pass or dynamic rendering that matches `pass` (one colour and one depth
  /// attachment; the viewport the camera's, at the origin). Misses are decoded and their uploads
  /// submitted on the context's queue now, so the host must submit `cmd` on that queue, after
  /// this call, through VulkanContext::submit, signalling the returned semaphore value; until
  /// then the frame's slot (one of framesInFlight()) and cache entries stay taken. `cmd` must
  /// not be one VulkanContext::submitAndWait is recording (a growing pool uses it). The draws
  /// bind the patch pipeline for `pass` (made on first use of each distinct pass), the records,
  /// tile pages and overlay sets, viewport and scissor: the host rebinds its own state after.
  /// With DepthConvention::ReversedZ, a colour attachment cleared as settings.clearRgb and depth
  /// cleared to 0, the pixels equal render()'s for the same cut and camera. Errors:
  /// InvalidArgument while offscreen frames are pending, for settings.present or a cut that
  /// does not fit the cache's budget in one pass (the message names both), for a camera of
  /// another size; the others as submit(). After an error nothing was recorded into `cmd`.
  formats::Result<HostFrame> drawInto(VkCommandBuffer cmd, const HostPass& pass,
                                      const runtime::Cut& cut, const runtime::Camera& camera,
                                      const FrameSettings& settings = {});

  /// Waits for the oldest pending frame and returns it (its image empty when it was submitted
  /// without readback; its stats with the device's timings). InvalidArgument when none is
  /// pending, DeviceError for Vulkan failures.
  formats::Result<RenderedFrame> collect();
  /// Frames submitted and not yet collected.
  std::size_t framesPending() const noexcept;
  /// The most frames that may be pending (TerrainRendererOptions::framesInFlight).
  std::uint32_t framesInFlight() const noexcept;

  /// Draws the previous render() call's frame again and reads it back: the command buffer that
  /// frame recorded for its render pass is submitted once more as it is — same per-draw records
  /// in their buffer, same resident patches and tiles, same camera and settings — with no
  /// refinement, record computation, decoding or upload. It is the baseline "raw draw of the
  /// same triangles from static buffers" that bench/bench_render.cpp compares render() with;
  /// the image is byte-identical to that frame's. Stats: the frame's patches, triangles and
  /// tiles, every entry a hit, no decode or upload; drawMs and frameMs measured as render()
  /// measures them. Errors: InvalidArgument when there is no previous frame (render() was never
  /// called, or its last call failed), when it took several passes (over budget: only its last
  /// pass is still recorded), when frames are pending or the last was not read back, or when
  /// another renderer of a shared cache has evicted one of its patches or tiles since;
  /// DeviceError for Vulkan failures.
  formats::Result<RenderedFrame> redrawLast();

  /// Selects the cut with `selector` (made for this renderer's context and dataset) and draws it
  /// from a draw list made on the device — the selection passes, draw_list.comp, then one
  /// vkCmdDrawIndexedIndirectCount — in one submission, with no read-back of the cut and no
  /// per-draw work on the host (docs/architecture.md "Selection by predicate"). Draws are in
  /// refine()'s order with the host's records bit for bit, so on IEEE devices the image is
  /// render()'s of selector.select()'s cut. The first call (and the first after render() has
  /// evicted anything) makes every patch and tile of the dataset resident by drawing them all
  /// once, and needs them to fit the private cache's budget, in one pool chunk and one texture
  /// page (TerrainRendererOptions::poolChunkBytes). Stats: patches and triangles drawn (read
  /// after the frame), uploadMs the selection and draw-list passes, drawMs the render pass; no
  /// tiles count. redrawLast() has no previous frame afterwards. `readableRecords` keeps the
  /// records where lastSelectedRecords() can read them (tests). One frame at a time: it is
  /// waited for. Errors: InvalidArgument while frames are pending, for a shared cache, a device
  /// without multi-draw indirect, indirect draw counts or draw parameters, or a dataset that does
  /// not fit (the message names the bytes); the others as render().
  formats::Result<RenderedFrame> renderSelected(GpuSelector& selector,
                                                const runtime::Camera& camera,
                                                const runtime::SelectionOptions& selection,
                                                const FrameSettings& settings = {},
                                                bool readableRecords = false);
  /// The records of renderSelected()'s last frame in draw order (made with readableRecords).
  formats::Result<std::vector<runtime::PatchDrawRecord>> lastSelectedRecords() const;

  /// Changes the image size to `widthPixels` x `heightPixels`: a new offscreen target, while the
  /// pools and every resident patch and tile stay (so a server can serve several sizes from one
  /// cache). A no-op for the current size. Afterwards redrawLast() has no previous frame.
  /// Errors as create() for the size, and InvalidArgument while frames are pending; the
  /// renderer keeps its old size then.
  formats::Result<void> resize(std::uint32_t widthPixels, std::uint32_t heightPixels);
  /// The frames' size now.
  /// @{
  std::uint32_t widthPixels() const noexcept;
  std::uint32_t heightPixels() const noexcept;
  /// @}

  /// Slot bytes resident now in the renderer's cache (shared or private).
  std::uint64_t residentBytes() const;
  /// The cache the renderer draws from.
  const std::shared_ptr<GpuCache>& cache() const noexcept;
  /// Whether tiles are sampled as BC1 on the device (else RGBA8).
  bool usesBc1Textures() const noexcept;

 private:
  struct Impl;
  friend class PassDrawer;  // one pass of a frame (TerrainRenderer.cpp)
  explicit TerrainRenderer(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pbdam::gpu
