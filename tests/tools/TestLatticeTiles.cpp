// The sparse lattice (LatticeTiles.h) against brute force: the dense layout is the face-major
// row-major grid; a row visits exactly the stored points, in order, once each, where index()
// says they are; scans of a tiling whose tiles all keep every point decide as the dense scans
// do; a tiled SampleGrid stores the dense grid's heights at its points.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "GreedyInsertion.h"
#include "RoughDem.h"
#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/builder/SampleGrid.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

TEST(LatticeTiles, DenseLayoutIsTheFaceMajorRowMajorGrid) {
  const LatticeTiles tiles = LatticeTiles::dense(8);
  EXPECT_TRUE(tiles.isDense());
  EXPECT_EQ(tiles.pointCount(), 6u * 81u);
  ASSERT_EQ(tiles.rowCount(), 6u * 9u);
  for (std::uint64_t r = 0; r < tiles.rowCount(); ++r) {
    const LatticeTiles::Row row = tiles.row(r);
    EXPECT_EQ(row.face, static_cast<int>(r / 9));
    EXPECT_EQ(row.first, (LatticeXY{0, static_cast<int>(r % 9)}));
    EXPECT_EQ(row.spacing, 1);
    EXPECT_EQ(row.points, 9u);
    EXPECT_EQ(row.offset, r * 9);
  }
  EXPECT_EQ(tiles.index(2, LatticeXY{3, 5}), (2u * 9u + 5u) * 9u + 3u);
}

/// Whether a tile of `tiles` (brute force over all of them) stores point p of `face`.
bool storedByBruteForce(const LatticeTiles& tiles, int face, LatticeXY p) {
  const auto cells = static_cast<int>(tiles.tileCells());
  const auto perSide = static_cast<int>(tiles.tilesPerSide());
  for (int ty = 0; ty < perSide; ++ty) {
    for (int tx = 0; tx < perSide; ++tx) {
      const std::size_t k = (static_cast<std::size_t>(face) * static_cast<std::size_t>(perSide) +
                             static_cast<std::size_t>(ty)) *
                                static_cast<std::size_t>(perSide) +
                            static_cast<std::size_t>(tx);
      const int s = tiles.spacing(k);
      const bool inside = p.x >= tx * cells && p.x <= (tx + 1) * cells && p.y >= ty * cells &&
                          p.y <= (ty + 1) * cells;
      if (inside && p.x % s == 0 && p.y % s == 0) return true;
    }
  }
  return false;
}

TEST(LatticeTiles, RowsVisitEveryStoredPointOnceInOrderWhereIndexSays) {
  std::mt19937 rng(7);
  constexpr std::uint32_t kCells = 32;
  constexpr std::uint32_t kTile = 8;
  std::vector<std::uint8_t> spacing(std::size_t{6} * 16);
  for (std::uint8_t& s : spacing) s = static_cast<std::uint8_t>(rng() % 4);  // 1, 2, 4 or 8
  const LatticeTiles tiles(kCells, kTile, spacing);
  EXPECT_FALSE(tiles.isDense());
  // Storage rows cover the storage exactly once, each row inside its tile.
  std::uint64_t next = 0;
  for (std::uint64_t r = 0; r < tiles.rowCount(); ++r) {
    const LatticeTiles::Row row = tiles.row(r);
    EXPECT_EQ(row.offset, next);
    next += row.points;
    for (std::uint32_t i = 0; i < row.points; ++i) {
      const LatticeXY p{row.first.x + static_cast<int>(i) * row.spacing, row.first.y};
      EXPECT_TRUE(storedByBruteForce(tiles, row.face, p));
    }
  }
  EXPECT_EQ(next, tiles.pointCount());
  for (int face : {0, 3, 5}) {
    for (int y = 0; y <= static_cast<int>(kCells); ++y) {
      for (const int stride : {1, 2, 4, 8, 16}) {
        const auto first = static_cast<std::uint32_t>(rng() % (kCells + 1));
        const std::int64_t lo = first;
        const std::int64_t hi = lo + static_cast<std::int64_t>(rng() % (kCells + 1 - first));
        std::vector<std::int64_t> expected;
        for (std::int64_t x = lo; x <= hi; ++x) {
          if (x % stride == 0 && storedByBruteForce(tiles, face, LatticeXY{static_cast<int>(x), y}))
            expected.push_back(x);
        }
        std::vector<std::int64_t> visited;
        tiles.forEachInRow(face, y, lo, hi, stride, [&](std::int64_t x, std::uint64_t at) {
          visited.push_back(x);
          const LatticeXY p{static_cast<int>(x), y};
          // The same point may live in several tiles: each copy is a position of p.
          const std::uint64_t direct = tiles.index(face, p);
          EXPECT_NE(direct, LatticeTiles::kAbsent);
          EXPECT_LT(at, tiles.pointCount());
          (void)direct;
        });
        EXPECT_EQ(visited, expected)
            << "face " << face << " row " << y << " [" << lo << ", " << hi << "] stride " << stride;
      }
      for (int x = 0; x <= static_cast<int>(kCells); ++x) {
        const LatticeXY p{x, y};
        EXPECT_EQ(tiles.index(face, p) != LatticeTiles::kAbsent,
                  storedByBruteForce(tiles, face, p));
      }
    }
  }
}

using test::roughDem;

TEST(LatticeTiles, ATiledGridStoresTheDenseGridsHeightsAtItsPoints) {
  const HeightGrid dem = roughDem();
  const Lattice lattice(32);
  std::vector<std::uint8_t> spacing(std::size_t{6} * 16);
  for (std::size_t k = 0; k < spacing.size(); ++k) spacing[k] = static_cast<std::uint8_t>(k % 3);
  const LatticeTiles tiles(32, 8, spacing);
  const SampleGrid dense = SampleGrid::build(dem, Planet::mars(), lattice, 1);
  const SampleGrid tiled = SampleGrid::build(dem, Planet::mars(), lattice, tiles, 1);
  EXPECT_EQ(tiled.sourceSampleCount(), dense.sourceSampleCount());
  std::size_t compared = 0;
  for (int face = 0; face < 6; ++face) {
    for (int y = 0; y <= 32; ++y) {
      tiles.forEachInRow(face, y, 0, 32, 1, [&](std::int64_t x, std::uint64_t) {
        const LatticeXY p{static_cast<int>(x), y};
        EXPECT_EQ(tiled.height(face, p), dense.height(face, p));
        EXPECT_EQ(tiled.heightsOf(face).at(p), dense.height(face, p));
        ++compared;
      });
    }
  }
  EXPECT_GT(compared, 6u * 16u * 9u);
}

/// A face-0 tiled storage of `tiles` filled with f(x, y).
template <typename F>
std::vector<float> fillTiles(const LatticeTiles& tiles, F&& f) {
  std::vector<float> storage(static_cast<std::size_t>(tiles.pointCount()), 0.0f);
  for (std::uint64_t r = 0; r < tiles.rowCount(); ++r) {
    const LatticeTiles::Row row = tiles.row(r);
    for (std::uint32_t i = 0; i < row.points; ++i) {
      storage[static_cast<std::size_t>(row.offset + i)] =
          f(row.first.x + static_cast<int>(i) * row.spacing, row.first.y);
    }
  }
  return storage;
}

float rough(int x, int y) {
  return 2000.0f * std::sin(0.21f * static_cast<float>(x)) *
             std::cos(0.13f * static_cast<float>(y)) +
         90.0f * std::sin(1.7f * static_cast<float>(x * 31 + y * 17));
}

TEST(LatticeTiles, InsertionOverTilesKeepingEveryPointIsTheDenseInsertion) {
  constexpr std::uint32_t kCells = 64;
  std::vector<float> dense(std::size_t{kCells + 1} * (kCells + 1));
  for (int y = 0; y <= static_cast<int>(kCells); ++y) {
    for (int x = 0; x <= static_cast<int>(kCells); ++x) {
      dense[static_cast<std::size_t>(y) * (kCells + 1) + static_cast<std::size_t>(x)] = rough(x, y);
    }
  }
  const LatticeTiles tiles(kCells, 16, std::vector<std::uint8_t>(std::size_t{6} * 16, 0));
  const std::vector<float> storage = fillTiles(tiles, rough);
  const std::array<LatticeXY, 3> corners = {LatticeXY{0, 0}, LatticeXY{64, 0}, LatticeXY{0, 64}};
  const std::vector<LatticeXY> boundary(corners.begin(), corners.end());
  for (const double target : {400.0, 50.0, 5.0}) {
    const InsertionResult a = insertGreedily(FaceHeights{dense.data(), kCells}, corners, boundary,
                                             InsertionLimits{target, 0, 65535}, {});
    const InsertionResult b =
        insertGreedily(FaceHeights{storage.data(), kCells, &tiles, 0}, corners, boundary,
                       InsertionLimits{target, 0, 65535}, {});
    EXPECT_EQ(a.patch.points, b.patch.points) << target;
    EXPECT_EQ(a.patch.indices, b.patch.indices) << target;
    EXPECT_EQ(a.maxErrorMeters, b.maxErrorMeters) << target;
  }
}

TEST(LatticeTiles, InsertionOverMixedTilesInsertsOnlyStoredPoints) {
  constexpr std::uint32_t kCells = 64;
  std::vector<std::uint8_t> spacing(std::size_t{6} * 16, 2);  // every 4th point
  spacing[5] = 0;  // one tile of face 0 keeps every point
  spacing[6] = 1;
  const LatticeTiles tiles(kCells, 16, spacing);
  const std::vector<float> storage = fillTiles(tiles, rough);
  const std::array<LatticeXY, 3> corners = {LatticeXY{0, 0}, LatticeXY{64, 0}, LatticeXY{0, 64}};
  const std::vector<LatticeXY> boundary(corners.begin(), corners.end());
  const InsertionResult r = insertGreedily(FaceHeights{storage.data(), kCells, &tiles, 0}, corners,
                                           boundary, InsertionLimits{0.0, 0, 65535}, {});
  std::set<std::pair<int, int>> fine;
  for (const LatticeXY p : r.patch.points) {
    EXPECT_NE(tiles.index(0, p), LatticeTiles::kAbsent) << p.x << "," << p.y;
    if (p.x % 4 != 0 || p.y % 4 != 0) fine.insert({p.x, p.y});
  }
  // With a zero target every stored point is inserted: the fine tiles' too.
  EXPECT_GT(fine.size(), 100u);
  EXPECT_EQ(r.maxErrorMeters, 0.0);
}

}  // namespace
}  // namespace pbdam::builder
