// Dropping a shared file mapping's pages from the process (RSS), for the formats that map large
// scratch data (HeightGrid's out-of-core heights). Thread-safety: safe to call from any thread.
#pragma once

#include <cstddef>

namespace pbdam {

/// Drops this process's page-table entries of the pages overlapping [data, data + bytes) of a
/// MAP_SHARED file mapping (madvise MADV_DONTNEED): the pages stay in the page cache, so a
/// later read is a minor fault. Must not be called on anonymous or private memory (it would
/// be zeroed).
void dropMappedPages(const void* data, std::size_t bytes) noexcept;

}  // namespace pbdam
