// How much memory a frame loop (`pbdam bench`, `render`, `fly`) may use, and how it is shared: the
// limit of the process's memory cgroup (v2 memory.max, v1 memory.limit_in_bytes; the smallest
// on the way to the root) or `--memory-budget-mib`, split into what the process already holds
// (libraries, the dataset's node tables, the Vulkan driver), the frames in flight (offscreen
// targets, readback and staging buffers), the GPU cache when the device's memory is the host's
// (lavapipe), and the room left for the dataset's pages that the next frames read — which the
// cgroup counts too. Below the smallest workable budget the loop refuses to start, naming what
// it needs. Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Result.h"

namespace pbdam::streaming {

/// A limit on the process's memory and where it came from.
struct MemoryLimit final {
  std::uint64_t bytes = 0;  ///< the limit
  /// "cgroup v2 memory.max of /sys/fs/cgroup/...", "cgroup v1 memory.limit_in_bytes of ...",
  /// "--memory-budget-mib".
  std::string source;
};

/// The memory limit of this process's cgroup: for cgroup v2 the smallest memory.max from its
/// cgroup up to the root, for cgroup v1 the same over memory.limit_in_bytes of the memory
/// controller's hierarchy. nullopt when no limit is set (or none can be read). `procSelfCgroup`
/// and `cgroupRoot` are for tests.
std::optional<MemoryLimit> cgroupMemoryLimit(
    const std::filesystem::path& procSelfCgroup = "/proc/self/cgroup",
    const std::filesystem::path& cgroupRoot = "/sys/fs/cgroup");

/// The limit a run is sized for: `budgetMiB` ("--memory-budget-mib") when it is above 0, else
/// the memory cgroup's (cgroupMemoryLimit); nullopt when there is neither.
std::optional<MemoryLimit> memoryLimitOf(double budgetMiB);

/// What a frame loop asks of memory.
struct MemoryDemand final {
  std::uint32_t widthPixels = 1280;  ///< the frames' size
  std::uint32_t heightPixels = 720;  ///< the frames' size
  std::uint32_t framesInFlight = 2;  ///< frames drawn at once, each with its own targets
  /// The GPU cache asked for (--gpu-cache-mib); with `cacheInHostMemory` it is lowered to fit.
  std::uint64_t gpuCacheBytes = 0;
  /// Whether the device's memory is the host's (a CPU device such as lavapipe): then the GPU
  /// cache is counted in the budget.
  bool cacheInHostMemory = true;
  /// Anonymous resident bytes of the process when the plan is made (node tables, the driver's
  /// allocations, heaps): what the kernel cannot reclaim. The libraries' clean file pages are
  /// left to the page room.
  std::uint64_t residentBytes = 0;
};

/// How a budget is shared.
struct MemoryPlan final {
  std::uint64_t budgetBytes = 0;    ///< the limit shared out (MemoryLimit::bytes)
  std::string source;               ///< where the limit came from (MemoryLimit::source)
  std::uint64_t residentBytes = 0;  ///< held already when the plan was made
  std::uint64_t frameBytes = 0;     ///< the frames in flight's targets and buffers
  std::uint64_t gpuCacheBytes = 0;  ///< the GPU cache's budget (lowered to fit on a CPU device)
  /// Host memory set aside for the cache's pools on a CPU device: twice its budget (the patch
  /// and the texture pool can each grow to the budget's worth of slots); 0 on other devices.
  std::uint64_t poolBytes = 0;
  std::uint64_t pageRoomBytes = 0;  ///< left for the dataset's pages (the page cache)
  bool cacheLowered = false;        ///< the cache asked for did not fit
  /// One line: the budget, its source and its shares.
  std::string describe() const;
  /// Whether the plan changed anything or was asked for (a cache lowered to fit, or an explicit
  /// --memory-budget-mib): then the commands print describe() on stderr; a roomy cgroup limit
  /// is only reported in the run's figures.
  bool worthReporting() const noexcept { return cacheLowered || source == "--memory-budget-mib"; }
};

/// How a frame loop under `limit` (memoryLimitOf) opens its dataset: with a limit, node tables
/// larger than the limit / kNodeCacheShare (over the six faces, at least 1 MiB a face) are paged
/// through a cache of that size (FaceViewOptions) instead of held whole, so that a dataset's
/// tables need not fit in memory; without one, tables are held whole.
formats::FaceViewOptions faceOptionsFor(const std::optional<MemoryLimit>& limit);
/// The share of a memory limit the node tables may take: limit / kNodeCacheShare.
inline constexpr std::uint64_t kNodeCacheShare = 32;

/// The smallest GPU cache and page room a frame loop is allowed to run with.
/// @{
inline constexpr std::uint64_t kMinGpuCacheBytes = std::uint64_t{16} << 20;
inline constexpr std::uint64_t kMinPageRoomBytes = std::uint64_t{48} << 20;
/// @}

/// Bytes the frames in flight hold besides the cache: per frame an RGBA8 colour target, a
/// 32-bit depth target, the readback buffer, and a staging allowance for the frame's uploads.
std::uint64_t frameBytes(std::uint32_t width, std::uint32_t height, std::uint32_t framesInFlight);

/// Shares `limit` among the demand's parts: the page room gets a quarter of what is left after
/// the process's resident bytes and the frames (at least kMinPageRoomBytes), the GPU cache's
/// pools the rest (on a CPU device twice the cache's budget, which is at most what was asked
/// for), and the page room whatever the cache leaves. InvalidArgument when the budget cannot
/// hold the resident bytes, the frames, the pools of a kMinGpuCacheBytes cache and
/// kMinPageRoomBytes: the message names the budget, its source and each of those figures.
formats::Result<MemoryPlan> planMemory(const MemoryLimit& limit, const MemoryDemand& demand);

/// A frame loop's plan, made once its dataset is open and its device made: memoryLimitOf
/// (`budgetMiB`) shared by planMemory with the process's anonymous resident bytes now (the
/// demand's residentBytes is set here); nullopt when there is no limit. With `report` it prints
/// describe() on stderr when the plan is worth reporting. Errors as planMemory.
formats::Result<std::optional<MemoryPlan>> planRunMemory(double budgetMiB, MemoryDemand demand,
                                                         bool report);

}  // namespace pbdam::streaming
