// Guarded copies out of file mappings: a mapping whose file was truncated under it reads as an
// error naming the file and offset (never a SIGBUS), bytes still in the file read as before, any
// number of threads may hit unreadable pages at once, a fault outside a guarded copy still
// kills the process as it did before the handler was installed, and a command-line tool that
// opts in reports an unguarded fault in a mapping with its file and offset.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "TestData.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/formats/MemoryMapping.h"

namespace pbdam::formats {
namespace {

/// A file of `pages` pages of a byte pattern, mapped, then cut to `keptBytes` in place.
struct TruncatedMapping {
  MemoryMapping mapping;
  std::string content;
};

TruncatedMapping mapThenTruncate(const test::TempDir& dir, std::size_t pages,
                                 std::size_t keptBytes) {
  TruncatedMapping t;
  t.content.resize(pages * MemoryMapping::pageSize());
  for (std::size_t k = 0; k < t.content.size(); ++k) t.content[k] = static_cast<char>(k * 7 % 253);
  std::ofstream(dir / "f.bin", std::ios::binary)
      .write(t.content.data(), static_cast<std::streamsize>(t.content.size()));
  auto mapped = MemoryMapping::open(dir / "f.bin");
  EXPECT_TRUE(mapped) << mapped.error().message;
  t.mapping = std::move(mapped).value();
  EXPECT_EQ(::truncate((dir / "f.bin").c_str(), static_cast<off_t>(keptBytes)), 0);
  return t;
}

TEST(GuardedCopy, CopiesOrdinaryMemory) {
  const std::string source = "bytes in ordinary memory";
  std::string copy(source.size(), '\0');
  EXPECT_FALSE(guardedCopy(reinterpret_cast<std::byte*>(copy.data()),
                           reinterpret_cast<const std::byte*>(source.data()), source.size()));
  EXPECT_EQ(copy, source);
}

TEST(GuardedCopy, ReadPastTheEndOfATruncatedMappingIsAnErrorNamingFileAndOffset) {
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  TruncatedMapping t = mapThenTruncate(dir, 4, page + 100);
  // Still in the file: read as before.
  std::vector<std::byte> out(page);
  ASSERT_TRUE(t.mapping.read(10, out)) << "the first page is still in the file";
  EXPECT_EQ(std::memcmp(out.data(), t.content.data() + 10, out.size()), 0);
  // Past the new end: the page is gone; the copy reports it instead of dying of SIGBUS.
  const auto r = t.mapping.read(2 * page + 8, out);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_NE(r.error().message.find((dir / "f.bin").string()), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("offset " + std::to_string(2 * page + 8)), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("SIGBUS"), std::string::npos) << r.error().message;
  // A copy that starts readable and runs into the missing pages stops at the first of them.
  std::vector<std::byte> longer(page + 200);
  const auto partial = guardedCopy(longer.data(), t.mapping.bytes().data() + page, longer.size());
  ASSERT_TRUE(partial);
  EXPECT_EQ(partial->offset, page);  // the first byte of the third page
  // The guard leaves the thread as it found it: the same read fails the same way again.
  EXPECT_FALSE(t.mapping.read(3 * page, std::span(out).first(1)));
  EXPECT_FALSE(t.mapping.touch(0, 4 * page));
  EXPECT_TRUE(t.mapping.touch(0, page + 100));
  EXPECT_FALSE(crc32Mapped(t.mapping.bytes(), 0, 4 * page, "f.bin"));
  const auto crc = crc32Mapped(t.mapping.bytes(), 0, page + 100, "f.bin");
  ASSERT_TRUE(crc);
  EXPECT_EQ(*crc, crc32(std::as_bytes(std::span(t.content)).first(page + 100)));
}

TEST(GuardedCopy, AGuardedFaultLeavesTheThreadsSignalMaskAsItWas) {
  // The jump out of the handler skips the sigreturn that restores the mask; a runtime that
  // runs our handler from its own with every signal blocked (ThreadSanitizer) would otherwise
  // leave SIGBUS blocked, and the next fault would kill the process.
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  TruncatedMapping t = mapThenTruncate(dir, 4, page);
  sigset_t before;
  ASSERT_EQ(::pthread_sigmask(SIG_SETMASK, nullptr, &before), 0);
  std::vector<std::byte> out(16);
  ASSERT_FALSE(t.mapping.read(2 * page, out));
  sigset_t after;
  ASSERT_EQ(::pthread_sigmask(SIG_SETMASK, nullptr, &after), 0);
  for (const int signal : {SIGBUS, SIGSEGV, SIGTERM, SIGINT, SIGHUP, SIGUSR1}) {
    EXPECT_EQ(sigismember(&after, signal), sigismember(&before, signal)) << "signal " << signal;
  }
  // And a second fault on the same thread is still an error, not the end of the process.
  EXPECT_FALSE(t.mapping.read(3 * page, out));
}

TEST(GuardedCopy, RangesOutsideTheMappingAreErrors) {
  test::TempDir dir;
  TruncatedMapping t = mapThenTruncate(dir, 1, MemoryMapping::pageSize());
  std::vector<std::byte> out(16);
  const auto r = t.mapping.read(MemoryMapping::pageSize() - 8, out);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("outside"), std::string::npos) << r.error().message;
}

TEST(GuardedCopy, ManyThreadsHitUnreadablePagesAtOnce) {
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  TruncatedMapping t = mapThenTruncate(dir, 16, 2 * page);
  std::atomic<int> failures{0}, successes{0}, expectedSuccesses{0};
  std::vector<std::thread> threads;
  threads.reserve(4);
  for (int i = 0; i < 4; ++i) {
    threads.emplace_back([&, i] {
      std::vector<std::byte> out(page);
      for (int k = 0; k < 200; ++k) {
        const std::size_t at = static_cast<std::size_t>((k + i) % 16) * page;
        if (at < 2 * page) ++expectedSuccesses;
        if (t.mapping.read(at, out)) {
          ++successes;
        } else {
          ++failures;
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(successes.load() + failures.load(), 800);
  EXPECT_EQ(successes.load(), expectedSuccesses.load());  // pages 0 and 1 are still in the file
}

/// Reads a byte of a truncated mapping directly, outside any guard.
int readUnguarded(const MemoryMapping& mapping, std::size_t offset) {
  const volatile auto* bytes =
      reinterpret_cast<const volatile unsigned char*>(mapping.bytes().data());
  return bytes[offset];
}

TEST(GuardedCopyDeathTest, AFaultOutsideAGuardStillKillsTheProcess) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  TruncatedMapping t = mapThenTruncate(dir, 4, page);
  installMappedReadGuard();
  // Unguarded read of a page the file lost: SIGBUS, handed on to the default action.
  EXPECT_DEATH((void)readUnguarded(t.mapping, 3 * page), "");
  // After a guarded fault on this thread, an unguarded one still kills.
  std::vector<std::byte> out(8);
  ASSERT_FALSE(t.mapping.read(2 * page, out));
  EXPECT_DEATH((void)readUnguarded(t.mapping, 2 * page), "");
  // A plain null-pointer read is a SIGSEGV that no guard expects.
  EXPECT_DEATH(
      {
        volatile int* volatile nowhere = nullptr;
        (void)*nowhere;
      },
      "");
}

TEST(GuardedCopyDeathTest, ACommandLineToolReportsAnUnguardedFaultInAMappingAndExits) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  TruncatedMapping t = mapThenTruncate(dir, 4, page);
  // The opt-in of `pbdam`'s main: a line naming the file and offset, and the exit code given.
  EXPECT_EXIT(
      {
        reportUnreadableMappingsAndExit(2);
        (void)readUnguarded(t.mapping, 3 * page + 5);
      },
      testing::ExitedWithCode(2), "f.bin: offset " + std::to_string(3 * page + 5));
  // Outside every mapping the fault still goes to the previous handler.
  EXPECT_DEATH(
      {
        reportUnreadableMappingsAndExit(2);
        volatile int* volatile nowhere = nullptr;
        (void)*nowhere;
      },
      "");
}

}  // namespace
}  // namespace pbdam::formats
