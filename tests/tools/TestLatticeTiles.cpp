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
  for (std::size_t k = 0; k < tiles.tileCount(); ++k) {
    const LatticeTiles::Tile& t = tiles.tile(k);
    const auto cells = static_cast<int>(t.cells);
    const int s = t.spacing();
    const bool inside =
        t.face == face && p.x >= t.x0 && p.x <= t.x0 + cells && p.y >= t.y0 && p.y <= t.y0 + cells;
    if (inside && p.x % s == 0 && p.y % s == 0) return true;
  }
  return false;
}

/// Checks every query of `tiles` against brute force over its tiles: the storage rows, every
/// row scan at several strides, index(), and the spacings of random boxes.
void expectQueriesMatchBruteForce(const LatticeTiles& tiles, std::mt19937& rng) {
  const auto n = static_cast<int>(tiles.sideCells());
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
    for (int y = 0; y <= n; ++y) {
      for (const int stride : {1, 2, 4, 8, 16}) {
        const auto first = static_cast<std::uint32_t>(rng() % static_cast<std::uint32_t>(n + 1));
        const std::int64_t lo = first;
        const std::int64_t hi =
            lo + static_cast<std::int64_t>(rng() % (static_cast<std::uint32_t>(n) + 1 - first));
        std::vector<std::int64_t> expected;
        for (std::int64_t x = lo; x <= hi; ++x) {
          if (x % stride == 0 && storedByBruteForce(tiles, face, LatticeXY{static_cast<int>(x), y}))
            expected.push_back(x);
        }
        std::vector<std::int64_t> visited;
        tiles.forEachInRow(face, y, lo, hi, stride, [&](std::int64_t x, std::uint64_t at) {
          visited.push_back(x);
          EXPECT_NE(tiles.index(face, LatticeXY{static_cast<int>(x), y}), LatticeTiles::kAbsent);
          EXPECT_LT(at, tiles.pointCount());
        });
        EXPECT_EQ(visited, expected)
            << "face " << face << " row " << y << " [" << lo << ", " << hi << "] stride " << stride;
      }
      for (int x = 0; x <= n; ++x) {
        const LatticeXY p{x, y};
        EXPECT_EQ(tiles.index(face, p) != LatticeTiles::kAbsent,
                  storedByBruteForce(tiles, face, p));
      }
    }
    for (int k = 0; k < 200; ++k) {
      const int x0 = static_cast<int>(rng() % static_cast<std::uint32_t>(n));
      const int y0 = static_cast<int>(rng() % static_cast<std::uint32_t>(n));
      const int x1 = x0 + 1 + static_cast<int>(rng() % static_cast<std::uint32_t>(n - x0));
      const int y1 = y0 + 1 + static_cast<int>(rng() % static_cast<std::uint32_t>(n - y0));
      int finest = 1 << 30;
      int coarsest = 1;
      for (std::size_t t = 0; t < tiles.tileCount(); ++t) {
        const LatticeTiles::Tile& tile = tiles.tile(t);
        if (tile.face != face) continue;
        const int c = static_cast<int>(tile.cells);
        if (tile.x0 <= x1 && tile.x0 + c >= x0 && tile.y0 <= y1 && tile.y0 + c >= y0)
          finest = std::min(finest, tile.spacing());
        if (tile.x0 < x1 && tile.x0 + c > x0 && tile.y0 < y1 && tile.y0 + c > y0)
          coarsest = std::max(coarsest, tile.spacing());
      }
      EXPECT_EQ(tiles.finestSpacingIn(face, x0, y0, x1, y1), finest);
      EXPECT_EQ(tiles.coarsestSpacingIn(face, x0, y0, x1, y1), coarsest);
    }
  }
}

TEST(LatticeTiles, RowsVisitEveryStoredPointOnceInOrderWhereIndexSays) {
  std::mt19937 rng(7);
  constexpr std::uint32_t kCells = 32;
  constexpr std::uint32_t kTile = 8;
  std::vector<std::uint8_t> spacing(std::size_t{6} * 16);
  for (std::uint8_t& s : spacing) s = static_cast<std::uint8_t>(rng() % 4);  // 1, 2, 4 or 8
  const LatticeTiles tiles(kCells, kTile, spacing);
  EXPECT_FALSE(tiles.isDense());
  expectQueriesMatchBruteForce(tiles, rng);
}

// An adaptive tiling: squares cut into quarters where a region wants more points than a tile
// may hold a side; every query still answers as brute force over the tiles does, and the
// points stored are about the regions' own.
TEST(LatticeTiles, AnAdaptiveTilingCutsSquaresWhereRegionsAreFineAndAnswersAsBruteForce) {
  std::mt19937 rng(11);
  constexpr std::uint32_t kCells = 64;
  const std::vector<LatticeTiles::Region> regions = {
      {0, 3, 5, 9, 12, 0},     // a fine box in one square
      {0, 30, 30, 34, 34, 1},  // across four squares' corner
      {3, 40, 0, 64, 8, 2},    // along a face edge
      {5, 17, 47, 18, 48, 0},  // one cell
  };
  const LatticeTiles tiles = LatticeTiles::adaptive(kCells, 16, 3, regions, 4);
  EXPECT_FALSE(tiles.isDense());
  EXPECT_GT(tiles.tileCount(), std::size_t{6} * 16);  // some squares were cut
  for (const LatticeTiles::Region& r : regions) {
    // Every point a region wants is stored.
    const int s = 1 << r.spacingLog2;
    for (int y = r.y0; y <= r.y1; y += s) {
      for (int x = r.x0; x <= r.x1; x += s) {
        if (x % s == 0 && y % s == 0) {
          EXPECT_TRUE(storedByBruteForce(tiles, r.face, LatticeXY{x, y}))
              << r.face << ": " << x << "," << y;
        }
      }
    }
  }
  for (std::size_t k = 0; k < tiles.tileCount(); ++k) {
    const LatticeTiles::Tile& t = tiles.tile(k);
    EXPECT_TRUE(tiles.pointsPerRow(k) <= 5 || t.cells == static_cast<std::uint32_t>(t.spacing()))
        << "tile " << k << " has " << tiles.pointsPerRow(k) << " points a side";
  }
  // Cut squares store fewer points than whole squares at their finest spacing would.
  const LatticeTiles whole = LatticeTiles::adaptive(kCells, 16, 3, regions, 1024);
  EXPECT_EQ(whole.tileCount(), std::size_t{6} * 16);
  EXPECT_LT(tiles.pointCount(), whole.pointCount());
  expectQueriesMatchBruteForce(tiles, rng);
  expectQueriesMatchBruteForce(whole, rng);
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
