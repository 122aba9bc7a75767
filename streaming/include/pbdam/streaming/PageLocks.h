// PageLocks: the process's one owner of mlock/munlock, so that page locks nest. mlock(2) locks do
// not: one munlock unlocks a page however many times it was locked, so a no-stall frame's hold
// that let go of its pages also unlocked the coarse levels the run-long hold had locked (they
// share pages). Here each page has a count of holds: it is mlocked when the count goes 0 → 1 and
// munlocked when it goes 1 → 0 (docs/decisions.md "No-stall pages held under a memory budget").
#pragma once

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <unordered_map>

namespace pbdam::streaming {

/// The count of holds on every locked page of the process. Ranges are widened to whole pages,
/// as mlock does. Every lock of the process's pages must go through it: an mlock or munlock made
/// elsewhere (or mlockall) breaks the counts — its munlock would unlock pages held here.
///
/// Thread-safety: every member may be called from any thread. One mutex covers the counts and
/// the mlock/munlock calls that follow from them, so the kernel's locks always match the counts
/// (a page going 1 → 0 on one thread cannot be munlocked after another thread's 0 → 1 mlocked it
/// again). mlock faults in a page that is not resident, and other threads' locks wait for that
/// read: callers lock pages they have just found resident (NoStallPolicy) or just read
/// (preloadCoarseLevels, before the first frame). Non-copyable; one instance per process.
/// Under ASan and TSan the runtime's mlock and munlock do nothing (and return 0): the counts
/// are kept all the same, but nothing is locked.
class PageLocks final {
 public:
  /// The process's registry (made on first use).
  static PageLocks& instance() noexcept;

  PageLocks(const PageLocks&) = delete;
  PageLocks& operator=(const PageLocks&) = delete;

  /// Adds a hold on every page overlapping [begin, begin + bytes), mlocking those that had none.
  /// False, with no hold taken and nothing left locked by this call, when mlock refused (errno
  /// ENOMEM or EPERM: RLIMIT_MEMLOCK, or memory that cannot be locked; EAGAIN). An empty range
  /// is held (true). The pages must stay mapped until the matching unlock.
  bool lock(const std::byte* begin, std::size_t bytes);

  /// Drops one hold on every page overlapping [begin, begin + bytes), munlocking those whose
  /// last hold this was. The range must be one that lock() returned true for (asserted).
  void unlock(const std::byte* begin, std::size_t bytes) noexcept;

  /// Pages with at least one hold.
  std::size_t lockedPages() const;

  /// The holds on the page containing `address` (0: not locked by this registry).
  std::uint32_t holds(const std::byte* address) const;

 private:
  PageLocks() = default;
  ~PageLocks() = default;

  mutable std::mutex mutex_;
  std::unordered_map<std::uintptr_t, std::uint32_t> holds_;  ///< page number → holds (≥ 1)
};

}  // namespace pbdam::streaming
