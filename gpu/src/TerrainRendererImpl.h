// The inside of a TerrainRenderer (internal to pbdam_gpu; TerrainRenderer.h): its frame slots and
// the protocol that keeps frames in flight safe. TerrainRenderer.cpp draws cuts the host chose;
// SelectedFrames.cpp draws from the draw list made on the device (DeviceDrawList.h).
//
// Frames in flight. The renderer owns `framesInFlight` slots, each with everything a submitted
// frame reads or writes until its fence signals: two command buffers (uploads, render pass), a
// fence, a staging buffer, a per-draw records buffer and its descriptor set, an overlay binding,
// an offscreen target with its readback buffer and four timestamp queries. submit() takes the
// next slot (it must have been collected), records the frame into it and submits it without
// waiting; collect() waits for the oldest slot's fence and reads it. The GPU cache entries the
// frame draws stay pinned from its reservation until its fence has been seen to signal, so no
// later frame (of this renderer or another of a shared cache) evicts or overwrites a slot a
// frame in flight reads; a reservation that does not fit beside them first waits for this
// renderer's own oldest frame (CacheLease::reserve's releaseOwnPins). Objects the renderer
// replaces go to `garbage` keyed by submission number and are destroyed once every submission up
// to that number has been seen to complete.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "AtmosphereBinding.h"
#include "CacheLease.h"
#include "DeferredDestruction.h"
#include "DeviceDrawList.h"
#include "GpuCacheState.h"
#include "StagingUploader.h"
#include "SurfaceOverlayBinding.h"
#include "ToneMapPass.h"
#include "pbdam/gpu/HostPass.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/UniqueHandle.h"
#include "pbdam/streaming/DecodeScheduler.h"

namespace pbdam::gpu {

/// How long a submission may take before it is reported as a device error.
inline constexpr std::uint64_t kSubmitTimeoutNanoseconds = 60'000'000'000ull;

/// Records `cmd` again (it was allocated from a pool that allows resetting single buffers, so
/// beginning resets it): reusable, not one-time-submit.
formats::Result<void> recordCommands(VkCommandBuffer cmd, const char* what,
                                     const std::function<void(VkCommandBuffer)>& record);
/// Points a records set (binding 0 of the patch pipeline's set 0) at `buffer`.
void bindRecords(VkDevice device, VkDescriptorSet set, VkBuffer buffer);
/// The push constants of a frame: view-projection (for the depth convention of the pass it is
/// drawn in), sun direction and ambient, and the camera and exposure of the atmosphere (none
/// unless `atmosphere` has tables and the settings an exposure).
PatchPush patchPush(const runtime::Camera& camera, const FrameSettings& settings,
                    const AtmosphereBinding& atmosphere,
                    DepthConvention depth = DepthConvention::ReversedZ);
/// The clear colour of `settings`, linear 0..1.
std::array<float, 4> clearColour(const FrameSettings& settings);

std::string mebibytes(std::uint64_t bytes);

/// One frame's worth of objects (see the file comment).
struct FrameSlot final {
  static constexpr std::size_t kUploadCommands = 0;
  static constexpr std::size_t kDrawCommands = 1;
  /// The copy into a window's image (PresentTarget): apart from the draw, which redrawLast()
  /// submits again as it is.
  static constexpr std::size_t kPresentCommands = 2;
  std::array<VkCommandBuffer, 3> commands{};  ///< freed with the renderer's command pool
  UniqueFence fence;
  OffscreenTarget target;
  StagingUploader uploader;
  GpuBuffer records;
  VkDescriptorSet recordsSet = VK_NULL_HANDLE;  ///< freed with the renderer's descriptor pool
  std::optional<SurfaceOverlayBinding> overlay;
  std::uint32_t firstQuery = 0;  ///< its four timestamp queries: 0 and 3 uploads, 1 and 2 draw

  /// The number of its latest submission on `fence`; 0: none yet.
  std::uint64_t submission = 0;
  /// Submitted and not yet seen to complete (its fence not waited for).
  bool running = false;
  /// A frame drawn into a host's pass (drawInto): the value of the renderer's timeline semaphore
  /// the host's submission signals once the draws are done; 0: none outstanding. Its pins and
  /// buffers are kept until the semaphore has been seen to reach it.
  std::uint64_t hostSignal = 0;
  /// Submitted and not yet collected (running, or complete and unread).
  bool pending = false;
  bool readback = true;
  /// Its frame's radiance is read back too (FrameSettings::readRadiance on a radiance frame).
  bool readRadiance = false;
  /// Cache entries its frame draws, pinned until its fence has been seen to signal.
  std::vector<streaming::ResidentKey> pins;
  /// The entries its last pass drew and their slots: redrawLast() pins them again, and
  /// refuses if another renderer of a shared cache has evicted one since.
  std::vector<std::pair<streaming::ResidentKey, std::uint32_t>> lastPassEntries;
  FrameStats stats;
  std::chrono::steady_clock::time_point start;
};

struct TerrainRenderer::Impl {
  VulkanContext* context = nullptr;
  const runtime::DatasetView* dataset = nullptr;
  TerrainRendererOptions options;
  /// The cache this renderer draws from: its own (privateCache) or one shared with other
  /// renderers (GpuCache.h). `cache` keeps it alive; `shared` is its state.
  std::shared_ptr<GpuCache> cache;
  GpuCache::State* shared = nullptr;
  bool privateCache = true;
  std::optional<streaming::DecodeScheduler> decoder;
  /// Set 4: the atmosphere's tables (TerrainRendererOptions::atmosphere; 1×1 ones without).
  std::optional<AtmosphereBinding> atmosphere;
  /// With the atmosphere: the tone map its frames end with, and the pipelines that draw them as
  /// radiance (the slots' targets keep a radiance image).
  std::optional<ToneMapPass> toneMap;
  std::optional<RadiancePipelines> radiancePipelines;

  UniqueDescriptorPool recordsPool;
  UniqueCommandPool commandPool;
  UniqueQueryPool queries;
  std::uint64_t timestampMask = 0;
  double timestampPeriodNs = 1.0;
  bool warned = false;

  std::vector<FrameSlot> slots;
  /// Pending slots, oldest first.
  std::deque<std::size_t> pendingOrder;
  /// Slots of frames drawn into a host's pass whose semaphore value has not been seen, oldest
  /// first; the timeline semaphore the host's submissions signal and its last value handed out.
  std::deque<std::size_t> hostOrder;
  UniqueSemaphore hostTimeline;
  std::uint64_t hostSignalled = 0;
  /// The patch pipelines made for the hosts' passes this renderer has drawn into.
  std::vector<std::pair<HostPass, UniquePipeline>> hostPipelines;
  /// The slot the next frame takes.
  std::size_t nextSlot = 0;
  /// Submissions are numbered 1, 2, … over every slot: `submitted` is the latest made,
  /// `completed` the latest up to which every submission has been seen to complete.
  std::uint64_t submitted = 0;
  std::uint64_t completed = 0;
  DeferredDestruction garbage;
  /// The stats of the last frame when it was collected after succeeding and nothing has been
  /// submitted since (its slot's draw commands then hold its last pass); else unset.
  std::optional<FrameStats> lastFrame;
  std::size_t lastFrameSlot = 0;

  /// renderSelected()'s draw list made on the device, the selector it reads and the records
  /// set of its records. It records where every patch and tile is in the cache, so a frame
  /// that evicts anything drops it.
  std::optional<DeviceDrawList> deviceList;
  const GpuSelector* deviceListSelector = nullptr;
  VkDescriptorSet deviceRecordsSet = VK_NULL_HANDLE;

  static constexpr std::uint32_t kQueriesPerSlot = 4;

  /// The exposure of the tone map a frame with `push` and `settings` ends with: the frame keeps
  /// its radiance (the float target, a tone-map pass after its last pass) only when it is read
  /// back (FrameSettings::readRadiance); else 0: its fragments are tone-mapped as they are drawn,
  /// the same colours (nothing blends) without a pass over the whole frame, which costs lavapipe
  /// as much as the atmosphere (docs/decisions.md "Light and air").
  float toneMapExposure(const PatchPush& push, const FrameSettings& settings) const noexcept {
    return toneMap && radiancePipelines && settings.readback && settings.readRadiance
               ? push.camera[3]
               : 0.0f;
  }

  ~Impl();

  /// Creates the descriptor pool, command pool and timestamp queries, and `count` slots.
  formats::Result<void> createFrameObjects(std::uint32_t count);
  formats::Result<void> ensureRecords(FrameSlot& slot, std::size_t count);

  /// Submits `buffers` (already recorded) of `slot` in one batch on its fence; with `wait`,
  /// waits for them (finish()).
  formats::Result<void> submitSlot(FrameSlot& slot, std::span<const VkCommandBuffer> buffers,
                                   const PresentTarget* present, const char* what, bool wait);
  /// Waits for `slot`'s submission if it is running and for the host's draws of a host-pass
  /// frame, then unpins its entries (the cache lock is taken unless `cacheLocked`), advances
  /// `completed` and destroys what waited for it.
  formats::Result<void> finish(FrameSlot& slot, bool cacheLocked);
  /// Waits until the host's submissions have signalled `value` on hostTimeline; DeviceError
  /// after kSubmitTimeoutNanoseconds (a frame drawn into a host's pass that was never submitted
  /// with its signal).
  formats::Result<void> waitForHost(std::uint64_t value) const;
  /// Waits for the oldest running slot, offscreen frames first, then frames in hosts' passes
  /// (the cache lock held by the caller): false when none runs.
  bool finishOldestLocked();
  /// Reads the slot's draw timestamps (1, 2) and, with `withUploads`, its upload timestamps
  /// (0, 3) into `stats`.
  void readTimestamps(const FrameSlot& slot, bool withUploads, FrameStats& stats) const;
  /// A frame's opening figures: the cut's counts and what is resident before it.
  FrameStats frameOpening(const runtime::Cut& cut) const;
  /// The node records of the cut's patches, in cut order.
  std::vector<formats::NodeRecord> cutNodes(const runtime::Cut& cut) const;
  /// Readies `slot` for a frame of `cut`: records buffer room and the settings' overlay.
  formats::Result<void> prepareSlot(FrameSlot& slot, const runtime::Cut& cut,
                                    const runtime::Camera& camera, const FrameSettings& settings);
  /// A frame's closing figures (what it left resident, the pools' size); a device draw list
  /// that knew where evicted entries were is dropped.
  void frameClosing(FrameStats& stats);
  /// The camera's viewport must be the renderer's size.
  formats::Result<void> checkViewport(const runtime::Camera& camera) const;
  /// The slot the next frame takes (a host-pass frame it held is waited for), or
  /// InvalidArgument when it has not been collected.
  formats::Result<FrameSlot*> freeSlot();
  /// Takes the pending slot off the queue and returns its frame (pixels read back if asked).
  formats::Result<RenderedFrame> collectOldest();

  /// After every patch and tile has been made resident: the device draw list over `selector`'s
  /// nodes, and its records set (SelectedFrames.cpp).
  formats::Result<void> makeDeviceList(const GpuSelector& selector, bool readableRecords);
  /// Records renderSelected()'s frame into `slot`: selection, draw list, indirect draw,
  /// readback (SelectedFrames.cpp).
  formats::Result<void> recordSelectedFrame(FrameSlot& slot, GpuSelector& selector,
                                            const runtime::Camera& camera,
                                            const runtime::SelectionOptions& selection,
                                            const FrameSettings& settings);
};

}  // namespace pbdam::gpu
