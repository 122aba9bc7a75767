// Counted page locks (PageLocks) on anonymous memory: a page stays locked — in the kernel's own
// count, VmLck — until its last hold goes, overlapping and unaligned ranges count per page, and a
// refused lock leaves nothing behind. Holds from several threads at once (TSan-checked).
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "TestData.h"
#include "pbdam/streaming/PageLocks.h"

namespace pbdam::streaming {
namespace {

/// The process's locked memory in kB (VmLck in /proc/self/status); -1 when it cannot be read.
long lockedKiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

const std::size_t kPage = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
const long kPageKiB = static_cast<long>(kPage / 1024);

// The ASan and TSan runtimes intercept mlock and munlock and do nothing (returning 0), so under
// them VmLck stays 0 and a range that is not mapped is "locked" too: the registry's own count
// stands in for the kernel's, and the refusal test does not apply.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kKernelLocks = false;
#else
constexpr bool kKernelLocks = true;
#endif

/// Eight pages of anonymous memory, unmapped at the end.
class PageLocksTest : public ::testing::Test {
 protected:
  void SetUp() override {
    void* at =
        ::mmap(nullptr, 8 * kPage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(at, MAP_FAILED);
    pages_ = static_cast<std::byte*>(at);
    base_ = lockedKiB();
    ASSERT_GE(base_, 0) << "no VmLck line in /proc/self/status";
    baseRegistered_ = PageLocks::instance().lockedPages();
    // Locking is best effort (RLIMIT_MEMLOCK); CI runs as root, where it must work.
    if (!PageLocks::instance().lock(pages_, kPage)) {
      if (test::runningInCi()) FAIL() << "mlock refused under CI";
      GTEST_SKIP() << "mlock is not allowed here (RLIMIT_MEMLOCK)";
    }
    PageLocks::instance().unlock(pages_, kPage);
  }
  void TearDown() override {
    if (pages_) ::munmap(pages_, 8 * kPage);
  }
  std::byte* page(std::size_t k) const { return pages_ + k * kPage; }
  /// Pages locked since SetUp: the kernel's count (VmLck), or the registry's under the
  /// sanitizers.
  long lockedPagesNow() const {
    if (!kKernelLocks) {
      return static_cast<long>(PageLocks::instance().lockedPages()) -
             static_cast<long>(baseRegistered_);
    }
    return (lockedKiB() - base_) / kPageKiB;
  }

 private:
  std::byte* pages_ = nullptr;
  long base_ = 0;
  std::size_t baseRegistered_ = 0;
};

TEST_F(PageLocksTest, APageStaysLockedUntilItsLastHoldGoes) {
  PageLocks& locks = PageLocks::instance();
  const std::size_t before = locks.lockedPages();
  ASSERT_TRUE(locks.lock(page(1), 3 * kPage));  // the run-long hold: pages 1-3
  ASSERT_TRUE(locks.lock(page(2), kPage));      // a frame's hold inside it
  EXPECT_EQ(lockedPagesNow(), 3);
  EXPECT_EQ(locks.holds(page(2)), 2U);
  locks.unlock(page(2), kPage);  // the frame is done
  EXPECT_EQ(lockedPagesNow(), 3) << "a nested release unlocked the outer hold's page";
  EXPECT_EQ(locks.holds(page(2)), 1U);
  locks.unlock(page(1), 3 * kPage);
  EXPECT_EQ(lockedPagesNow(), 0);
  EXPECT_EQ(locks.lockedPages(), before);
  EXPECT_EQ(locks.holds(page(2)), 0U);
}

// Byte ranges are widened to pages, as mlock does: two ranges that share only a page share a
// hold on it, and the page goes when the second one goes.
TEST_F(PageLocksTest, UnalignedRangesCountPerPage) {
  PageLocks& locks = PageLocks::instance();
  ASSERT_TRUE(locks.lock(page(1) + 100, kPage));      // pages 1-2
  ASSERT_TRUE(locks.lock(page(2) + 200, 2 * kPage));  // pages 2-4
  EXPECT_EQ(lockedPagesNow(), 4);
  EXPECT_EQ(locks.holds(page(2) + kPage - 1), 2U);
  locks.unlock(page(1) + 100, kPage);
  EXPECT_EQ(lockedPagesNow(), 3) << "page 1 goes, page 2 is still held by the second range";
  EXPECT_EQ(locks.holds(page(1)), 0U);
  EXPECT_EQ(locks.holds(page(2)), 1U);
  locks.unlock(page(2) + 200, 2 * kPage);
  EXPECT_EQ(lockedPagesNow(), 0);
  EXPECT_TRUE(locks.lock(page(0), 0)) << "an empty range is held";
}

// A lock the kernel refuses takes no hold and leaves no lock behind, not even on the pages before
// the one it refused (mlock locks up to where it fails), and the pages held before stay as they
// were. The refusal here: a range with a page that is not mapped (ENOMEM, as RLIMIT_MEMLOCK's
// refusal is for an unprivileged process; root ignores that limit).
TEST_F(PageLocksTest, ARefusedLockTakesNoHold) {
  if (!kKernelLocks) GTEST_SKIP() << "the sanitizer's mlock refuses nothing";
  PageLocks& locks = PageLocks::instance();
  ASSERT_TRUE(locks.lock(page(4), kPage));
  ASSERT_EQ(::munmap(page(6), kPage), 0);
  EXPECT_FALSE(locks.lock(page(3), 5 * kPage)) << "page 6 is not mapped";
  EXPECT_EQ(lockedPagesNow(), 1) << "pages 3 and 5 were left locked";
  EXPECT_EQ(locks.holds(page(4)), 1U);
  EXPECT_EQ(locks.holds(page(3)), 0U);
  EXPECT_EQ(locks.holds(page(5)), 0U);
  locks.unlock(page(4), kPage);
  EXPECT_EQ(lockedPagesNow(), 0);
}

// Holds taken and let go on several threads at once over the same pages (a render context per
// thread in `pbdam serve`, the no-stall loader beside the render thread): the counts and the
// kernel's locks agree at the end, and the page a long hold has stays locked throughout.
TEST_F(PageLocksTest, HoldsFromSeveralThreadsNest) {
  PageLocks& locks = PageLocks::instance();
  ASSERT_TRUE(locks.lock(page(0), 8 * kPage));
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < 4; ++t) {
    threads.emplace_back([&locks, this, t] {
      for (int round = 0; round < 200; ++round) {
        const std::size_t first = (t + static_cast<std::size_t>(round)) % 6;
        if (locks.lock(page(first) + 10, 2 * kPage)) locks.unlock(page(first) + 10, 2 * kPage);
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(lockedPagesNow(), 8);
  for (std::size_t k = 0; k < 8; ++k) EXPECT_EQ(locks.holds(page(k)), 1U) << "page " << k;
  locks.unlock(page(0), 8 * kPage);
  EXPECT_EQ(lockedPagesNow(), 0);
}

}  // namespace
}  // namespace pbdam::streaming
