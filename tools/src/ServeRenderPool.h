// The render contexts of `pbdam serve`: N worker threads, each driving a gpu::Terrain (with
// frames in flight: a context records its next request while the device draws), all
// created from ONE VulkanContext (device, queue), drawing ONE shared read-only dataset mapping
// from ONE GPU cache (gpu/GpuCache.h: one budget, one LRU, one set of pools — what one context
// uploads the others draw); a bounded FIFO of frame requests in front of them, each with a
// deadline. Thread-safety: every public member is thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "LightOption.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/RgbaImage.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::tools {

/// One exact-mode frame to draw.
struct FrameRequest final {
  runtime::CameraPose pose;
  runtime::Viewport viewport;
  double tolerancePixels = 3.0;
  double morphRange = 0.25;  ///< RefinementOptions::morphRange (0: no morph)
  /// RefinementOptions::exaggeration: must be the pool's (RenderPoolOptions::exaggeration).
  double exaggeration = 1.0;
  std::shared_ptr<const gpu::SurfaceOverlay> overlay;  ///< draped over the terrain (a viewshed)
  Light
      light;  ///< time=, sun=, ambient= (LightOption.h); a placed sun stands over the view's target
};

/// A drawn frame and what it cost.
struct FrameResult final {
  gpu::RgbaImage image;
  gpu::FrameStats stats;
  double queueMs = 0.0;      ///< waiting for a render context
  double traversalMs = 0.0;  ///< refinement (the cut)
  std::uint32_t worker = 0;  ///< which render context drew it
};

/// Why a frame was not drawn, when it was not (besides a render error).
enum class FrameRefusal {
  None,
  QueueFull,     ///< every context busy and the queue at capacity: 503 + Retry-After
  Deadline,      ///< not drawn before the request's deadline: 503 + Retry-After
  ShuttingDown,  ///< the server is stopping: 503
};

/// What RenderPool::render gives back: a frame, a refusal, or the renderer's error.
struct FrameOutcome final {
  FrameRefusal refusal = FrameRefusal::None;
  std::optional<formats::Result<FrameResult>> frame;  ///< set when refusal == None
};

/// Figures for GET /stats.
struct RenderPoolStats final {
  std::uint32_t workers = 0;
  std::uint32_t queueCapacity = 0;
  std::uint32_t queued = 0;     ///< waiting now
  std::uint32_t rendering = 0;  ///< being drawn now
  std::uint32_t peakQueued = 0;
  std::uint64_t frames = 0;  ///< drawn successfully
  std::uint64_t renderErrors = 0;
  std::uint64_t rejectedQueueFull = 0;
  std::uint64_t expired = 0;  ///< answered 503: deadline passed while queued or drawing
  double renderMsTotal = 0.0;
  double queueMsTotal = 0.0;
  // The shared GPU cache: its state now, and lookups summed over the contexts' frames.
  gpu::GpuCacheStats cache;
  std::uint64_t hits = 0;
  std::uint64_t misses = 0;
  std::uint64_t evictions = 0;
  std::uint64_t bytesUploaded = 0;
  std::uint64_t multiPassFrames = 0;  ///< cuts over a context's budget (drawn in passes)
};

struct RenderPoolOptions final {
  std::uint32_t workers = 2;
  std::uint32_t queueCapacity = 8;
  std::uint64_t gpuCacheBytes = std::uint64_t{256} << 20;  ///< the one cache of all contexts
  std::string device;  ///< ContextOptions::device: empty for PBDAM_DEVICE or the best device
  std::uint32_t initialWidthPixels = 640;
  std::uint32_t initialHeightPixels = 480;
  /// Frames each context may have in flight (TerrainRendererOptions::framesInFlight).
  std::uint32_t framesInFlight = 2;
  /// Memory budget in MiB (0: the memory cgroup's limit, if any): on a CPU device the shared
  /// cache is lowered to leave room for the frames and the dataset's pages (MemoryBudget.h).
  double memoryBudgetMiB = 0.0;
  /// The vertical exaggeration every context draws with (the shared cache's patches are
  /// decoded under it: GpuCacheOptions::exaggeration).
  double exaggeration = 1.0;
  /// Load the planet's atmosphere tables (LightOption.h atmosphereTablesFor) for the contexts.
  bool atmosphere = true;
};

class RenderPool final {
 public:
  /// Creates the Vulkan context, the shared GPU cache and the workers' renderers; `dataset` must
  /// outlive the pool. InvalidArgument when the budget is below the cache's minimum (the
  /// message names both), DeviceError for Vulkan failures.
  static formats::Result<std::unique_ptr<RenderPool>> create(
      const streaming::MappedDataset& dataset, const RenderPoolOptions& options);

  RenderPool(const RenderPool&) = delete;
  RenderPool& operator=(const RenderPool&) = delete;
  /// Calls shutdown().
  ~RenderPool();

  /// Queues `request` and blocks until a context has drawn it, the deadline passes, or the pool
  /// is shut down. Never waits for room in the queue: a full queue is refused at once. The
  /// request's viewport and pose must be valid (validateViewport, validateCameraPose).
  FrameOutcome render(const FrameRequest& request, std::chrono::steady_clock::time_point deadline);

  /// Refuses new requests, lets the workers finish what is queued and in flight, joins them.
  /// Idempotent.
  void shutdown();

  RenderPoolStats stats() const;
  const std::string& deviceName() const noexcept { return deviceName_; }
  /// The contexts' Vulkan context, for compute queries (it serialises submissions).
  gpu::VulkanContext& context() noexcept { return *context_; }

 private:
  struct Job;
  struct InFlight;
  RenderPool(const streaming::MappedDataset& dataset, const RenderPoolOptions& options);
  void workerLoop(std::uint32_t index);
  /// Collects context `index`'s oldest frame in flight and answers its request.
  void collectOldest(std::uint32_t index, std::deque<InFlight>& inFlight);
  /// Answers `job` with `frame` and counts it.
  void finishJob(const std::shared_ptr<Job>& job, std::chrono::steady_clock::time_point start,
                 formats::Result<FrameResult> frame);

  const streaming::MappedDataset& dataset_;
  RenderPoolOptions options_;
  std::string deviceName_;
  std::optional<gpu::VulkanContext> context_;
  std::shared_ptr<gpu::GpuCache> cache_;
  std::vector<std::unique_ptr<gpu::Terrain>> terrains_;  ///< one a context, sharing cache_
  std::vector<std::thread> threads_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Job>> queue_;
  bool stopping_ = false;
  bool joined_ = false;
  RenderPoolStats stats_;
};

}  // namespace pbdam::tools
