// MemoryMapping: the one owner of pbdam's mmap regions — read-only file mappings (face files,
// checkpoints), writable file mappings whose disk space is reserved before the first write
// (builder scratch files) and unnamed scratch mappings (out-of-core DEM heights) — and the
// madvise/mincore page control they share. Thread-safety: const members may be called from any
// thread; the mapping lives until the owner is destroyed or moved from.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <utility>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The access pattern the kernel should assume for a mapping.
enum class MappingAdvice { Normal, Random, Sequential };

/// A file mapped into memory (mmap), unmapped when the owner goes: read-only for a dataset's
/// files, writable for the builder's outputs and scratch grids. Move-only; a moved-from mapping
/// is empty. Reads that must survive a truncated file or a failing disk go through read() and
/// touch() (guarded copies). Thread-safety: const members from any thread.
class MemoryMapping final {
 public:
  MemoryMapping() = default;
  ~MemoryMapping();
  /// Takes over `other`'s mapping, leaving it empty.
  /// @{
  MemoryMapping(MemoryMapping&& other) noexcept;
  MemoryMapping& operator=(MemoryMapping&& other) noexcept;
  /// @}
  MemoryMapping(const MemoryMapping&) = delete;
  MemoryMapping& operator=(const MemoryMapping&) = delete;

  /// Maps `path` read-only and shared. An empty file gives an empty mapping. Errors name the
  /// file.
  static Result<MemoryMapping> open(const std::filesystem::path& path);

  /// Creates (or truncates) `path` with `size` bytes reserved on its filesystem
  /// (posix_fallocate) and maps it shared and writable. Reserving first makes a full disk an
  /// error here, naming the file, instead of a SIGBUS at the first write to an unbacked page.
  /// `size` must be positive.
  static Result<MemoryMapping> create(const std::filesystem::path& path, std::size_t size);

  /// Like create, for an unnamed file in `directory` (O_TMPFILE, else a named one unlinked at
  /// once): its space goes back to the filesystem when the mapping is destroyed. `size` must be
  /// positive.
  static Result<MemoryMapping> createScratch(const std::filesystem::path& directory,
                                             std::size_t size);

  /// The mapped bytes (empty for an empty or moved-from mapping). Reading them directly can
  /// fault (SIGBUS) when the file is truncated or its disk fails: code that must survive that
  /// reads through read(), touch() or formats/GuardedCopy.h instead.
  std::span<const std::byte> bytes() const noexcept { return {data_, size_}; }

  /// Copies bytes [offset, offset + out.size()) into `out` through a guarded copy
  /// (GuardedCopy.h). CorruptData naming the file and offset when the range lies outside the
  /// mapping or a page of it cannot be read (truncated file, failing disk).
  Result<void> read(std::uint64_t offset, std::span<std::byte> out) const;
  /// Reads every page of [offset, offset + length) through guarded copies (bringing them into
  /// the page cache) and discards the bytes. Errors as read().
  Result<void> touch(std::uint64_t offset, std::uint64_t length) const;
  /// The mapped bytes for writing; empty unless the mapping is writable.
  std::span<std::byte> writableBytes() const noexcept {
    return writable_ ? std::span<std::byte>(data_, size_) : std::span<std::byte>();
  }
  /// Bytes mapped.
  std::size_t size() const noexcept { return size_; }
  /// Whether the mapping is writable (create, createScratch).
  bool writable() const noexcept { return writable_; }
  /// The mapped file's path (the directory for a scratch mapping).
  const std::filesystem::path& path() const noexcept { return path_; }
  /// The mapped file's device and inode numbers (st_dev, st_ino) when it was opened: whether
  /// the path still names the mapped file or one put in its place since. Zero for writable and
  /// scratch mappings.
  std::pair<std::uint64_t, std::uint64_t> fileIdentity() const noexcept {
    return {device_, inode_};
  }

  /// Sets the whole mapping's access pattern (MADV_RANDOM makes fault accounting honest).
  Result<void> advise(MappingAdvice advice) const noexcept;

  /// Asks the kernel to start reading [offset, offset + length) (MADV_WILLNEED on the enclosing
  /// pages). Blocks ~50–80 µs: call it from a prefetch thread, never the render thread. The
  /// range must lie inside the mapping.
  Result<void> willNeed(std::size_t offset, std::size_t length) const noexcept;

  /// Drops the mapping's page-table entries (MADV_DONTNEED): the process's RSS no longer counts
  /// the file's pages; they stay in the page cache (written pages dirty, to be written back),
  /// so touching them again is a minor fault.
  Result<void> releaseResident() const noexcept;
  /// The same for the pages overlapping [offset, offset + length), which must lie inside the
  /// mapping.
  Result<void> releaseResident(std::size_t offset, std::size_t length) const noexcept;

  /// Number of the mapping's pages currently resident in the page cache (mincore).
  Result<std::size_t> residentPages() const noexcept;
  /// Number of pages of [offset, offset + length) resident, and the number of pages the range
  /// touches. The range must lie inside the mapping.
  Result<std::pair<std::size_t, std::size_t>> residentPages(std::size_t offset,
                                                            std::size_t length) const noexcept;

  /// Writes the mapping's dirty pages to the file and waits for them (msync MS_SYNC).
  Result<void> sync() const noexcept;
  /// Makes a writable mapping read-only from here on (mprotect): a stray write faults.
  Result<void> protectReadOnly() noexcept;

  /// The system page size in bytes.
  static std::size_t pageSize() noexcept;

 private:
  static Result<MemoryMapping> mapWritable(int fd, std::size_t size,
                                           const std::filesystem::path& path);
  void reset() noexcept;
  std::filesystem::path path_;
  std::byte* data_ = nullptr;
  std::size_t size_ = 0;
  bool writable_ = false;
  std::uint64_t device_ = 0;
  std::uint64_t inode_ = 0;
  int reportSlot_ = -1;  ///< registerMappedRange's slot (GuardedCopy.h)
};

/// Drops this process's page-table entries of the pages overlapping [data, data + bytes) of a
/// MAP_SHARED file mapping (madvise MADV_DONTNEED), for holders of a pointer into a mapping
/// rather than its owner (HeightGrid's out-of-core heights). The pages stay in the page cache,
/// so a later read is a minor fault. Must not be called on anonymous or private memory (it
/// would be zeroed). Safe to call from any thread.
void dropMappedPages(const void* data, std::size_t bytes) noexcept;

/// Whether every page overlapping `bytes` (inside any mapping, file-backed or not) is resident
/// (mincore): reading them needs no disk read. False when mincore fails.
bool pagesResident(std::span<const std::byte> bytes) noexcept;

}  // namespace pbdam::formats
