// The GPU cache's bookkeeping (ResidencyLru, no Vulkan): byte budget in slot bytes, one LRU
// order over patches and tiles, no eviction of entries the current pass uses, lowest free slots
// first; and the one packing of node and tile keys that the cache and the prefetcher share.
#include <gtest/gtest.h>

#include <random>
#include <unordered_set>
#include <vector>

#include "pbdam/streaming/ResidencyLru.h"

using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::streaming {
namespace {

ResidentKey patch(std::uint64_t heap) { return ResidentKey::patch(NodeKey{1, 0, heap}); }
ResidentKey tile(std::uint64_t heap) { return ResidentKey::tile(TileKey{2, heap}); }

TEST(ResidencyLru, KeysKeepKindFaceTreeAndHeapApart) {
  EXPECT_EQ(patch(5).kind(), ResidentKind::Patch);
  EXPECT_EQ(tile(5).kind(), ResidentKind::Tile);
  EXPECT_NE(patch(5), tile(5));
  EXPECT_NE(ResidentKey::patch(NodeKey{0, 0, 7}), ResidentKey::patch(NodeKey{0, 1, 7}));
  EXPECT_NE(ResidentKey::patch(NodeKey{0, 0, 7}), ResidentKey::patch(NodeKey{5, 0, 7}));
  EXPECT_NE(ResidentKey::tile(TileKey{0, 7}), ResidentKey::tile(TileKey{5, 7}));
}

TEST(KeyPacking, IsInjectiveOverTheValidRanges) {
  // Exhaustive over every face, tree and the heap indices of a bintree of depth 10 (and a
  // texture quadtree of 5 levels), plus the largest heap indices the packing allows.
  std::unordered_set<std::uint64_t> seen;
  std::size_t count = 0;
  std::vector<std::uint64_t> heaps;
  for (std::uint64_t heap = 0; heap < (std::uint64_t{1} << 11); ++heap) heaps.push_back(heap);
  const std::uint64_t top = (std::uint64_t{1} << kMaxKeyHeapBits) - 1;
  for (std::uint64_t k = 0; k < 16; ++k) heaps.push_back(top - k);
  for (std::uint8_t face = 0; face < 8; ++face) {
    for (const std::uint64_t heap : heaps) {
      for (std::uint8_t tree = 0; tree < 2; ++tree) {
        seen.insert(packKey(NodeKey{face, tree, heap}));
        ++count;
      }
      seen.insert(packKey(TileKey{face, heap}));
      ++count;
    }
  }
  EXPECT_EQ(seen.size(), count);
  // Random keys round-trip through the bit fields the packing documents.
  std::mt19937_64 random(7);
  for (int i = 0; i < 100000; ++i) {
    const NodeKey node{static_cast<std::uint8_t>(random() % 8),
                       static_cast<std::uint8_t>(random() % 2), random() & top};
    const std::uint64_t p = packKey(node);
    EXPECT_EQ(p >> 63, 0u);
    EXPECT_EQ((p >> 60) & 7, node.face);
    EXPECT_EQ((p >> 59) & 1, node.tree);
    EXPECT_EQ(p & top, node.heap);
    const TileKey tile{node.face, node.heap};
    const std::uint64_t q = packKey(tile);
    EXPECT_EQ(q >> 63, 1u);
    EXPECT_EQ((q >> 60) & 7, tile.face);
    EXPECT_EQ(q & top, tile.heap);
  }
  // The cache's keys are exactly these packings.
  EXPECT_EQ(ResidentKey::patch(NodeKey{3, 1, 99}).packed, packKey(NodeKey{3, 1, 99}));
  EXPECT_EQ(ResidentKey::tile(TileKey{3, 99}).packed, packKey(TileKey{3, 99}));
}

TEST(ResidencyLru, CountsSlotBytesAndNeverExceedsTheBudget) {
  ResidencyLru lru(100, {10, 30});
  EXPECT_EQ(lru.capacity(ResidentKind::Patch), 10u);
  EXPECT_EQ(lru.capacity(ResidentKind::Tile), 3u);
  std::vector<ResidentKey> evicted;
  std::uint64_t epoch = 1;
  for (std::uint64_t i = 0; i < 7; ++i) {
    ASSERT_TRUE(lru.insert(patch(i), epoch, evicted).has_value());
  }
  ASSERT_TRUE(lru.insert(tile(0), epoch, evicted).has_value());
  EXPECT_EQ(lru.residentBytes(), 100u);
  EXPECT_TRUE(evicted.empty());
  // Everything is used by this epoch: nothing may be evicted, so nothing more fits.
  EXPECT_FALSE(lru.insert(patch(99), epoch, evicted).has_value());
  EXPECT_TRUE(evicted.empty());
  EXPECT_EQ(lru.residentBytes(), 100u);
  // A later epoch evicts the least recently used entries, patches and tiles alike.
  ++epoch;
  lru.touch(patch(0), epoch);
  ASSERT_TRUE(lru.insert(tile(1), epoch, evicted).has_value());
  ASSERT_EQ(evicted.size(), 3u);  // 30 bytes: patches 1, 2, 3 (patch 0 was touched)
  EXPECT_EQ(evicted[0], patch(1));
  EXPECT_EQ(evicted[1], patch(2));
  EXPECT_EQ(evicted[2], patch(3));
  EXPECT_LE(lru.residentBytes(), lru.budgetBytes());
  EXPECT_TRUE(lru.find(patch(0)).has_value());
  EXPECT_FALSE(lru.find(patch(1)).has_value());
}

TEST(ResidencyLru, AFailedInsertEvictsNothing) {
  ResidencyLru lru(60, {10, 30});
  std::vector<ResidentKey> evicted;
  ASSERT_TRUE(lru.insert(patch(0), 1, evicted).has_value());
  ASSERT_TRUE(lru.insert(tile(0), 2, evicted).has_value());
  ASSERT_TRUE(lru.insert(patch(1), 2, evicted).has_value());
  // 50 resident; a tile needs 30: evicting patch 0 (epoch 1) frees only 10.
  EXPECT_FALSE(lru.insert(tile(1), 2, evicted).has_value());
  EXPECT_TRUE(evicted.empty());
  EXPECT_TRUE(lru.find(patch(0)).has_value());
  EXPECT_EQ(lru.residentBytes(), 50u);
}

TEST(ResidencyLru, ReusesTheLowestFreeSlot) {
  ResidencyLru lru(1000, {10, 10});
  std::vector<ResidentKey> evicted;
  for (std::uint64_t i = 0; i < 5; ++i) EXPECT_EQ(*lru.insert(patch(i), 1, evicted), i);
  EXPECT_EQ(*lru.insert(tile(0), 1, evicted), 0u);  // slots are numbered per kind
  lru.erase(patch(3));
  lru.erase(patch(1));
  EXPECT_EQ(*lru.insert(patch(10), 1, evicted), 1u);
  EXPECT_EQ(*lru.insert(patch(11), 1, evicted), 3u);
  EXPECT_EQ(*lru.insert(patch(12), 1, evicted), 5u);
  lru.erase(patch(12));
  lru.erase(patch(4));
  EXPECT_EQ(*lru.insert(patch(13), 1, evicted), 4u);
  EXPECT_EQ(lru.count(ResidentKind::Patch), 5u);
  EXPECT_EQ(lru.count(ResidentKind::Tile), 1u);
}

TEST(ResidencyLru, HighestSlotStaysBelowTheCapacity) {
  ResidencyLru lru(95, {10, 1000});
  std::vector<ResidentKey> evicted;
  std::uint32_t highest = 0;
  for (std::uint64_t i = 0; i < 1000; ++i) {
    const auto slot = lru.insert(patch(i), i + 1, evicted);
    ASSERT_TRUE(slot.has_value());
    highest = std::max(highest, *slot);
    ASSERT_LE(lru.residentBytes(), 95u);
  }
  EXPECT_LT(highest, lru.capacity(ResidentKind::Patch));
  EXPECT_EQ(lru.size(), 9u);
  // A tile larger than the whole budget never fits.
  EXPECT_FALSE(lru.insert(tile(0), 5000, evicted).has_value());
}

TEST(ResidencyLru, APinnedEntryIsNeverEvictedWhateverItsEpoch) {
  ResidencyLru lru(40, {10, 30});
  std::vector<ResidentKey> evicted;
  for (std::uint64_t i = 0; i < 4; ++i) ASSERT_TRUE(lru.insert(patch(i), 1, evicted).has_value());
  lru.pin(patch(0));  // the least recently used, pinned twice (two passes in flight)
  lru.pin(patch(0));
  EXPECT_EQ(lru.pinnedBytes(), 10u);
  // A later pass needs 30 bytes: patches 1, 2, 3 go, patch 0 stays although it is the oldest.
  ASSERT_TRUE(lru.insert(tile(0), 2, evicted).has_value());
  ASSERT_EQ(evicted.size(), 3u);
  EXPECT_EQ(evicted[0], patch(1));
  EXPECT_TRUE(lru.find(patch(0)).has_value());
  // Everything else is pinned or of the current epoch: nothing more fits.
  lru.pin(tile(0));
  evicted.clear();
  EXPECT_FALSE(lru.insert(patch(9), 3, evicted).has_value());
  EXPECT_TRUE(evicted.empty());
  // One pin taken back still leaves patch 0 pinned; the second releases it.
  lru.unpin(patch(0));
  EXPECT_FALSE(lru.insert(patch(9), 3, evicted).has_value());
  lru.unpin(patch(0));
  EXPECT_EQ(lru.pinnedBytes(), 30u);
  ASSERT_TRUE(lru.insert(patch(9), 3, evicted).has_value());
  ASSERT_EQ(evicted.size(), 1u);
  EXPECT_EQ(evicted[0], patch(0));
  // Erasing a pinned entry (a failed upload) takes its pinned bytes along.
  lru.erase(tile(0));
  EXPECT_EQ(lru.pinnedBytes(), 0u);
  EXPECT_EQ(lru.residentBytes(), 10u);
}

}  // namespace
}  // namespace pbdam::streaming
