// Counted page locks (PageLocks.h): mlock on a page's first hold, munlock on its last.
#include "pbdam/streaming/PageLocks.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cassert>
#include <cerrno>
#include <utility>
#include <vector>

namespace pbdam::streaming {
namespace {

std::uintptr_t pageBytes() noexcept {
  static const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
  return page;
}

/// The page numbers [first, end) that [begin, begin + bytes) overlaps; bytes > 0.
std::pair<std::uintptr_t, std::uintptr_t> pagesOf(const std::byte* begin,
                                                  std::size_t bytes) noexcept {
  const auto at = reinterpret_cast<std::uintptr_t>(begin);
  const std::uintptr_t page = pageBytes();
  return {at / page, (at + bytes - 1) / page + 1};
}

/// Runs of consecutive page numbers [first, end), in order.
using PageRuns = std::vector<std::pair<std::uintptr_t, std::uintptr_t>>;

void addToRuns(PageRuns& runs, std::uintptr_t pageNumber) {
  if (!runs.empty() && runs.back().second == pageNumber) {
    ++runs.back().second;
  } else {
    runs.emplace_back(pageNumber, pageNumber + 1);
  }
}

void* addressOf(std::uintptr_t pageNumber) noexcept {
  return reinterpret_cast<void*>(pageNumber * pageBytes());  // NOLINT(performance-no-int-to-ptr)
}

std::size_t bytesOf(const std::pair<std::uintptr_t, std::uintptr_t>& run) noexcept {
  return (run.second - run.first) * pageBytes();
}

}  // namespace

PageLocks& PageLocks::instance() noexcept {
  static PageLocks locks;
  return locks;
}

bool PageLocks::lock(const std::byte* begin, std::size_t bytes) {
  if (bytes == 0) return true;
  const auto [first, end] = pagesOf(begin, bytes);
  const std::lock_guard guard(mutex_);
  // Room for the counts first: after the mlocks below nothing may fail. (Only ever grown:
  // reserve() below the bucket count would shrink the table, a rehash on every call.)
  const std::size_t needed = holds_.size() + (end - first);
  if (static_cast<double>(needed) >
      static_cast<double>(holds_.max_load_factor()) * static_cast<double>(holds_.bucket_count())) {
    holds_.reserve(needed);
  }
  // The pages no one holds yet are locked run by run; the counts change only once every run is
  // locked, so a refusal leaves the counts and the kernel's locks as they were. The refused run
  // is unlocked too: mlock may have locked part of it before failing, and no one holds it.
  PageRuns unheld;
  for (std::uintptr_t p = first; p < end; ++p) {
    if (holds_.find(p) == holds_.end()) addToRuns(unheld, p);
  }
  for (std::size_t r = 0; r < unheld.size(); ++r) {
    if (::mlock(addressOf(unheld[r].first), bytesOf(unheld[r])) != 0) {
      const int refused = errno;
      for (std::size_t k = 0; k <= r; ++k) {
        ::munlock(addressOf(unheld[k].first), bytesOf(unheld[k]));
      }
      errno = refused;
      return false;
    }
  }
  for (std::uintptr_t p = first; p < end; ++p) ++holds_[p];
  return true;
}

void PageLocks::unlock(const std::byte* begin, std::size_t bytes) noexcept {
  if (bytes == 0) return;
  const auto [first, end] = pagesOf(begin, bytes);
  const std::lock_guard guard(mutex_);
  // Pages whose last hold this was are munlocked in runs of consecutive pages (no allocation).
  std::uintptr_t runFirst = 0;
  std::uintptr_t runEnd = 0;
  const auto flush = [&runFirst, &runEnd] {
    if (runEnd > runFirst) ::munlock(addressOf(runFirst), (runEnd - runFirst) * pageBytes());
    runFirst = runEnd = 0;
  };
  for (std::uintptr_t p = first; p < end; ++p) {
    const auto it = holds_.find(p);
    assert(it != holds_.end() && "unlock of a page this registry does not hold");
    if (it == holds_.end() || --it->second != 0) {
      flush();
      continue;
    }
    holds_.erase(it);
    if (runEnd != p) {
      flush();
      runFirst = p;
    }
    runEnd = p + 1;
  }
  flush();
}

std::size_t PageLocks::lockedPages() const {
  const std::lock_guard guard(mutex_);
  return holds_.size();
}

std::uint32_t PageLocks::holds(const std::byte* address) const {
  const std::lock_guard guard(mutex_);
  const auto it = holds_.find(reinterpret_cast<std::uintptr_t>(address) / pageBytes());
  return it == holds_.end() ? 0 : it->second;
}

}  // namespace pbdam::streaming
