// A pass's pins and slots in the shared GPU cache, handed back on every path (CacheLease.h).
#include "CacheLease.h"

#include <algorithm>
#include <cassert>
#include <chrono>

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::gpu {

namespace {

using Clock = std::chrono::steady_clock;

double millisecondsBetween(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

}  // namespace

CacheLease::CacheLease(GpuCache::State& cache)
    : cache_(&cache), lock_(cache.mutex, std::defer_lock) {
  lock();
  ++cache_->leases;
}

void CacheLease::lock() {
  const Clock::time_point asked = Clock::now();
  lock_.lock();
  heldSince_ = Clock::now();
  cache_->lockWaitMs += millisecondsBetween(asked, heldSince_);
}

void CacheLease::unlock() {
  cache_->lockHeldMs += millisecondsBetween(heldSince_, Clock::now());
  lock_.unlock();
}

CacheLease::~CacheLease() {
  if (!lock_.owns_lock()) lock();
  ResidencyLru& l = *cache_->lru;
  for (const ResidentKey key : inserted_) {
    if (committed_) {
      l.unpin(key);
    } else {
      l.erase(key);
    }
  }
  for (const ResidentKey key : hits_) l.unpin(key);
  if (!inserted_.empty() || !hits_.empty()) cache_->unpinned.notify_all();
  cache_->lockHeldMs += millisecondsBetween(heldSince_, Clock::now());
}

Result<void> CacheLease::reserve(std::span<const ResidentKey> entries,
                                 std::vector<std::size_t>& misses,
                                 std::vector<std::uint32_t>& missSlots, LeaseCounters& counters,
                                 const std::function<bool()>& releaseOwnPins) {
  GpuCache::State& c = *cache_;
  ResidencyLru& l = *c.lru;
  std::uint64_t passEpoch = 0;
  for (;;) {
    // Hits first (touched and pinned), so that making room for the misses never evicts them.
    passEpoch = ++c.epoch;
    misses.clear();
    hits_.clear();
    std::uint64_t missBytes = 0;
    for (std::size_t i = 0; i < entries.size(); ++i) {
      const ResidentKey key = entries[i];
      if (l.find(key)) {
        l.touch(key, passEpoch);
        l.pin(key);
        hits_.push_back(key);
      } else {
        misses.push_back(i);
        missBytes += l.slotBytes(key.kind());
      }
    }
    // Every unpinned entry is of an earlier pass, hence evictable: the misses fit if the
    // unpinned bytes and the free bytes together cover them.
    if (missBytes <= l.budgetBytes() - l.pinnedBytes()) break;
    for (const ResidentKey key : hits_) l.unpin(key);
    hits_.clear();
    // The caller's own frames in flight first: nobody else would ever release those pins.
    if (releaseOwnPins && releaseOwnPins()) continue;
    if (l.pinnedBytes() == 0) {
      return makeError(ErrorCode::Internal, "GPU cache: a planned pass does not fit its budget");
    }
    // Other renderers' passes in flight pin the rest: wait for one of them to finish.
    ++c.waits;
    c.lockHeldMs += millisecondsBetween(heldSince_, Clock::now());
    c.unpinned.wait(lock_);
    heldSince_ = Clock::now();
  }
  counters.hits += hits_.size();

  missSlots.clear();
  std::vector<ResidentKey> evicted;
  for (const std::size_t i : misses) {
    const ResidentKey key = entries[i];
    evicted.clear();
    const std::optional<std::uint32_t> slot = l.insert(key, passEpoch, evicted);
    if (!slot) {
      return makeError(ErrorCode::Internal, "GPU cache: a planned pass does not fit its budget");
    }
    l.pin(key);
    inserted_.push_back(key);
    counters.evictions += evicted.size();
    missSlots.push_back(*slot);
  }
  counters.peakResidentBytes = std::max(counters.peakResidentBytes, l.residentBytes());
  return {};
}

std::vector<ResidentKey> CacheLease::keepPins() {
  assert(committed_);
  std::vector<ResidentKey> pins = std::move(hits_);
  pins.insert(pins.end(), inserted_.begin(), inserted_.end());
  hits_.clear();
  inserted_.clear();
  return pins;
}

}  // namespace pbdam::gpu
