#include "pbdam/streaming/MemoryBudget.h"

#include "pbdam/streaming/ProcessMemory.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>
#include <vector>

using namespace pbdam::formats;

namespace pbdam::streaming {
namespace {

namespace fs = std::filesystem;

/// Limits at or above this are "no limit" (cgroup v1 writes PAGE_COUNTER_MAX pages in bytes).
constexpr std::uint64_t kUnlimited = std::uint64_t{1} << 60;

std::optional<std::uint64_t> readLimitFile(const fs::path& file) {
  std::ifstream in(file);
  std::string text;
  if (!(in >> text) || text == "max") return std::nullopt;
  std::uint64_t value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + static_cast<std::uint64_t>(c - '0');
    if (value >= kUnlimited) return std::nullopt;
  }
  return value;
}

/// The smallest limit in `file` of `dir` and each of its parents up to `root`.
std::optional<MemoryLimit> smallestUpTo(const fs::path& root, const fs::path& dir, const char* file,
                                        const char* kind) {
  std::optional<MemoryLimit> best;
  fs::path at = dir;
  while (true) {
    if (const std::optional<std::uint64_t> limit = readLimitFile(at / file)) {
      if (!best || *limit < best->bytes) {
        best = MemoryLimit{*limit, std::string(kind) + " " + file + " of " + at.string()};
      }
    }
    if (at == root || !at.has_parent_path() || at.parent_path() == at) break;
    at = at.parent_path();
    if (at.string().size() < root.string().size()) break;
  }
  return best;
}

std::string mib(std::uint64_t bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f MiB", static_cast<double>(bytes) / 1048576.0);
  return text;
}

}  // namespace

std::optional<MemoryLimit> cgroupMemoryLimit(const fs::path& procSelfCgroup,
                                             const fs::path& cgroupRoot) {
  std::ifstream in(procSelfCgroup);
  std::string line;
  std::optional<MemoryLimit> best;
  const auto keep = [&best](std::optional<MemoryLimit> found) {
    if (found && (!best || found->bytes < best->bytes)) best = std::move(found);
  };
  while (std::getline(in, line)) {
    // hierarchy-ID:controller-list:cgroup-path
    const std::size_t first = line.find(':');
    const std::size_t second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    const std::string path = line.substr(second + 1);
    const fs::path relative = fs::path(path).relative_path();
    if (line.compare(0, first, "0") == 0 && controllers.empty()) {
      // cgroup v2: the unified hierarchy, at the root or (hybrid systems) under unified/.
      for (const fs::path& root : {cgroupRoot, cgroupRoot / "unified"}) {
        if (fs::exists(root / "cgroup.controllers")) {
          keep(smallestUpTo(root, root / relative, "memory.max", "cgroup v2"));
        }
      }
      continue;
    }
    std::istringstream list(controllers);
    for (std::string controller; std::getline(list, controller, ',');) {
      if (controller == "memory") {
        const fs::path root = cgroupRoot / "memory";
        keep(smallestUpTo(root, root / relative, "memory.limit_in_bytes", "cgroup v1"));
      }
    }
  }
  return best;
}

std::optional<MemoryLimit> memoryLimitOf(double budgetMiB) {
  if (budgetMiB > 0.0) {
    return MemoryLimit{static_cast<std::uint64_t>(budgetMiB * 1048576.0), "--memory-budget-mib"};
  }
  return cgroupMemoryLimit();
}

formats::FaceViewOptions faceOptionsFor(const std::optional<MemoryLimit>& limit) {
  formats::FaceViewOptions options;
  if (limit) {
    options.nodeCacheBytes =
        std::max<std::uint64_t>(std::uint64_t{1} << 20, limit->bytes / kNodeCacheShare / 6);
  }
  return options;
}

std::uint64_t frameBytes(std::uint32_t width, std::uint32_t height, std::uint32_t framesInFlight) {
  const std::uint64_t pixels = std::uint64_t{width} * height;
  constexpr std::uint64_t kStagingAllowance = std::uint64_t{8} << 20;
  return std::uint64_t{framesInFlight} * (pixels * 12 + kStagingAllowance);
}

std::string MemoryPlan::describe() const {
  return "memory budget " + mib(budgetBytes) + " (" + source + "): " + mib(residentBytes) +
         " held at start, " + mib(frameBytes) + " for the frames in flight, GPU cache " +
         mib(gpuCacheBytes) + (cacheLowered ? " (lowered to fit)" : "") +
         (poolBytes > gpuCacheBytes ? " in pools of up to " + mib(poolBytes) : "") + ", " +
         mib(pageRoomBytes) + " left for dataset pages";
}

Result<MemoryPlan> planMemory(const MemoryLimit& limit, const MemoryDemand& demand) {
  MemoryPlan plan;
  plan.budgetBytes = limit.bytes;
  plan.source = limit.source;
  plan.residentBytes = demand.residentBytes;
  plan.frameBytes = frameBytes(demand.widthPixels, demand.heightPixels, demand.framesInFlight);
  // On a CPU device the cache's pools are host memory, and they can hold up to twice its
  // budget: the patch pool and the texture pool each grow to the budget's worth of slots of
  // their own kind (one LRU over both, pools that never shrink).
  const std::uint64_t poolFactor = demand.cacheInHostMemory ? 2 : 0;
  const std::uint64_t cacheFloor = kMinGpuCacheBytes * poolFactor;
  const std::uint64_t needed =
      plan.residentBytes + plan.frameBytes + cacheFloor + kMinPageRoomBytes;
  if (limit.bytes < needed) {
    return invalidArgument(
        "a memory budget of " + mib(limit.bytes) + " (" + limit.source + ") is below the " +
        mib(needed) + " this run needs: " + mib(plan.residentBytes) +
        " held at start (node tables, driver, heap), " + mib(plan.frameBytes) + " for " +
        std::to_string(demand.framesInFlight) + " frames of " + std::to_string(demand.widthPixels) +
        "x" + std::to_string(demand.heightPixels) +
        (demand.cacheInHostMemory ? ", " + mib(cacheFloor) + " for the pools of a " +
                                        mib(kMinGpuCacheBytes) + " GPU cache"
                                  : "") +
        " and " + mib(kMinPageRoomBytes) + " for dataset pages");
  }
  const std::uint64_t spare = limit.bytes - plan.residentBytes - plan.frameBytes;
  if (!demand.cacheInHostMemory) {
    plan.gpuCacheBytes = demand.gpuCacheBytes;
    plan.pageRoomBytes = spare;
    return plan;
  }
  const std::uint64_t pageRoom = std::max(kMinPageRoomBytes, spare / 4);
  plan.gpuCacheBytes = std::min(demand.gpuCacheBytes, (spare - pageRoom) / poolFactor);
  plan.cacheLowered = plan.gpuCacheBytes < demand.gpuCacheBytes;
  plan.poolBytes = plan.gpuCacheBytes * poolFactor;
  plan.pageRoomBytes = spare - plan.poolBytes;
  return plan;
}

Result<std::optional<MemoryPlan>> planRunMemory(double budgetMiB, MemoryDemand demand,
                                                bool report) {
  const std::optional<MemoryLimit> limit = memoryLimitOf(budgetMiB);
  if (!limit) return std::optional<MemoryPlan>();
  demand.residentBytes = anonymousResidentBytes();
  auto plan = planMemory(*limit, demand);
  if (!plan) return std::move(plan).error();
  if (report && plan->worthReporting()) {
    std::fprintf(stderr, "pbdam: %s\n", plan->describe().c_str());
  }
  return std::optional<MemoryPlan>(std::move(*plan));
}

}  // namespace pbdam::streaming
