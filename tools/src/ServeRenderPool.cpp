// Render contexts and the bounded request queue of `pbdam serve` (ServeRenderPool.h).
#include "ServeRenderPool.h"

#include "pbdam/streaming/MemoryBudget.h"

#include <algorithm>
#include <exception>
#include <future>
#include <string>

#include "pbdam/runtime/Refinement.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::tools {
namespace {

using Clock = std::chrono::steady_clock;

double millisecondsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

struct RenderPool::Job {
  FrameRequest request;
  Clock::time_point deadline;
  Clock::time_point enqueued;
  std::promise<FrameOutcome> promise;
  // Guarded by RenderPool::mutex_.
  bool done = false;  ///< the worker has finished with it (promise about to be set)
};

RenderPool::RenderPool(const MappedDataset& dataset, const RenderPoolOptions& options)
    : dataset_(dataset), options_(options) {}

Result<std::unique_ptr<RenderPool>> RenderPool::create(const MappedDataset& dataset,
                                                       const RenderPoolOptions& options) {
  if (options.workers == 0) return makeError(ErrorCode::InvalidArgument, "--workers must be >= 1");
  std::unique_ptr<RenderPool> pool(new RenderPool(dataset, options));
  gpu::ContextOptions contextOptions;
  contextOptions.device = options.device;
  auto context = gpu::VulkanContext::create(contextOptions);
  if (!context) return std::move(context).error();
  pool->context_.emplace(std::move(*context));
  pool->deviceName_ = pool->context_->deviceInfo().name;

  gpu::GpuCacheOptions cacheOptions;
  cacheOptions.budgetBytes = options.gpuCacheBytes;
  // Every context's frames in flight at the initial size; larger requests are answered from
  // the same cache (drawn in passes when a cut does not fit).
  MemoryDemand demand;
  demand.widthPixels = options.initialWidthPixels;
  demand.heightPixels = options.initialHeightPixels;
  demand.framesInFlight = options.workers * options.framesInFlight;
  demand.gpuCacheBytes = options.gpuCacheBytes;
  demand.cacheInHostMemory = pool->context_->deviceInfo().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  auto plan = planRunMemory(options.memoryBudgetMiB, demand, true);
  if (!plan) return std::move(plan).error();
  if (*plan) cacheOptions.budgetBytes = (*plan)->gpuCacheBytes;

  cacheOptions.exaggeration = options.exaggeration;
  auto cache = gpu::GpuCache::create(*pool->context_, dataset.view(), cacheOptions);
  if (!cache) {
    Error error = std::move(cache).error();
    if (error.code == ErrorCode::InvalidArgument)
      error.message = "--gpu-cache-mib: " + error.message;
    return error;
  }
  pool->cache_ = std::move(*cache);
  gpu::TerrainOptions terrainOptions;
  terrainOptions.viewport.width = options.initialWidthPixels;
  terrainOptions.viewport.height = options.initialHeightPixels;
  terrainOptions.sharedCache = pool->cache_;
  terrainOptions.refinement.exaggeration = options.exaggeration;
  // A cut over the budget is still the exact frame (drawn in passes); /stats counts them.
  terrainOptions.warnWhenBudgetExceeded = false;
  terrainOptions.framesInFlight = options.framesInFlight;
  // Earth's or Mars's atmosphere, for the requests that ask for it (time=, sun=, atmosphere=).
  if (options.atmosphere) {
    Light air;
    air.air = Light::Air::On;
    terrainOptions.atmosphere = atmosphereTablesFor(air, dataset.view().planet(), false);
  }
  // The server's dataset outlives the pool: the terrains share it without owning it. Each keeps
  // its refinement tree between frames, so a viewer's consecutive requests re-evaluate only the
  // decisions its movement may change (the same cuts as refine()).
  const std::shared_ptr<const MappedDataset> shared(std::shared_ptr<const MappedDataset>(),
                                                    &dataset);
  for (std::uint32_t i = 0; i < options.workers; ++i) {
    auto terrain = gpu::Terrain::open(*pool->context_, shared, terrainOptions);
    if (!terrain) return std::move(terrain).error();
    pool->terrains_.push_back(std::move(*terrain));
  }
  pool->stats_.workers = options.workers;
  pool->stats_.queueCapacity = options.queueCapacity;
  for (std::uint32_t i = 0; i < options.workers; ++i) {
    pool->threads_.emplace_back([p = pool.get(), i] { p->workerLoop(i); });
  }
  return pool;
}

RenderPool::~RenderPool() { shutdown(); }

void RenderPool::shutdown() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (joined_) return;
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
  const std::lock_guard<std::mutex> lock(mutex_);
  joined_ = true;
}

FrameOutcome RenderPool::render(const FrameRequest& request, Clock::time_point deadline) {
  auto job = std::make_shared<Job>();
  job->request = request;
  job->deadline = deadline;
  job->enqueued = Clock::now();
  std::future<FrameOutcome> result = job->promise.get_future();
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return {FrameRefusal::ShuttingDown, std::nullopt};
    // Room for every idle context plus the queue: requests beyond that are refused at once.
    // With several frames in flight a context draws more than one, so `rendering` may exceed
    // the contexts (the difference once wrapped around and admitted every request).
    const std::size_t idle =
        stats_.rendering < stats_.workers ? stats_.workers - stats_.rendering : 0;
    if (queue_.size() >= idle + options_.queueCapacity) {
      ++stats_.rejectedQueueFull;
      return {FrameRefusal::QueueFull, std::nullopt};
    }
    queue_.push_back(job);
    const auto waiting = static_cast<std::uint32_t>(queue_.size());
    stats_.peakQueued = std::max(stats_.peakQueued, waiting);
  }
  wake_.notify_one();
  if (result.wait_until(deadline) == std::future_status::ready) return result.get();

  std::unique_lock<std::mutex> lock(mutex_);
  if (auto it = std::find(queue_.begin(), queue_.end(), job); it != queue_.end()) {
    queue_.erase(it);
    ++stats_.expired;
    return {FrameRefusal::Deadline, std::nullopt};
  }
  if (job->done) {
    lock.unlock();
    return result.get();
  }
  // Being drawn: its context finishes the frame, which nobody waits for any more.
  ++stats_.expired;
  return {FrameRefusal::Deadline, std::nullopt};
}

/// A frame a worker has submitted and not yet handed back.
struct RenderPool::InFlight {
  std::shared_ptr<Job> job;
  Clock::time_point start;
  double traversalMs = 0.0;
};

void RenderPool::finishJob(const std::shared_ptr<Job>& job, Clock::time_point start,
                           Result<FrameResult> frame) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    --stats_.rendering;
    job->done = true;
    if (frame) {
      ++stats_.frames;
      stats_.renderMsTotal += millisecondsBetween(start, Clock::now());
      stats_.queueMsTotal += frame->queueMs;
      stats_.hits += frame->stats.hits;
      stats_.misses += frame->stats.misses;
      stats_.evictions += frame->stats.evictions;
      stats_.bytesUploaded += frame->stats.bytesUploaded;
      if (frame->stats.budgetExceeded) ++stats_.multiPassFrames;
    } else {
      ++stats_.renderErrors;
    }
  }
  job->promise.set_value({FrameRefusal::None, std::move(frame)});
}

void RenderPool::collectOldest(std::uint32_t index, std::deque<InFlight>& inFlight) {
  InFlight oldest = std::move(inFlight.front());
  inFlight.pop_front();
  Result<FrameResult> frame = makeError(ErrorCode::Internal, "frame not drawn");
  try {
    Result<gpu::RenderedFrame> drawn = terrains_[index]->collect();
    if (!drawn) {
      frame = std::move(drawn).error();
    } else {
      FrameResult out;
      out.image = std::move(drawn->image);
      out.stats = drawn->stats;
      out.queueMs = millisecondsBetween(oldest.job->enqueued, oldest.start);
      out.traversalMs = oldest.traversalMs;
      out.worker = index;
      frame = std::move(out);
    }
  } catch (const std::exception& e) {
    frame = makeError(ErrorCode::Internal, std::string("render failed: ") + e.what());
  }
  finishJob(oldest.job, oldest.start, std::move(frame));
}

void RenderPool::workerLoop(std::uint32_t index) {
  gpu::Terrain& terrain = *terrains_[index];
  const gpu::TerrainRenderer& renderer = terrain.renderer();
  const DatasetView& view = dataset_.view();
  // Frames in flight: the next request is refined, decoded and recorded while the device draws
  // the previous ones; a frame is collected (and its request answered) when every slot is taken
  // or no request is waiting, so a lone viewer never waits for a next request.
  std::deque<InFlight> inFlight;
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (inFlight.empty()) wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty() && inFlight.empty()) return;  // stopping, and nothing left to draw
      if (!queue_.empty() && inFlight.size() < renderer.framesInFlight()) {
        job = std::move(queue_.front());
        queue_.pop_front();
        if (Clock::now() >= job->deadline) {
          ++stats_.expired;
          job->done = true;
          lock.unlock();
          job->promise.set_value({FrameRefusal::Deadline, std::nullopt});
          continue;
        }
        ++stats_.rendering;
      }
    }
    if (!job) {
      collectOldest(index, inFlight);
      continue;
    }

    const auto start = Clock::now();
    try {
      const FrameRequest& r = job->request;
      // A new size replaces the offscreen targets: the frames drawn into the old ones first.
      if (r.viewport.width != renderer.widthPixels() ||
          r.viewport.height != renderer.heightPixels()) {
        while (!inFlight.empty()) collectOldest(index, inFlight);
      }
      if (Result<void> resized = terrain.resize(r.viewport.width, r.viewport.height); !resized) {
        finishJob(job, start, std::move(resized).error());
        continue;
      }
      const Camera camera = Camera::fromPose(view.planet(), r.pose, r.viewport);
      RefinementOptions refinement;
      refinement.tolerancePixels = r.tolerancePixels;
      refinement.morphRange = r.morphRange;
      refinement.exaggeration = r.exaggeration;
      if (Result<void> set = terrain.setRefinement(refinement); !set) {
        finishJob(job, start, std::move(set).error());
        continue;
      }
      if (auto cut = terrain.update(camera); !cut) {
        finishJob(job, start, std::move(cut).error());
        continue;
      }
      const double traversalMs = millisecondsBetween(start, Clock::now());
      gpu::FrameSettings settings;
      settings.overlay = r.overlay;
      applyLight(r.light, terrain.view().planet(), camera, 0.0, settings);
      if (Result<void> submitted = terrain.submit(settings); !submitted) {
        finishJob(job, start, std::move(submitted).error());
        continue;
      }
      inFlight.push_back({job, start, traversalMs});
    } catch (const std::exception& e) {
      // std::bad_alloc for a huge frame, say: the request fails, the server goes on.
      finishJob(job, start,
                makeError(ErrorCode::Internal, std::string("render failed: ") + e.what()));
    }
  }
}

RenderPoolStats RenderPool::stats() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  RenderPoolStats s = stats_;
  s.queued = static_cast<std::uint32_t>(queue_.size());
  s.cache = cache_->stats();
  return s;
}

}  // namespace pbdam::tools
