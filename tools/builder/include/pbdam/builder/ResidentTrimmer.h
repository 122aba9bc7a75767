// ResidentTrimmer: a thread that drops this process's page-table entries of memory mappings
// every period, or only while the process holds more than a budget of file pages resident
// (docs/builder.md "Distributed build", "Out of core"), used by the builder and by verify.
// Thread-safety: the release function runs on the trimmer's thread; it must only call thread-safe
// releases (MemoryMapping::releaseResident and dropMappedPages are).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <stop_token>
#include <thread>

namespace pbdam::builder {

/// Bytes of file pages this process has resident: its mappings of files (the lattice, the
/// bucketed samples, the checkpoint's parts, a DEM's scratch file) and its executable's pages
/// (/proc/self/statm's shared pages). Nothing where that cannot be read.
std::optional<std::uint64_t> residentFileBytes() noexcept;

/// Whether mappings should be dropped now under a budget of `budgetBytes` resident file bytes:
/// always with a budget of 0 (every period, whatever is resident), and where the figure cannot
/// be read.
inline bool overResidentBudget(std::uint64_t budgetBytes) noexcept {
  if (budgetBytes == 0) return true;
  const std::optional<std::uint64_t> resident = residentFileBytes();
  return !resident || *resident > budgetBytes;
}

/// RSS bound: every `period` drops this process's page-table entries of the mappings `release`
/// names (heights, source samples, carry, checkpoint files being assembled). Their pages stay in
/// the page cache, so a later read is a minor fault; what a rank keeps resident is then what its
/// threads touched in the last period, not the data size. With a budget, a period drops them
/// only while more than `budgetBytes` of file pages are resident: each drop costs a page fault
/// on every page read again, which on a virtual machine with shadow page tables is tens of
/// microseconds, so dropping a working set that fits four times a second made a fifth of a
/// build's CPU time. Stops (and joins) on destruction.
class ResidentTrimmer final {
 public:
  ResidentTrimmer(std::chrono::milliseconds period, std::function<void()> release,
                  std::uint64_t budgetBytes = 0)
      : thread_(
            [this, period, budgetBytes, release = std::move(release)](const std::stop_token& stop) {
              std::unique_lock lock(mutex_);
              while (!stop.stop_requested()) {
                wake_.wait_for(lock, stop, period, [] { return false; });
                if (!stop.stop_requested() && overResidentBudget(budgetBytes)) release();
              }
            }) {}
  ResidentTrimmer(const ResidentTrimmer&) = delete;
  ResidentTrimmer& operator=(const ResidentTrimmer&) = delete;
  ~ResidentTrimmer() { thread_.request_stop(); }

 private:
  std::mutex mutex_;
  std::condition_variable_any wake_;
  std::jthread thread_;  // last: joined first, while mutex_ and wake_ still exist
};

}  // namespace pbdam::builder
