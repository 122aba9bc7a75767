// CacheLease (internal to pbdam_gpu): one pass's reservation in a GpuCache (GpuCache.h;
// docs/architecture.md "Streaming") as an RAII lease. It takes the cache lock, pins the pass's
// resident entries (hits), gives its misses slots (evicting least-recently-used entries of earlier
// passes, waiting while other renderers' passes pin the budget) and pins them too. Whatever path
// leaves the pass, the destructor hands everything back under the lock: pins are released, and
// misses whose uploads were not committed (an error before their submission completed) are erased,
// so nothing half-uploaded stays resident. Thread-safety: one thread; the cache's lock guards the
// state.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <vector>

#include "GpuCacheState.h"
#include "pbdam/formats/Result.h"
#include "pbdam/streaming/ResidencyLru.h"

namespace pbdam::gpu {

/// What a reservation counted, for FrameStats.
struct LeaseCounters final {
  std::uint64_t hits = 0;
  std::uint64_t evictions = 0;
  std::uint64_t peakResidentBytes = 0;
};

class CacheLease final {
 public:
  /// Takes `cache`'s lock (held until unlock() or destruction).
  explicit CacheLease(GpuCache::State& cache);
  ~CacheLease();
  CacheLease(const CacheLease&) = delete;
  CacheLease& operator=(const CacheLease&) = delete;

  /// Reserves `entries` (distinct keys) for this pass: hits are touched and pinned, misses are
  /// inserted and pinned; `misses` receives the indices in `entries` of the missing keys, in
  /// order, and `missSlots` their slots. Call once per lease. When the misses do not fit beside
  /// what is pinned, `releaseOwnPins` (when set) is called first, with the lock held: it waits
  /// for one of the caller's own frames in flight and unpins its entries, returning false when
  /// the caller has none left; only then does the lease wait for other renderers' passes.
  /// Errors: Internal when the pass cannot fit the budget even with every other pass finished
  /// (the frame planner makes passes that fit).
  formats::Result<void> reserve(std::span<const streaming::ResidentKey> entries,
                                std::vector<std::size_t>& misses,
                                std::vector<std::uint32_t>& missSlots, LeaseCounters& counters,
                                const std::function<bool()>& releaseOwnPins = {});

  /// The misses' uploads have completed (or, with a private cache, are submitted ahead of
  /// every later use): they stay resident when the lease ends.
  void commitUploads() noexcept { committed_ = true; }

  /// Hands the pass's pins (hits and committed misses) to the caller, who unpins each key once
  /// the submission that draws them has completed (a frame in flight); the lease then releases
  /// nothing. Call after commitUploads().
  std::vector<streaming::ResidentKey> keepPins();

  /// Lets other renderers use the cache while this pass draws (its entries stay pinned).
  void unlock();
  /// Takes the lock again after unlock().
  void lock();

  /// The cache's bookkeeping; the lock must be held.
  streaming::ResidencyLru& lru() noexcept { return *cache_->lru; }

 private:
  GpuCache::State* cache_;
  std::unique_lock<std::mutex> lock_;
  /// When the lock was last taken (for GpuCache::State::lockHeldMs).
  std::chrono::steady_clock::time_point heldSince_;
  std::vector<streaming::ResidentKey> hits_;
  std::vector<streaming::ResidentKey> inserted_;
  bool committed_ = false;
};

}  // namespace pbdam::gpu
