// Speculative prefetch (docs/architecture.md "Streaming"; [P-BDAM 2003] §4.4): a worker thread
// predicts the camera at 1/8, 1/4, 1/2 and all of a look-ahead ahead (nearest first) by linear
// extrapolation of the last poses, runs the renderer's refinement for each predicted camera, and
// asks the kernel to start reading (madvise(MADV_WILLNEED)) the page-aligned byte ranges of every
// needed patch and tile that is not resident. The render path knows nothing of it: whoever drives
// the frames hands it the camera of each frame. Thread-safety: observe() and stats() may be called
// from any thread while the worker runs.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>

#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/ResidencyLru.h"

namespace pbdam::streaming {

/// Linear extrapolation of a camera from its last poses: position and view axes move with the
/// velocity of the last two observations (axes re-orthonormalised). Not thread-safe.
class CameraPredictor final {
 public:
  /// Records `camera` as the pose at `timeSeconds`.
  void observe(double timeSeconds, const runtime::Camera& camera);
  /// The camera predicted at `timeSeconds`; nullopt before the first observation. With one
  /// observation it is that camera.
  std::optional<runtime::Camera> predict(double timeSeconds) const;
  /// The time of the last observation; nullopt before the first.
  std::optional<double> lastTime() const;

 private:
  struct Sample {
    double time;
    runtime::Camera camera;
  };
  std::deque<Sample> samples_;
};

/// A patch's or tile's byte range of a predicted cut, as the prefetcher handled it.
struct PrefetchRange final {
  ResidentKey key;           ///< the patch or tile (packKey() of its NodeKey or TileKey)
  int face = 0;              ///< the face file the range is in
  std::uint64_t offset = 0;  ///< first byte in the face file
  std::uint64_t bytes = 0;   ///< the range's length
  bool wasResident = false;  ///< already in the page cache: not advised
  std::uint64_t cycle = 0;   ///< which prediction (1, 2, …) asked for it
};

/// How far ahead a Prefetcher predicts and how it refines and advises the predicted cuts.
struct PrefetchOptions final {
  double lookaheadSeconds = 0.5;          ///< the farthest prediction, from the last observed frame
  runtime::RefinementOptions refinement;  ///< the frames' own refinement options
  /// Beyond the nearest horizon (which asks for exactly the predicted camera's cut, first), the
  /// predicted cameras see this much more (degrees added to the vertical field of view, the
  /// image grown with it so that pixels per radian and so levels of detail stay the same), so
  /// that a turn the extrapolation misses still finds its data resident.
  double fovMarginDegrees = 10.0;
  /// Beyond the nearest horizon, the predicted cuts are refined at this fraction of the
  /// frames' tolerance, so that a descent faster than extrapolated still finds its finer levels
  /// resident (docs/performance.md "Insets": measured on the Mars flight over an inset and over
  /// the large-data dataset).
  double toleranceScale = 0.75;
  /// Called on the worker thread for every range of a predicted cut that was not advised in
  /// the last 16 predictions, or was and left the page cache since (a proactive reclaimer takes
  /// pages read ahead and not yet used), after it was advised (or found resident). Unset: nothing.
  /// Lets a caller (a test) see what was fetched; must not call back into the Prefetcher.
  std::function<void(const PrefetchRange&)> onRange;
  /// The page cache's room for the dataset under a memory budget (MemoryPlan::pageRoomBytes);
  /// 0: no bound. Otherwise a prediction advises at most half of it (bytes not resident yet,
  /// the nearest horizon first) and leaves the rest to the next predictions (rangesDeferred),
  /// so that under a cap advised pages do not push out each other, or the pages the frames
  /// are reading, before they are used.
  std::uint64_t pageRoomBytes = 0;
};

/// What the prefetcher did so far.
struct PrefetchStats final {
  std::uint64_t predictions = 0;     ///< refinements of a predicted camera
  std::uint64_t rangesAdvised = 0;   ///< madvise(MADV_WILLNEED) calls
  std::uint64_t bytesAdvised = 0;    ///< bytes in those ranges
  std::uint64_t rangesResident = 0;  ///< ranges found already resident (no call)
  std::uint64_t rangesDeferred = 0;  ///< ranges left to a later prediction (pageRoomBytes)
};

/// Reads ahead of the camera: a worker thread extrapolates the observed cameras
/// (CameraPredictor), refines the predicted cuts and advises the kernel (MADV_WILLNEED) of their
/// patches' and tiles' pages not yet resident, so that the render thread's faults find them.
/// observe() and stats() may be called from any thread; the dataset must outlive it.
class Prefetcher final {
 public:
  /// Starts the worker over `dataset`.
  Prefetcher(const MappedDataset& dataset, const PrefetchOptions& options);
  ~Prefetcher();
  Prefetcher(const Prefetcher&) = delete;
  Prefetcher& operator=(const Prefetcher&) = delete;

  /// Hands the worker the camera of a frame (cheap: a copy under a lock and a notify).
  void observe(double timeSeconds, const runtime::Camera& camera);
  /// Stops the worker and waits for it (also done by the destructor).
  void stop();
  /// What it did so far.
  PrefetchStats stats() const;

 private:
  /// `camera` with the field of view widened by options_.fovMarginDegrees.
  runtime::Camera widened(const runtime::Camera& camera) const;
  void run();
  void prefetch(const runtime::Cut& cut);
  void adviseRange(int face, std::uint64_t offset, std::uint64_t bytes, ResidentKey key);

  const MappedDataset& dataset_;
  PrefetchOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<double, runtime::Camera>> pending_;
  bool stopping_ = false;
  // Worker-only state.
  CameraPredictor predictor_;
  std::unordered_map<std::uint64_t, std::uint64_t> advisedAt_;  ///< range key → cycle
  std::uint64_t cycle_ = 0;
  std::uint64_t cycleBytes_ = 0;  ///< bytes advised by the current prediction
  std::atomic<std::uint64_t> predictions_{0}, rangesAdvised_{0}, bytesAdvised_{0},
      rangesResident_{0}, rangesDeferred_{0};
  std::thread worker_;
};

}  // namespace pbdam::streaming
