// Read-only file mappings with madvise/mincore (MappedFile.h).
#include "pbdam/streaming/MappedFile.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cassert>
#include <cerrno>
#include <cstring>
#include <utility>
#include <vector>

namespace pbdam {

MappedFile::~MappedFile() { reset(); }

MappedFile::MappedFile(MappedFile&& other) noexcept
    : path_(std::move(other.path_)),
      data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)) {}

MappedFile& MappedFile::operator=(MappedFile&& other) noexcept {
  if (this != &other) {
    reset();
    path_ = std::move(other.path_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

void MappedFile::reset() noexcept {
  if (data_ != nullptr) {
    ::munmap(const_cast<std::byte*>(data_), size_);  // NOLINT: munmap takes void*
  }
  data_ = nullptr;
  size_ = 0;
}

std::size_t MappedFile::pageSize() noexcept {
  static const auto size = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  return size;
}

Result<MappedFile> MappedFile::open(const std::filesystem::path& path) {
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
  MappedFile file;
  file.path_ = path;
  file.size_ = static_cast<std::size_t>(st.st_size);
  if (file.size_ > 0) {
    void* p = ::mmap(nullptr, file.size_, PROT_READ, MAP_SHARED, fd, 0);
    if (p == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      file.size_ = 0;
      return makeError(ErrorCode::IoError,
                       path.string() + ": cannot map (" + std::strerror(err) + ")");
    }
    file.data_ = static_cast<const std::byte*>(p);
  }
  ::close(fd);  // the mapping keeps the file referenced
  return file;
}

Result<void> MappedFile::advise(MappingAdvice advice) const noexcept {
  if (size_ == 0) return {};
  const int flag = advice == MappingAdvice::Random       ? MADV_RANDOM
                   : advice == MappingAdvice::Sequential ? MADV_SEQUENTIAL
                                                         : MADV_NORMAL;
  if (::madvise(const_cast<std::byte*>(data_), size_, flag) != 0) {  // NOLINT
    return makeError(ErrorCode::IoError,
                     path_.string() + ": madvise failed (" + std::strerror(errno) + ")");
  }
  return {};
}

Result<void> MappedFile::releaseResident() const noexcept {
  if (size_ == 0) return {};
  if (::madvise(const_cast<std::byte*>(data_), size_, MADV_DONTNEED) != 0) {  // NOLINT
    return makeError(ErrorCode::IoError,
                     path_.string() + ": madvise(DONTNEED) failed (" + std::strerror(errno) + ")");
  }
  return {};
}

Result<void> MappedFile::willNeed(std::size_t offset, std::size_t length) const noexcept {
  assert(offset <= size_ && length <= size_ - offset);
  if (length == 0) return {};
  const std::size_t page = pageSize();
  const std::size_t begin = offset / page * page;
  const std::size_t end = offset + length;
  if (::madvise(const_cast<std::byte*>(data_) + begin, end - begin, MADV_WILLNEED) !=
      0) {  // NOLINT
    return makeError(ErrorCode::IoError, path_.string() + ": madvise(WILLNEED) at offset " +
                                             std::to_string(offset) + " failed (" +
                                             std::strerror(errno) + ")");
  }
  return {};
}

Result<std::size_t> MappedFile::residentPages() const noexcept {
  auto r = residentPages(0, size_);
  if (!r) return std::move(r).error();
  return r->first;
}

Result<std::pair<std::size_t, std::size_t>> MappedFile::residentPages(
    std::size_t offset, std::size_t length) const noexcept {
  assert(offset <= size_ && length <= size_ - offset);
  if (length == 0) return std::pair<std::size_t, std::size_t>{0, 0};
  const std::size_t page = pageSize();
  const std::size_t begin = offset / page * page;
  const std::size_t end = offset + length;
  std::vector<unsigned char> vec((end - begin + page - 1) / page);
  if (::mincore(const_cast<std::byte*>(data_) + begin, end - begin,  // NOLINT
                vec.data()) != 0) {
    return makeError(ErrorCode::IoError,
                     path_.string() + ": mincore failed (" + std::strerror(errno) + ")");
  }
  std::size_t resident = 0;
  for (unsigned char v : vec) resident += (v & 1U);
  return std::pair<std::size_t, std::size_t>{resident, vec.size()};
}

}  // namespace pbdam
