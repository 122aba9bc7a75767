// MappedFile: a read-only memory mapping of a whole file, owned (unmapped on destruction), with
// page-aligned madvise hints for prefetch. Face files are read only through mappings on the
// render path (docs/architecture.md "Streaming"). Thread-safety: const members may be called from
// any thread; the mapping lives until the owner is destroyed or moved from.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <utility>

#include "pbdam/formats/Result.h"

namespace pbdam {

/// The access pattern the kernel should assume for a mapping.
enum class MappingAdvice { Normal, Random, Sequential };

class MappedFile final {
 public:
  MappedFile() = default;
  ~MappedFile();
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&& other) noexcept;
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  /// Maps `path` read-only. An empty file gives an empty mapping. Errors name the file.
  static Result<MappedFile> open(const std::filesystem::path& path);

  /// The mapped bytes (empty for an empty or moved-from mapping).
  std::span<const std::byte> bytes() const noexcept { return {data_, size_}; }
  std::size_t size() const noexcept { return size_; }
  const std::filesystem::path& path() const noexcept { return path_; }

  /// Sets the whole mapping's access pattern (MADV_RANDOM makes fault accounting honest).
  Result<void> advise(MappingAdvice advice) const noexcept;

  /// Asks the kernel to start reading [offset, offset + length) (MADV_WILLNEED on the enclosing
  /// pages). Blocks ~50–80 µs: call it from a prefetch thread, never the render thread. The
  /// range must lie inside the mapping.
  Result<void> willNeed(std::size_t offset, std::size_t length) const noexcept;

  /// Drops the mapping's page-table entries (MADV_DONTNEED): the process's RSS no longer counts
  /// the file's pages; they stay in the page cache, so touching them again is a minor fault.
  Result<void> releaseResident() const noexcept;

  /// Number of the mapping's pages currently resident in the page cache (mincore).
  Result<std::size_t> residentPages() const noexcept;
  /// Number of pages of [offset, offset + length) resident, and the number of pages the range
  /// touches. The range must lie inside the mapping.
  Result<std::pair<std::size_t, std::size_t>> residentPages(std::size_t offset,
                                                            std::size_t length) const noexcept;

  /// The system page size in bytes.
  static std::size_t pageSize() noexcept;

 private:
  void reset() noexcept;
  std::filesystem::path path_;
  const std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace pbdam
