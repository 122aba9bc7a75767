// The builder's RSS bound (ResidentTrimmer.h): the resident file pages it weighs, and that a
// trimmer with a budget drops mappings only while more than the budget is resident, one
// without a budget every period.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include "TestData.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/formats/MemoryMapping.h"

using namespace std::chrono_literals;

namespace pbdam::builder {
namespace {

/// Waits up to `limit` for `done`.
template <class Done>
bool waitFor(std::chrono::milliseconds limit, Done&& done) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

TEST(ResidentTrimmer, ResidentFileBytesCountAMappingsPagesOnceRead) {
  test::TempDir dir;
  const std::size_t bytes = std::size_t{16} << 20;
  {
    std::string content(bytes, '\x5a');
    std::ofstream(dir / "f.bin", std::ios::binary)
        .write(content.data(), static_cast<std::streamsize>(content.size()));
  }
  auto file = formats::MemoryMapping::open(dir / "f.bin");
  ASSERT_TRUE(file) << file.error().message;
  const std::optional<std::uint64_t> before = residentFileBytes();
  ASSERT_TRUE(before);
  EXPECT_GT(*before, 0u);  // this test's own executable pages at least
  unsigned sum = 0;
  for (std::size_t at = 0; at < bytes; at += formats::MemoryMapping::pageSize()) {
    sum += static_cast<unsigned>(file->bytes()[at]);
  }
  EXPECT_EQ(sum, 0x5au * static_cast<unsigned>(bytes / formats::MemoryMapping::pageSize()));
  const std::optional<std::uint64_t> read = residentFileBytes();
  ASSERT_TRUE(read);
  EXPECT_GE(*read, *before + bytes * 3 / 4);
  ASSERT_TRUE(file->releaseResident());
  const std::optional<std::uint64_t> released = residentFileBytes();
  ASSERT_TRUE(released);
  EXPECT_LE(*released, *read - bytes * 3 / 4);
}

TEST(ResidentTrimmer, DropsEveryPeriodWithoutABudgetAndOnlyOverOneWithIt) {
  EXPECT_TRUE(overResidentBudget(0));
  EXPECT_FALSE(overResidentBudget(std::uint64_t{1} << 50));
  EXPECT_TRUE(overResidentBudget(1));  // a page of the executable is resident
  std::atomic<int> unbudgeted{0};
  std::atomic<int> underBudget{0};
  std::atomic<int> overBudget{0};
  {
    const ResidentTrimmer every(10ms, [&] { ++unbudgeted; });
    const ResidentTrimmer under(
        10ms, [&] { ++underBudget; }, std::uint64_t{1} << 50);
    const ResidentTrimmer over(
        10ms, [&] { ++overBudget; }, 1);
    EXPECT_TRUE(waitFor(10s, [&] { return unbudgeted >= 3 && overBudget >= 3; }));
  }
  EXPECT_EQ(underBudget, 0);
}

}  // namespace
}  // namespace pbdam::builder
