// The memory budget of a frame loop: the cgroup limit read as v1 and v2 lay it out (a fake
// hierarchy in a temporary directory), the smallest limit on the way to the root, "max" and
// v1's huge "unlimited", and how a budget is shared or refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "TestData.h"
#include "pbdam/streaming/MemoryBudget.h"

namespace pbdam::streaming {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

TEST(MemoryBudget, CgroupV2TakesTheSmallestMemoryMaxUpToTheRoot) {
  const test::TempDir tmp;
  const fs::path root = tmp / "cg";
  write(root / "cgroup.controllers", "cpu memory\n");
  write(root / "user.slice" / "memory.max", "1073741824\n");
  write(root / "user.slice" / "app" / "memory.max", "max\n");
  write(tmp / "self", "0::/user.slice/app\n");
  auto limit = cgroupMemoryLimit(tmp / "self", root);
  ASSERT_TRUE(limit.has_value());
  EXPECT_EQ(limit->bytes, 1073741824u);
  EXPECT_NE(limit->source.find("cgroup v2 memory.max"), std::string::npos) << limit->source;
  write(root / "user.slice" / "app" / "memory.max", "268435456\n");
  limit = cgroupMemoryLimit(tmp / "self", root);
  ASSERT_TRUE(limit.has_value());
  EXPECT_EQ(limit->bytes, 268435456u);
  write(root / "user.slice" / "app" / "memory.max", "max\n");
  write(root / "user.slice" / "memory.max", "max\n");
  EXPECT_FALSE(cgroupMemoryLimit(tmp / "self", root).has_value());
}

TEST(MemoryBudget, CgroupV1ReadsTheMemoryControllersLimitAndIgnoresUnlimited) {
  const test::TempDir tmp;
  const fs::path root = tmp / "cg";
  write(tmp / "self", "12:pids:/\n4:memory:/jobs/one\n1:name=systemd:/\n0::/\n");
  write(root / "memory" / "memory.limit_in_bytes", "9223372036854771712\n");
  write(root / "memory" / "jobs" / "memory.limit_in_bytes", "9223372036854771712\n");
  write(root / "memory" / "jobs" / "one" / "memory.limit_in_bytes", "9223372036854771712\n");
  EXPECT_FALSE(cgroupMemoryLimit(tmp / "self", root).has_value());
  write(root / "memory" / "jobs" / "memory.limit_in_bytes", "536870912\n");
  const auto limit = cgroupMemoryLimit(tmp / "self", root);
  ASSERT_TRUE(limit.has_value());
  EXPECT_EQ(limit->bytes, 536870912u);
  EXPECT_NE(limit->source.find("cgroup v1"), std::string::npos);
  EXPECT_NE(limit->source.find("jobs"), std::string::npos) << limit->source;
  EXPECT_FALSE(cgroupMemoryLimit(tmp / "missing", root).has_value());
}

TEST(MemoryBudget, ABudgetIsSharedAndTooSmallOneIsRefusedNamingWhatItNeeds) {
  MemoryDemand demand;
  demand.widthPixels = 1280;
  demand.heightPixels = 720;
  demand.framesInFlight = 2;
  demand.gpuCacheBytes = std::uint64_t{64} << 20;
  demand.residentBytes = std::uint64_t{100} << 20;
  const MemoryLimit big{std::uint64_t{4} << 30, "--memory-budget-mib"};
  auto plan = planMemory(big, demand);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->gpuCacheBytes, demand.gpuCacheBytes);
  EXPECT_FALSE(plan->cacheLowered);
  EXPECT_EQ(plan->poolBytes, 2 * plan->gpuCacheBytes);
  EXPECT_EQ(plan->residentBytes + plan->frameBytes + plan->poolBytes + plan->pageRoomBytes,
            big.bytes);

  const MemoryLimit tight{std::uint64_t{240} << 20, "cgroup v1 memory.limit_in_bytes of /x"};
  plan = planMemory(tight, demand);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_TRUE(plan->cacheLowered);
  EXPECT_GE(plan->gpuCacheBytes, kMinGpuCacheBytes);
  EXPECT_GE(plan->pageRoomBytes, kMinPageRoomBytes);
  EXPECT_EQ(plan->residentBytes + plan->frameBytes + plan->poolBytes + plan->pageRoomBytes,
            tight.bytes);
  EXPECT_NE(plan->describe().find("in pools of up to"), std::string::npos) << plan->describe();
  EXPECT_NE(plan->describe().find("240 MiB (cgroup v1"), std::string::npos) << plan->describe();

  const MemoryLimit tiny{std::uint64_t{150} << 20, "--memory-budget-mib"};
  const auto refused = planMemory(tiny, demand);
  ASSERT_FALSE(refused.ok());
  for (const char* part :
       {"150 MiB", "--memory-budget-mib", "100 MiB held at start (node tables",
        "2 frames of 1280x720", "32 MiB for the pools of a 16 MiB GPU cache", "48 MiB"}) {
    EXPECT_NE(refused.error().message.find(part), std::string::npos)
        << part << ": " << refused.error().message;
  }
  // A discrete GPU's cache is not host memory: a budget that could not hold it on a CPU device
  // holds the run.
  demand.cacheInHostMemory = false;
  const MemoryLimit small{std::uint64_t{200} << 20, "--memory-budget-mib"};
  plan = planMemory(small, demand);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  EXPECT_EQ(plan->gpuCacheBytes, demand.gpuCacheBytes);
  EXPECT_EQ(plan->poolBytes, 0u);
}

}  // namespace
}  // namespace pbdam::streaming
