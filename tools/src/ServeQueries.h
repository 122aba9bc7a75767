// The terrain queries of `pbdam serve` (GET /los, /viewshed, and /frame?viewshed=): line of sight
// and viewsheds on the render pool's Vulkan context, one query at a time (they are seconds of
// CPU on lavapipe and would starve the frames otherwise; a request that cannot start within the
// wait is refused as busy), and the last few viewsheds kept with their drape, so that the
// frames that show one do not compute it again. Thread-safety: every member is thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Viewshed.h"

namespace pbdam::tools {

/// The most cells a side of a served viewshed (`pbdam query viewshed` takes more).
inline constexpr int kServeMaxViewshedCells = 2049;

/// A computed viewshed and its drape.
struct ServedViewshed final {
  gpu::TerrainViewshed viewshed;
  std::shared_ptr<const gpu::SurfaceOverlay> overlay;
  double heightAboveGroundMeters = 0.0;
};

/// A query's answer, or the error that stopped it, or `busy`: another query held the device
/// for the whole wait (503 + Retry-After).
template <typename T>
struct QueryOutcome final {
  bool busy = false;
  std::optional<formats::Result<T>> result;
};

struct ServeQueryStats final {
  std::uint64_t sightlines = 0;
  std::uint64_t viewsheds = 0;     ///< computed
  std::uint64_t viewshedHits = 0;  ///< answered from the kept ones
  std::uint64_t busy = 0;
};

class ServeQueries final {
 public:
  /// `view` and `context` must outlive this. `wait`: how long a query waits for the device.
  ServeQueries(const runtime::DatasetView& view, gpu::VulkanContext& context,
               std::chrono::duration<double> wait)
      : view_(view), context_(context), wait_(wait) {}

  /// The viewshed of `request` (kept: the last kKept distinct requests). InvalidArgument for a
  /// bad request or a grid of more than kServeMaxViewshedCells a side.
  QueryOutcome<std::shared_ptr<const ServedViewshed>> viewshed(
      const runtime::ViewshedRequest& request);
  QueryOutcome<gpu::TerrainSightline> sightline(const gpu::GroundPoint& from,
                                                const gpu::GroundPoint& to);
  ServeQueryStats stats() const;

 private:
  /// Takes the device within the wait; false (counted as busy) when another query held it for
  /// the whole wait. A true return must be matched by releaseDevice().
  bool takeDevice();
  void releaseDevice() noexcept;
  /// Gives the device back when it goes: made right after a takeDevice() that returned true.
  class DeviceTurn final {
   public:
    explicit DeviceTurn(ServeQueries& queries) noexcept : queries_(queries) {}
    ~DeviceTurn() { queries_.releaseDevice(); }
    DeviceTurn(const DeviceTurn&) = delete;
    DeviceTurn& operator=(const DeviceTurn&) = delete;

   private:
    ServeQueries& queries_;
  };

  static constexpr std::size_t kKept = 4;
  const runtime::DatasetView& view_;
  gpu::VulkanContext& context_;
  std::chrono::duration<double> wait_;
  // One query on the device at a time: a flag under a mutex and a condition variable rather
  // than std::timed_mutex, whose try_lock_for (pthread_mutex_clocklock) GCC 12's TSan does not
  // intercept — it then saw only the unlock ("unlock of an unlocked mutex") and none of the
  // ordering between queries.
  std::mutex deviceMutex_;
  std::condition_variable deviceFree_;
  bool deviceBusy_ = false;   ///< guarded by deviceMutex_
  mutable std::mutex mutex_;  ///< the kept viewsheds and the counters
  std::list<std::pair<std::string, std::shared_ptr<const ServedViewshed>>> kept_;  ///< newest first
  ServeQueryStats stats_;
};

}  // namespace pbdam::tools
