// ResidentTrimmer: a thread that drops this process's page-table entries of memory mappings
// every period (docs/builder.md "Distributed build", "Out of core"), used by the builder and by
// verify. Thread-safety: the release function runs on the trimmer's thread; it must only call
// thread-safe releases (MemoryMapping::releaseResident and dropMappedPages are).
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <stop_token>
#include <thread>

namespace pbdam::builder {

/// RSS bound: every `period` drops this process's page-table entries of the mappings `release`
/// names (heights, source samples, carry, checkpoint files being assembled). Their pages stay in
/// the page cache, so a later read is a minor fault; what a rank keeps resident is then what its
/// threads touched in the last period, not the data size. Stops (and joins) on destruction.
class ResidentTrimmer final {
 public:
  ResidentTrimmer(std::chrono::milliseconds period, std::function<void()> release)
      : thread_([this, period, release = std::move(release)](const std::stop_token& stop) {
          std::unique_lock lock(mutex_);
          while (!stop.stop_requested()) {
            wake_.wait_for(lock, stop, period, [] { return false; });
            if (!stop.stop_requested()) release();
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
