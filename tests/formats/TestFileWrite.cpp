// Full-disk-safe writing: a write past the file-size limit (RLIMIT_FSIZE, in a child process so
// that the limit and the ignored SIGXFSZ stay there) and an injected ENOSPC are NoSpace errors
// naming the file and the bytes; a reservation past the limit fails before anything is written.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <csignal>
#include <string>
#include <vector>

#include "TestData.h"
#include "pbdam/formats/FileWrite.h"

namespace pbdam::formats {
namespace {

/// Runs `body` in a forked child under a file-size limit of `limitBytes` with SIGXFSZ ignored;
/// the child's exit code is what `body` returns (0 when its expectations held).
int underFileSizeLimit(rlim_t limitBytes, int (*body)(const char*), const char* path) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const rlimit limit{limitBytes, limitBytes};
    std::signal(SIGXFSZ, SIG_IGN);
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(90);
    ::_exit(body(path));
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 100 + WTERMSIG(status);
}

int writePastTheLimit(const char* path) {
  const int fd = ::open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return 91;
  const std::vector<std::byte> bytes(std::size_t{3} * 4096, std::byte{7});
  const auto r = writeFully(fd, bytes, path);
  ::close(fd);
  if (r) return 92;
  if (r.error().code != ErrorCode::NoSpace) return 93;
  // The first 4096 bytes fit: the rest is what it needed.
  if (r.error().message.find(std::string(path) + ": no space to write 8192 bytes") ==
      std::string::npos) {
    return 94;
  }
  return 0;
}

int reservePastTheLimit(const char* path) {
  const int fd = ::open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return 91;
  const auto r = reserveFileSpace(fd, 0, 65536, path);
  ::close(fd);
  if (r) return 92;
  if (r.error().code != ErrorCode::NoSpace) return 93;
  if (r.error().message.find("no space to reserve 65536 bytes") == std::string::npos) return 94;
  return 0;
}

TEST(FileWrite, AWritePastTheFileSizeLimitIsNoSpaceNamingFileAndBytes) {
  test::TempDir dir;
  const std::string path = (dir / "limited.bin").string();
  EXPECT_EQ(underFileSizeLimit(4096, writePastTheLimit, path.c_str()), 0);
  EXPECT_EQ(std::filesystem::file_size(path), 4096u);
}

TEST(FileWrite, AReservationPastTheFileSizeLimitFailsBeforeWriting) {
  test::TempDir dir;
  const std::string path = (dir / "reserved.bin").string();
  EXPECT_EQ(underFileSizeLimit(4096, reservePastTheLimit, path.c_str()), 0);
  EXPECT_EQ(std::filesystem::file_size(path), 0u);
}

TEST(FileWrite, AnInjectedFailureHitsOnlyMatchingPaths) {
  test::TempDir dir;
  failWritesForTesting("face3");
  const std::vector<std::byte> bytes(100, std::byte{1});
  for (const char* name : {"face3.pbdam", "face2.pbdam"}) {
    const auto path = dir / name;
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    ASSERT_GE(fd, 0);
    const auto written = writeFully(fd, bytes, path);
    const auto reserved = reserveFileSpace(fd, 0, 100, path);
    const auto positioned = pwriteFully(fd, bytes, 100, path);
    ::close(fd);
    const bool matches = std::string(name) == "face3.pbdam";
    EXPECT_EQ(written.ok(), !matches) << name;
    EXPECT_EQ(reserved.ok(), !matches) << name;
    EXPECT_EQ(positioned.ok(), !matches) << name;
    if (matches) {
      EXPECT_EQ(written.error().code, ErrorCode::NoSpace);
      EXPECT_NE(written.error().message.find("face3.pbdam: no space to write 100 bytes (No space "
                                             "left on device)"),
                std::string::npos)
          << written.error().message;
    }
  }
  failWritesForTesting("");
}

TEST(FileWrite, OtherErrorsStayIoErrors) {
  const auto r = writeFully(-1, std::vector<std::byte>(8), "nowhere.bin");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::IoError);
  EXPECT_NE(r.error().message.find("nowhere.bin: cannot write 8 bytes"), std::string::npos)
      << r.error().message;
}

}  // namespace
}  // namespace pbdam::formats
