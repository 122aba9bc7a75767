// The owner of mmap regions and their madvise/mincore page control (MemoryMapping.h).
#include "pbdam/formats/MemoryMapping.h"

#include "pbdam/formats/GuardedCopy.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/formats/FileWrite.h"

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

Error ioFailure(const fs::path& path, const std::string& what, int err) {
  return makeError(ErrorCode::IoError,
                   path.string() + ": " + what + " (" + std::strerror(err) + ")");
}

/// The page-aligned start of the pages overlapping [offset, ...) of a mapping at `data`.
std::byte* pageStart(std::byte* data, std::size_t offset) noexcept {
  const std::size_t page = MemoryMapping::pageSize();
  return data + offset / page * page;
}

}  // namespace

MemoryMapping::~MemoryMapping() { reset(); }

MemoryMapping::MemoryMapping(MemoryMapping&& other) noexcept
    : path_(std::move(other.path_)),
      data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      writable_(std::exchange(other.writable_, false)),
      device_(std::exchange(other.device_, 0)),
      inode_(std::exchange(other.inode_, 0)),
      reportSlot_(std::exchange(other.reportSlot_, -1)) {}

MemoryMapping& MemoryMapping::operator=(MemoryMapping&& other) noexcept {
  if (this != &other) {
    reset();
    path_ = std::move(other.path_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    writable_ = std::exchange(other.writable_, false);
    device_ = std::exchange(other.device_, 0);
    inode_ = std::exchange(other.inode_, 0);
    reportSlot_ = std::exchange(other.reportSlot_, -1);
  }
  return *this;
}

void MemoryMapping::reset() noexcept {
  unregisterMappedRange(std::exchange(reportSlot_, -1));
  if (data_ != nullptr) ::munmap(data_, size_);
  data_ = nullptr;
  size_ = 0;
  writable_ = false;
}

std::size_t MemoryMapping::pageSize() noexcept {
  static const auto size = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  return size;
}

Result<MemoryMapping> MemoryMapping::open(const fs::path& path) {
  installMappedReadGuard();  // before any byte of a mapping can be read
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    return makeError(err == ENOENT ? ErrorCode::NotFound : ErrorCode::IoError,
                     path.string() + ": cannot open (" + std::strerror(err) + ")");
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return makeError(ErrorCode::IoError, path.string() + ": not a regular file");
  }
  MemoryMapping mapping;
  mapping.path_ = path;
  mapping.device_ = static_cast<std::uint64_t>(st.st_dev);
  mapping.inode_ = static_cast<std::uint64_t>(st.st_ino);
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > 0) {
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      return ioFailure(path, "cannot map", err);
    }
    mapping.data_ = static_cast<std::byte*>(p);
    mapping.size_ = size;
    mapping.reportSlot_ = registerMappedRange(mapping.data_, size, path.string());
  }
  ::close(fd);  // the mapping keeps the file referenced
  return mapping;
}

Result<MemoryMapping> MemoryMapping::mapWritable(int fd, std::size_t size, const fs::path& path) {
  assert(size > 0);
  if (auto reserved = reserveFileSpace(fd, 0, size, path); !reserved) {
    ::close(fd);
    return std::move(reserved).error();
  }
  void* p = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  const int mapErr = errno;
  if (::close(fd) != 0 && p != MAP_FAILED) {
    const int err = errno;
    ::munmap(p, size);
    return ioFailure(path, "close failed", err);
  }
  if (p == MAP_FAILED) return ioFailure(path, "cannot map for writing", mapErr);
  MemoryMapping mapping;
  mapping.path_ = path;
  mapping.data_ = static_cast<std::byte*>(p);
  mapping.size_ = size;
  mapping.writable_ = true;
  mapping.reportSlot_ = registerMappedRange(mapping.data_, size, path.string());
  return mapping;
}

Result<MemoryMapping> MemoryMapping::create(const fs::path& path, std::size_t size) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return ioFailure(path, "cannot create", errno);
  return mapWritable(fd, size, path);
}

Result<MemoryMapping> MemoryMapping::createScratch(const fs::path& directory, std::size_t size) {
  int fd = ::open(directory.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd < 0) {
    // Filesystems without unnamed files: a named one, unlinked at once.
    std::string name = (directory / ".pbdam-scratch-XXXXXX").string();
    fd = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd < 0) return ioFailure(directory, "cannot create a scratch file", errno);
    ::unlink(name.c_str());
  }
  return mapWritable(fd, size, directory);
}

Result<void> MemoryMapping::read(std::uint64_t offset, std::span<std::byte> out) const {
  return readMapped(bytes(), offset, out, path_.string());
}

Result<void> MemoryMapping::touch(std::uint64_t offset, std::uint64_t length) const {
  // One byte of every page is enough to fault it in; the range's last byte ends it.
  const std::uint64_t page = pageSize();
  std::byte sink{};
  for (std::uint64_t at = offset; at < offset + length; at = (at / page + 1) * page) {
    if (auto r = read(at, std::span(&sink, 1)); !r) return r;
  }
  return {};
}

Result<void> MemoryMapping::advise(MappingAdvice advice) const noexcept {
  if (size_ == 0) return {};
  const int flag = advice == MappingAdvice::Random       ? MADV_RANDOM
                   : advice == MappingAdvice::Sequential ? MADV_SEQUENTIAL
                                                         : MADV_NORMAL;
  if (::madvise(data_, size_, flag) != 0) return ioFailure(path_, "madvise failed", errno);
  return {};
}

Result<void> MemoryMapping::releaseResident() const noexcept { return releaseResident(0, size_); }

Result<void> MemoryMapping::releaseResident(std::size_t offset, std::size_t length) const noexcept {
  assert(offset <= size_ && length <= size_ - offset);
  if (length == 0) return {};
  std::byte* begin = pageStart(data_, offset);
  if (::madvise(begin, static_cast<std::size_t>(data_ + offset + length - begin), MADV_DONTNEED) !=
      0) {
    return ioFailure(path_, "madvise(DONTNEED) failed", errno);
  }
  return {};
}

Result<void> MemoryMapping::willNeed(std::size_t offset, std::size_t length) const noexcept {
  assert(offset <= size_ && length <= size_ - offset);
  if (length == 0) return {};
  std::byte* begin = pageStart(data_, offset);
  if (::madvise(begin, static_cast<std::size_t>(data_ + offset + length - begin), MADV_WILLNEED) !=
      0) {
    return ioFailure(path_, "madvise(WILLNEED) at offset " + std::to_string(offset) + " failed",
                     errno);
  }
  return {};
}

Result<std::size_t> MemoryMapping::residentPages() const noexcept {
  auto r = residentPages(0, size_);
  if (!r) return std::move(r).error();
  return r->first;
}

Result<std::pair<std::size_t, std::size_t>> MemoryMapping::residentPages(
    std::size_t offset, std::size_t length) const noexcept {
  assert(offset <= size_ && length <= size_ - offset);
  if (length == 0) return std::pair<std::size_t, std::size_t>{0, 0};
  const std::size_t page = pageSize();
  std::byte* begin = pageStart(data_, offset);
  const auto bytes = static_cast<std::size_t>(data_ + offset + length - begin);
  std::vector<unsigned char> vec((bytes + page - 1) / page);
  if (::mincore(begin, bytes, vec.data()) != 0) return ioFailure(path_, "mincore failed", errno);
  std::size_t resident = 0;
  for (unsigned char v : vec) resident += (v & 1U);
  return std::pair<std::size_t, std::size_t>{resident, vec.size()};
}

Result<void> MemoryMapping::sync() const noexcept {
  if (size_ == 0 || !writable_) return {};
  if (::msync(data_, size_, MS_SYNC) != 0) return ioFailure(path_, "msync failed", errno);
  return {};
}

Result<void> MemoryMapping::protectReadOnly() noexcept {
  if (size_ == 0 || !writable_) return {};
  if (::mprotect(data_, size_, PROT_READ) != 0) return ioFailure(path_, "mprotect failed", errno);
  writable_ = false;
  return {};
}

void dropMappedPages(const void* data, std::size_t bytes) noexcept {
  if (bytes == 0) return;
  const auto page = static_cast<std::uintptr_t>(MemoryMapping::pageSize());
  const auto first = reinterpret_cast<std::uintptr_t>(data) / page * page;
  const auto last = reinterpret_cast<std::uintptr_t>(data) + bytes;
  // NOLINTNEXTLINE(performance-no-int-to-ptr): the mapping's own pages
  (void)::madvise(reinterpret_cast<void*>(first), last - first, MADV_DONTNEED);
}

bool pagesResident(std::span<const std::byte> bytes) noexcept {
  if (bytes.empty()) return true;
  const std::size_t page = MemoryMapping::pageSize();
  const auto address = reinterpret_cast<std::uintptr_t>(bytes.data());  // NOLINT: page arithmetic
  const std::uintptr_t first = address / page * page;
  const std::size_t length = address + bytes.size() - first;
  std::array<unsigned char, 64> small{};
  std::vector<unsigned char> large;
  const std::size_t pages = (length + page - 1) / page;
  unsigned char* vec = small.data();
  if (pages > small.size()) {
    large.resize(pages);
    vec = large.data();
  }
  // NOLINTNEXTLINE(performance-no-int-to-ptr): mincore takes the page's address
  void* start = reinterpret_cast<void*>(first);
  if (::mincore(start, length, vec) != 0) return false;
  return std::all_of(vec, vec + pages, [](unsigned char v) { return (v & 1U) != 0; });
}

}  // namespace pbdam::formats
