// Writing files so that a full disk or the file-size limit (RLIMIT_FSIZE, `ulimit -f`) is an
// error that names the file and the bytes it needed — never a SIGBUS in a mapping, a SIGXFSZ
// or a short file taken for a complete one. Every writer of the builder goes through these:
// space for a file written through a mapping, or whose size is known, is reserved first
// (posix_fallocate); streamed bytes are written in full or the write fails with the reason.
// Thread-safety: the functions are thread-safe; failWritesForTesting must be called before any
// thread writes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <utility>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// True for the errno values that mean "no room": ENOSPC (the filesystem is full), EDQUOT (the
/// user's quota) and EFBIG (the file-size limit, or the filesystem's largest file).
bool isNoSpaceErrno(int err) noexcept;

/// The error of a write or reservation of `bytes` bytes to `path` that failed with `err`:
/// ErrorCode::NoSpace where isNoSpaceErrno(err) ("PATH: no space to write 1048576 bytes (No
/// space left on device)"), else ErrorCode::IoError. `what` is "write" or "reserve".
Error writeFailure(const std::filesystem::path& path, std::uint64_t bytes, int err,
                   const char* what = "write");

/// Writes all of `bytes` to `fd` at its file offset (retrying short writes and EINTR).
/// `path` names the file in errors.
Result<void> writeFully(int fd, std::span<const std::byte> bytes,
                        const std::filesystem::path& path);
/// Writes all of `bytes` to `fd` at `offset` (pwrite).
Result<void> pwriteFully(int fd, std::span<const std::byte> bytes, std::uint64_t offset,
                         const std::filesystem::path& path);
/// Reserves the blocks of [offset, offset + bytes) of `fd` (posix_fallocate), so that later
/// writes there, and stores through a shared mapping of them, cannot fail for lack of space.
Result<void> reserveFileSpace(int fd, std::uint64_t offset, std::uint64_t bytes,
                              const std::filesystem::path& path);
/// Makes fsync of `fd` report a full disk (delayed allocation) as writeFailure does.
Result<void> syncFile(int fd, std::uint64_t bytes, const std::filesystem::path& path);

/// Gives the disk blocks of every whole page inside the byte ranges [first, second) of the file
/// at `path` back to the filesystem (FALLOC_FL_PUNCH_HOLE; the file keeps its size and those
/// pages then read as zeros). Returns the bytes of the pages freed. Errors: IoError naming the
/// file and the reason (a filesystem without hole punching: EOPNOTSUPP).
Result<std::uint64_t> freeFileRanges(
    const std::filesystem::path& path,
    std::span<const std::pair<std::uint64_t, std::uint64_t>> ranges);

/// Test aid (PBDAM_TEST_FAIL_WRITE): from now on, every write, pwrite, reservation and fsync
/// above to a path whose string contains `pathPart` fails with ENOSPC, as on a full disk.
/// Empty: no injected failures (the default).
void failWritesForTesting(std::string pathPart);

}  // namespace pbdam::formats
