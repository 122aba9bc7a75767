// Full-disk-safe writing (FileWrite.h).
#include "pbdam/formats/FileWrite.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

// Set once by failWritesForTesting before any writer runs; read concurrently afterwards.
std::string& injectedPathPart() {
  static std::string part;
  return part;
}

/// ENOSPC when `path` matches the injected failure, else 0.
int injectedErrno(const fs::path& path) {
  const std::string& part = injectedPathPart();
  if (part.empty()) return 0;
  return path.string().find(part) != std::string::npos ? ENOSPC : 0;
}

}  // namespace

bool isNoSpaceErrno(int err) noexcept { return err == ENOSPC || err == EDQUOT || err == EFBIG; }

Error writeFailure(const fs::path& path, std::uint64_t bytes, int err, const char* what) {
  const std::string amount = std::to_string(bytes) + " bytes (" + std::strerror(err) + ")";
  if (isNoSpaceErrno(err)) {
    return makeError(ErrorCode::NoSpace, path.string() + ": no space to " + what + " " + amount);
  }
  return makeError(ErrorCode::IoError, path.string() + ": cannot " + what + " " + amount);
}

Result<void> writeFully(int fd, std::span<const std::byte> bytes, const fs::path& path) {
  if (const int err = injectedErrno(path); err != 0 && !bytes.empty()) {
    return writeFailure(path, bytes.size(), err);
  }
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return writeFailure(path, bytes.size() - done, n < 0 ? errno : ENOSPC);
    done += static_cast<std::size_t>(n);
  }
  return {};
}

Result<void> pwriteFully(int fd, std::span<const std::byte> bytes, std::uint64_t offset,
                         const fs::path& path) {
  if (const int err = injectedErrno(path); err != 0 && !bytes.empty()) {
    return writeFailure(path, bytes.size(), err);
  }
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n =
        ::pwrite(fd, bytes.data() + done, bytes.size() - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return writeFailure(path, bytes.size() - done, n < 0 ? errno : ENOSPC);
    done += static_cast<std::size_t>(n);
  }
  return {};
}

Result<void> reserveFileSpace(int fd, std::uint64_t offset, std::uint64_t bytes,
                              const fs::path& path) {
  if (bytes == 0) return {};
  if (const int err = injectedErrno(path); err != 0)
    return writeFailure(path, bytes, err, "reserve");
  // posix_fallocate returns the error instead of setting errno; past RLIMIT_FSIZE it is EFBIG
  // (with SIGXFSZ, which the CLI ignores so that the error is what reports it).
  int err = 0;
  do {
    err = ::posix_fallocate(fd, static_cast<off_t>(offset), static_cast<off_t>(bytes));
  } while (err == EINTR);
  if (err != 0) return writeFailure(path, bytes, err, "reserve");
  return {};
}

Result<void> syncFile(int fd, std::uint64_t bytes, const fs::path& path) {
  if (const int err = injectedErrno(path); err != 0) return writeFailure(path, bytes, err);
  if (::fsync(fd) != 0) return writeFailure(path, bytes, errno);
  return {};
}

void failWritesForTesting(std::string pathPart) { injectedPathPart() = std::move(pathPart); }

Result<std::uint64_t> freeFileRanges(
    const fs::path& path, std::span<const std::pair<std::uint64_t, std::uint64_t>> ranges) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    return makeError(ErrorCode::IoError, path.string() + ": cannot open to free its pages (" +
                                             std::strerror(errno) + ")");
  }
  const auto page = static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
  std::uint64_t freed = 0;
  for (const auto& [first, end] : ranges) {
    const std::uint64_t from = (first + page - 1) / page * page;
    const std::uint64_t to = end / page * page;
    if (to <= from) continue;
    if (::fallocate(fd, FALLOC_FL_PUNCH_HOLE | FALLOC_FL_KEEP_SIZE, static_cast<off_t>(from),
                    static_cast<off_t>(to - from)) != 0) {
      const int err = errno;
      ::close(fd);
      return makeError(ErrorCode::IoError, path.string() + ": cannot free bytes " +
                                               std::to_string(from) + ".." + std::to_string(to) +
                                               " (" + std::strerror(err) + ")");
    }
    freed += to - from;
  }
  ::close(fd);
  return freed;
}

}  // namespace pbdam::formats
