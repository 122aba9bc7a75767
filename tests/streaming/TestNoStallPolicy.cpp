// The no-stall policy without Vulkan (NoStallPolicy): on a private copy of the MOLA dataset,
// evicted from the page cache (posix_fadvise DONTNEED), the cut it chooses is the finest
// level-capped cut whose every patch and tile is resident — one level finer is not — and once
// the full cut's bytes are read in, nothing is capped.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "PrivateCopy.h"
#include "TestData.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/NoStallPolicy.h"
#include "pbdam/streaming/PageCache.h"
#include "pbdam/streaming/PageLocks.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::streaming {
namespace {

bool cutResident(const MappedDataset& dataset, const Cut& cut) {
  const DatasetView& view = dataset.view();
  for (const CutPatch& p : cut.patches) {
    const NodeRecord n = view.node(p.node);
    if (!NoStallPolicy::rangeResident(dataset.faceFile(p.node.face), n.blobOffset,
                                      n.blobsBytes())) {
      return false;
    }
  }
  for (const TileKey& t : cut.tiles) {
    const TextureRecord r = view.textureNode(t);
    if (!NoStallPolicy::rangeResident(dataset.faceFile(t.face), r.blobOffset, r.blobsBytes())) {
      return false;
    }
  }
  return true;
}

/// The process's locked memory in kB (VmLck in /proc/self/status), what the kernel counts: mincore
/// cannot tell a locked page from a resident one. -1 when the line cannot be read.
long lockedKiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmLck:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

// The ASan and TSan runtimes intercept mlock and munlock and do nothing (returning 0), which
// leaves VmLck at 0: under them the page registry's count stands in for the kernel's.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kKernelLocks = false;
#else
constexpr bool kKernelLocks = true;
#endif

/// What is locked now, in kB: VmLck, or the registry's pages under the sanitizers.
long lockedNowKiB() {
  if (kKernelLocks) return lockedKiB();
  return static_cast<long>(PageLocks::instance().lockedPages() *
                           static_cast<std::size_t>(::sysconf(_SC_PAGESIZE)) / 1024);
}

/// Reads `cut`'s patch and tile bytes into the page cache (what the loader thread does).
void readIn(const MappedDataset& dataset, const Cut& cut) {
  const DatasetView& view = dataset.view();
  const auto touch = [](const MappedFile& file, std::uint64_t offset, std::uint64_t size) {
    ASSERT_TRUE(file.willNeed(offset, size).ok());
    volatile std::uint8_t sink = 0;
    const auto data = file.bytes();
    for (std::uint64_t k = offset; k < offset + size; k += 512) {
      sink = sink + static_cast<std::uint8_t>(data[k]);
    }
  };
  for (const CutPatch& p : cut.patches) {
    const NodeRecord n = view.node(p.node);
    touch(dataset.faceFile(p.node.face), n.blobOffset, n.blobsBytes());
  }
  for (const TileKey& t : cut.tiles) {
    const TextureRecord r = view.textureNode(t);
    touch(dataset.faceFile(t.face), r.blobOffset, r.blobsBytes());
  }
}

/// A private copy of the MOLA test dataset, evicted from the page cache and mapped, with its
/// coarse levels preloaded as the bench does before the first frame; a camera over Olympus Mons.
class NoStallPolicyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    PBDAM_REQUIRE_DATASET(shared, "mola");
    const std::filesystem::path dir = test::privateCopy(shared, temp_);
    ASSERT_TRUE(evictDataset(dir).ok());
    auto opened = MappedDataset::open(dir);
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    dataset_ = std::move(*opened);
    policy_.emplace(*dataset_);
    EXPECT_TRUE(policy_->preloadCoarseLevels().empty());
  }
  const MappedDataset& dataset() const { return *dataset_; }
  const DatasetView& view() const { return dataset_->view(); }
  const NoStallPolicy& policy() const { return *policy_; }
  Camera camera() const {
    return Camera::fromPose(view().planet(), {18.65, 226.2, 400e3, 0.0, -40.0, 0.0},
                            {320, 240, 60.0});
  }

 private:
  test::TempDir temp_;
  std::unique_ptr<MappedDataset> dataset_;
  std::optional<NoStallPolicy> policy_;
};

TEST_F(NoStallPolicyTest, DrawsTheFinestFullyResidentCapAndNothingCappedOnceResident) {
  const DatasetView& view = this->view();
  const MappedDataset& cold = dataset();
  const NoStallPolicy& policy = this->policy();

  const Camera camera = this->camera();
  const RefinementOptions options;
  const Cut full = refine(view, camera, options);
  ASSERT_FALSE(cutResident(cold, full)) << "the eviction was meant to leave the cut cold";

  const NoStallCut chosen = policy.cut(camera, options);
  ASSERT_GE(chosen.levelCap, 0) << "the preloaded coarse levels always give a cut";
  ASSERT_LT(chosen.levelCap, view.depth());
  EXPECT_FALSE(chosen.cut.patches.empty());
  EXPECT_TRUE(cutResident(cold, chosen.cut));
  RefinementOptions capped = options;
  capped.maxLevel = chosen.levelCap;
  EXPECT_EQ(refine(view, camera, capped).patches.size(), chosen.cut.patches.size());
  // The finest: one level more needs something that is not resident.
  capped.maxLevel = chosen.levelCap + 1;
  EXPECT_FALSE(cutResident(cold, refine(view, camera, capped)));

  // Read the full cut's bytes in: then nothing is capped and the cut is the full one.
  readIn(cold, full);
  ASSERT_TRUE(cutResident(cold, full));
  const NoStallCut warm = policy.cut(camera, options);
  EXPECT_EQ(warm.levelCap, view.depth());
  EXPECT_EQ(warm.cut.patches.size(), full.patches.size());
  EXPECT_EQ(warm.cut.triangles, full.triangles);
}

// What the caller holds decoded (its GPU cache) needs no page: with every page of the dataset
// evicted, even the roots', a cut the cache holds is still drawn whole, and locks nothing. Before,
// an uncapped no-stall flight drew frames with nothing in them whenever other processes' memory
// pressure took the roots' pages from the page cache while the GPU cache still held them.
TEST_F(NoStallPolicyTest, WhatTheGpuCacheHoldsNeedsNoPage) {
  const DatasetView& view = this->view();
  const Camera camera = this->camera();
  const RefinementOptions options;
  const Cut full = refine(view, camera, options);
  ASSERT_TRUE(evictDataset(dataset().directory()).ok());
  EXPECT_EQ(policy().cut(camera, options).levelCap, -1) << "the roots' pages were evicted too";

  std::set<std::uint64_t> patches;
  std::set<std::uint64_t> tiles;
  for (const CutPatch& p : full.patches) patches.insert(packKey(p.node));
  for (const TileKey& t : full.tiles) tiles.insert(packKey(t));
  NoStallCached cached;
  cached.patch = [&patches](const NodeKey& key) { return patches.count(packKey(key)) != 0; };
  cached.tile = [&tiles](const TileKey& key) { return tiles.count(packKey(key)) != 0; };
  const NoStallPolicy holding(dataset(), true, cached);
  const NoStallCut chosen = holding.cut(camera, options);
  EXPECT_EQ(chosen.levelCap, view.depth());
  EXPECT_EQ(chosen.cut.patches.size(), full.patches.size());
  EXPECT_EQ(chosen.held.bytes(), 0U) << "cached patches and tiles are not read: nothing to lock";

  // One patch of the cut not cached (and not resident) caps the cut below its level again.
  const CutPatch missing = full.patches.front();
  patches.erase(packKey(missing.node));
  const NoStallPolicy lacking(dataset(), false, cached);
  EXPECT_LT(lacking.cut(camera, options).levelCap, missing.level);
}

// The cap rises at most two levels a frame, but it does not wait for levels that nobody fetches:
// the loader reads the camera's own cut, so with that resident and the levels between the
// previous cap and it not, the next frame draws the full cut (a flight over a large dataset
// once stayed at level 0 for the rest of its path).
TEST_F(NoStallPolicyTest, TheCapDoesNotWaitForLevelsTheLoaderDoesNotFetch) {
  const DatasetView& view = this->view();
  const MappedDataset& cold = dataset();
  const NoStallPolicy& policy = this->policy();
  const Camera camera = this->camera();
  const RefinementOptions options;
  readIn(cold, refine(view, camera, options));
  RefinementOptions three = options;
  three.maxLevel = 3;
  const Cut between = refine(view, camera, three);
  ASSERT_FALSE(cutResident(cold, between)) << "level 3 near the camera was meant to be cold";

  const NoStallCut next = policy.cutAfter(camera, options, 1);
  EXPECT_EQ(next.levelCap, view.depth());
  EXPECT_TRUE(cutResident(cold, next.cut));

  // Where the next step is resident, the rise is held to it.
  readIn(cold, between);
  EXPECT_EQ(policy.cutAfter(camera, options, 1).levelCap, 3);
  // At the top, nothing changes.
  EXPECT_EQ(policy.cutAfter(camera, options, view.depth()).levelCap, view.depth());
}

// With node tables paged through a small cache and their pages out of the page cache, the
// records the cut would descend into cap it too: the render thread's cut reads no record from
// disk (no major fault on its thread), and once the loader has read them the cap rises.
TEST(NoStallPolicyPaged, RecordsNotAtHandCapTheLevelWithoutADiskRead) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  FaceViewOptions paged;
  paged.nodeCacheBytes = 1;  // one chunk a shard
  auto opened = MappedDataset::open(dir, paged);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  const MappedDataset& dataset = **opened;
  const DatasetView& view = dataset.view();
  ASSERT_TRUE(view.face(0).nodeTablePaged());
  for (int f = 0; f < 6; ++f) ASSERT_TRUE(dataset.faceFile(f).releaseResident().ok());
  ASSERT_TRUE(evictDataset(dir).ok());
  const NoStallPolicy policy(dataset);
  EXPECT_TRUE(policy.preloadCoarseLevels().empty());
  const Camera camera =
      Camera::fromPose(view.planet(), {18.65, 226.2, 400e3, 0.0, -40.0, 0.0}, {320, 240, 60.0});
  const RefinementOptions options;

  rusage before{};
  ASSERT_EQ(::getrusage(RUSAGE_THREAD, &before), 0);
  const NoStallCut cold = policy.cut(camera, options);
  rusage after{};
  ASSERT_EQ(::getrusage(RUSAGE_THREAD, &after), 0);
  EXPECT_EQ(after.ru_majflt, before.ru_majflt) << "the no-stall cut read from disk";
  ASSERT_GE(cold.levelCap, 0);
  EXPECT_LT(cold.levelCap, view.depth());
  EXPECT_EQ(cold.cut.unresidentRecordLevel, -1);

  // The loader's refinement reads the records (and its patches' bytes): nothing is capped.
  const Cut full = refine(view, camera, options);
  readIn(dataset, full);
  const NoStallCut warm = policy.cut(camera, options);
  EXPECT_EQ(warm.levelCap, view.depth());
  EXPECT_EQ(warm.cut.patches.size(), full.patches.size());
}

// Under a memory budget the preload also locks the coarse levels: they stay resident when the
// page cache is dropped around them, so a no-stall frame always has a cut to draw.
TEST(NoStallPolicyPaged, HeldCoarseLevelsStayResidentWhenTheRestIsDropped) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  auto opened = MappedDataset::open(dir);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  const MappedDataset& dataset = **opened;
  const DatasetView& view = dataset.view();
  HeldPages coarse;
  EXPECT_TRUE(NoStallPolicy(dataset).preloadCoarseLevels(&coarse).empty());
  // Locking is best effort (RLIMIT_MEMLOCK); CI runs as root, where it must work.
  if (coarse.bytes() == 0) {
    if (test::runningInCi()) FAIL() << "mlock refused under CI";
    GTEST_SKIP() << "mlock is not allowed here (RLIMIT_MEMLOCK)";
  }
  for (int f = 0; f < 6; ++f) {
    const MappedFile& file = dataset.faceFile(f);
    const std::uint64_t blobs = view.face(f).header().blobsOffset;
    coarse.releaseResidentAround(file, blobs, file.size() - blobs);
  }
  ASSERT_TRUE(evictDataset(dir).ok());
  for (int f = 0; f < 6; ++f) {
    const NodeRecord root = view.node(NodeKey{static_cast<std::uint8_t>(f), 0, 0});
    EXPECT_TRUE(
        NoStallPolicy::rangeResident(dataset.faceFile(f), root.blobOffset, root.blobsBytes()))
        << "face " << f;
  }
  const NoStallCut cut = NoStallPolicy(dataset).cut(
      Camera::fromPose(view.planet(), {18.65, 226.2, 400e3, 0.0, -40.0, 0.0}, {320, 240, 60.0}),
      RefinementOptions{});
  EXPECT_GE(cut.levelCap, 0);
}

// A frame's hold takes pages the run-long hold already has: the cut of a capped frame is made of
// the preloaded coarse levels. mlock does not nest — one munlock unlocks a page however often it
// was locked — so dropping the frame's hold (and each retry at a lower cap) used to unlock the
// coarse levels for the rest of the run: a no-stall bench under a 300 MiB budget went from
// 272 kB locked to 0 within its first frames. Holds now count, and a page is unlocked when its
// last holder lets it go.
TEST(NoStallPolicyPaged, CoarseLevelsStayLockedWhenAFramesHoldIsDropped) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  auto opened = MappedDataset::open(shared);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  const MappedDataset& dataset = **opened;
  const DatasetView& view = dataset.view();
  const long unlocked = lockedNowKiB();
  ASSERT_GE(unlocked, 0) << "no VmLck line in /proc/self/status";
  std::optional<HeldPages> coarse(std::in_place);
  EXPECT_TRUE(NoStallPolicy(dataset).preloadCoarseLevels(&*coarse).empty());
  // Locking is best effort (RLIMIT_MEMLOCK); CI runs as root, where it must work.
  if (coarse->bytes() == 0) {
    if (test::runningInCi()) FAIL() << "mlock refused under CI";
    GTEST_SKIP() << "mlock is not allowed here (RLIMIT_MEMLOCK)";
  }
  const long coarseKiB = lockedNowKiB();
  ASSERT_GT(coarseKiB, unlocked);

  // Capped at level 1 the cut is levels 0-1 with the root tiles: all of it preloaded, so all of
  // its pages are the coarse hold's too.
  const Camera camera =
      Camera::fromPose(view.planet(), {18.65, 226.2, 400e3, 0.0, -40.0, 0.0}, {320, 240, 60.0});
  RefinementOptions coarseOnly;
  coarseOnly.maxLevel = 1;
  const NoStallPolicy holding(dataset, true);
  for (int frame = 0; frame < 3; ++frame) {
    std::optional<NoStallCut> cut = holding.cut(camera, coarseOnly);
    ASSERT_GE(cut->levelCap, 0);
    ASSERT_GT(cut->held.bytes(), 0U);
    EXPECT_EQ(lockedNowKiB(), coarseKiB) << "the frame locks nothing the preload did not";
    cut.reset();  // the frame is decoded
    EXPECT_EQ(lockedNowKiB(), coarseKiB) << "frame " << frame << "'s release unlocked coarse pages";
  }
  // A cut that retries at lower caps (the full cut is not resident) lets go of each try's locks
  // in the loop; what it keeps, and the coarse levels, are still locked after.
  {
    const NoStallCut capped = holding.cut(camera, RefinementOptions{});
    ASSERT_GE(capped.levelCap, 0);
    EXPECT_GE(lockedNowKiB(), coarseKiB);
  }
  EXPECT_EQ(lockedNowKiB(), coarseKiB);
  // The last holder of a page unlocks it.
  coarse.reset();
  EXPECT_EQ(lockedNowKiB(), unlocked);
}

}  // namespace
}  // namespace pbdam::streaming
