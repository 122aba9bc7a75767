// Page-cache control for cold-cache benchmarks (docs/architecture.md "Streaming", "Measured
// facts"): evicting a file with posix_fadvise(POSIX_FADV_DONTNEED) and counting its resident pages
// with mincore. Eviction only drops pages no process has mapped, so evict before mapping a dataset
// (or after unmapping it). Thread-safety: free functions, no shared state.
#pragma once

#include <cstddef>
#include <filesystem>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::streaming {

/// Resident and total pages of one or more files.
struct PageResidency final {
  std::size_t residentPages = 0;  ///< in the page cache (mincore)
  std::size_t totalPages = 0;     ///< of the files
  /// residentPages / totalPages (0 for no pages).
  double residentFraction() const noexcept {
    return totalPages == 0 ? 0.0
                           : static_cast<double>(residentPages) / static_cast<double>(totalPages);
  }
};

/// Flushes and drops `path`'s pages from the page cache. Errors name the file.
formats::Result<void> evictFromPageCache(const std::filesystem::path& path);

/// Counts `path`'s pages resident in the page cache (maps it briefly).
formats::Result<PageResidency> pageResidency(const std::filesystem::path& path);

/// The dataset's files: manifest.json and the six faces named by it.
formats::Result<std::vector<std::filesystem::path>> datasetFiles(
    const std::filesystem::path& directory);

/// Evicts every file of a dataset and returns the residency measured afterwards (the cold-cache
/// benchmark requires ≤ 1% and reports the figure).
formats::Result<PageResidency> evictDataset(const std::filesystem::path& directory);

}  // namespace pbdam::streaming
