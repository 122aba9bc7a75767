// SampleGrid's bucketed source samples on MOLA: every sample in its bucket as stored, positions
// kept to a millimetre at 2^24 cells a face, the binned visits of a leaf's triangles equal to
// each triangle's own, files written in row ranges equal to the in-memory grid, and dense
// buckets split into sub-buckets without losing a sample.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include "TestData.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/Planet.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

/// MOLA's DEM and Mars; nothing (with the reason as a test failure) if either cannot be read.
std::optional<std::pair<HeightGrid, Planet>> readMars(const fs::path& demPath) {
  auto dem = readDem(demPath);
  if (!dem) {
    ADD_FAILURE() << dem.error().message;
    return std::nullopt;
  }
  auto planet = Planet::fromSpec("mars");
  if (!planet) {
    ADD_FAILURE() << planet.error().message;
    return std::nullopt;
  }
  return std::pair<HeightGrid, Planet>{std::move(dem).value(), std::move(planet).value()};
}

TEST(SampleGrid, EverySourceSampleLiesInItsBucketAsStored) {
  // A triangle looks for its samples in the buckets its corners span, and tests each by its
  // stored position, so a sample must lie in its bucket by that position. Bucketing the double
  // face position but storing a float one put MOLA samples that rounded onto a lattice line into
  // the bucket beside it, and triangles on that line missed them (stored errors up to 11 m too
  // small). Positions are now stored from the bucket's corner, within it.
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const auto mars = readMars(demPath);
  ASSERT_TRUE(mars);
  const HeightGrid& dem = mars->first;
  const Planet& planet = mars->second;
  const Lattice lattice(512);
  for (const std::uint32_t cells : {1u, 8u}) {
    const SampleGrid grid = SampleGrid::build(dem, planet, lattice, cells);
    const auto side = static_cast<float>(cells);
    std::size_t onALine = 0;
    std::size_t outside = 0;
    std::size_t samples = 0;
    for (int face = 0; face < 6; ++face) {
      for (std::uint32_t by = 0; by < grid.bucketsPerSide(); ++by) {
        for (std::uint32_t bx = 0; bx < grid.bucketsPerSide(); ++bx) {
          for (const SourceSample& s : grid.bucket(0, face, bx, by)) {
            if (s.x == std::floor(s.x) || s.y == std::floor(s.y)) ++onALine;
            if (!(s.x >= 0.0f && s.x <= side && s.y >= 0.0f && s.y <= side)) ++outside;
            ++samples;
          }
        }
      }
    }
    EXPECT_GT(onALine, 0u);  // the case that matters occurs in this data
    EXPECT_EQ(outside, 0u);
    EXPECT_EQ(samples, 1440u * 720u);
  }
}

TEST(SampleGrid, PositionsKeepAMillimetreAt2To24CellsAFace) {
  // 1 m lidar samples on a lattice of 2^24 cells a face side (0.6 m cells on Earth): a float
  // face coordinate kept them to half a cell (0.3 m), so errors were measured against samples
  // moved by up to that. From their bucket's corner (4096 cells) they keep 2^-24 of a bucket.
  const Planet earth = Planet::earthWgs84();
  const Lattice lattice(1u << 24);
  const double n = static_cast<double>(lattice.sideCells());
  const double faceMetres = 0.5 * 3.14159265358979 * 6378137.0;  // a face's side, about
  double worst = 0.0;
  for (int i = 0; i < 400; ++i) {
    const double lat = 49.8 + 0.0001234 * i;
    const double lon = 5.87 + 0.0002345 * i - 0.5 * (i % 7);
    const auto placed = SampleGrid::placeSample(earth, lattice, 4096, lat, lon, 300.0f);
    ASSERT_TRUE(placed);
    const FaceUv truth = CubeMap::directionToFaceUv(earth.geodeticToDirection(lat, lon));
    ASSERT_EQ(cubeFaceIndex(truth.face), placed->face);
    const double x = (placed->bx * 4096.0 + static_cast<double>(placed->sample.x)) / n;
    const double y = (placed->by * 4096.0 + static_cast<double>(placed->sample.y)) / n;
    worst = std::max({worst, std::abs(x - truth.uv.x), std::abs(y - truth.uv.y)});
  }
  EXPECT_LT(worst * faceMetres, 1e-3) << worst * n << " cells";
  EXPECT_FALSE(SampleGrid::placeSample(earth, lattice, 4096, 91.0, 0.0, 1.0f));
  EXPECT_FALSE(SampleGrid::placeSample(earth, lattice, 4096, 0.0, 0.0, std::nanf("")));
}

TEST(SampleGrid, BinnedVisitsAreThoseOfEachTriangle) {
  // A leaf's samples located through bins of cells: the same (triangle, sample, weights) as
  // testing each triangle's own buckets.
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const auto mars = readMars(demPath);
  ASSERT_TRUE(mars);
  const HeightGrid& dem = mars->first;
  const Planet& planet = mars->second;
  const Lattice lattice(512);
  using Visit = std::tuple<std::size_t, float, float, double, double, double>;
  for (const std::uint32_t bucketCells : {1u, 4u}) {
    const SampleGrid grid = SampleGrid::build(dem, planet, lattice, bucketCells);
    std::size_t visits = 0;
    // Every leaf (32-cell legs, depth 8) of two trees: an equatorial face and a polar one.
    for (const std::uint64_t first : {std::uint64_t{0}, 8 * Lattice::nodesPerTree(8)}) {
      for (std::uint64_t id = first + Lattice::firstIndexOfLevel(8);
           id < first + Lattice::nodesPerTree(8); id += 37) {
        const BinTriangle t = triangleOfNode(lattice, id, 8);
        const WorkPatch leaf = makeLeafPatch(t);
        std::vector<std::array<LatticeXY, 3>> corners;
        for (std::size_t k = 0; k < leaf.indices.size(); k += 3) {
          corners.push_back({leaf.points[leaf.indices[k]], leaf.points[leaf.indices[k + 1]],
                             leaf.points[leaf.indices[k + 2]]});
        }
        std::vector<Visit> byTriangle;
        for (std::size_t k = 0; k < corners.size(); ++k) {
          grid.forEachSourceSampleIn(t.face, corners[k][0], corners[k][1], corners[k][2],
                                     [&](double l0, double l1, double l2, const SourceSample& s) {
                                       byTriangle.emplace_back(k, s.x, s.y, l0, l1, l2);
                                     });
        }
        std::vector<Visit> byCell;
        grid.forEachSourceSampleInTriangles(
            t.face, {t.apex, t.left, t.right}, corners,
            [&](std::size_t k, double l0, double l1, double l2, const SourceSample& s) {
              byCell.emplace_back(k, s.x, s.y, l0, l1, l2);
            });
        std::sort(byTriangle.begin(), byTriangle.end());
        std::sort(byCell.begin(), byCell.end());
        EXPECT_EQ(byCell, byTriangle) << "leaf " << id;
        visits += byCell.size();
      }
    }
    EXPECT_GT(visits, 2000u);
  }
}

TEST(SampleGrid, FilesWrittenInRowRangesGiveTheInMemoryGrid) {
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const auto mars = readMars(demPath);
  ASSERT_TRUE(mars);
  const HeightGrid& dem = mars->first;
  const Planet& planet = mars->second;
  const Lattice lattice(64);
  const std::uint32_t bucketCells = 4;
  const SampleGrid memory = SampleGrid::build(dem, planet, lattice, bucketCells);

  // Three "ranks": uneven ranges of lattice rows and of DEM rows.
  test::TempDir dir;
  const fs::path heights = dir / "heights.f32";
  const std::size_t rows = std::size_t{6} * 65;
  const auto demRows = static_cast<std::size_t>(dem.height());
  const std::array<std::size_t, 4> rowCuts = {0, 100, 101, rows};
  const std::array<std::size_t, 4> demCuts = {0, demRows / 3, demRows / 2, demRows};
  HeightRowStats total;
  total.minHeightMeters = std::numeric_limits<float>::infinity();
  total.maxHeightMeters = -std::numeric_limits<float>::infinity();
  std::vector<fs::path> samples;
  for (std::size_t r = 0; r < 3; ++r) {
    auto stats =
        SampleGrid::writeHeightRows(dem, planet, lattice, heights, rowCuts[r], rowCuts[r + 1]);
    ASSERT_TRUE(stats) << stats.error().message;
    total.noDataPoints += stats->noDataPoints;
    total.minHeightMeters = std::min(total.minHeightMeters, stats->minHeightMeters);
    total.maxHeightMeters = std::max(total.maxHeightMeters, stats->maxHeightMeters);
    samples.push_back(dir / ("samples." + std::to_string(r)));
    ASSERT_TRUE(SampleGrid::writeSourceBuckets(dem, planet, lattice, bucketCells, samples.back(),
                                               demCuts[r], demCuts[r + 1]));
  }
  auto mapped = SampleGrid::open(lattice, planet, heights, samples, bucketCells, total);
  ASSERT_TRUE(mapped) << mapped.error().message;
  mapped->releaseResident();

  EXPECT_EQ(mapped->minHeightMeters(), memory.minHeightMeters());
  EXPECT_EQ(mapped->maxHeightMeters(), memory.maxHeightMeters());
  EXPECT_EQ(mapped->noDataPoints(), memory.noDataPoints());
  EXPECT_EQ(mapped->sourceSampleCount(), memory.sourceSampleCount());
  EXPECT_EQ(mapped->sourceSampleCount(), 1440u * 720u);
  EXPECT_EQ(mapped->bucketTables(), 3u);
  for (int face = 0; face < 6; ++face) {
    for (std::int32_t j = 0; j <= 64; ++j) {
      for (std::int32_t i = 0; i <= 64; ++i) {
        ASSERT_EQ(mapped->height(face, {i, j}), memory.height(face, {i, j}))
            << face << " " << i << " " << j;
      }
    }
    // Source samples are visited in the same order, so any reduction over them is the same.
    std::vector<float> a;
    std::vector<float> b;
    const glm::dvec2 p0(0.0, 0.0);
    const glm::dvec2 p1(1.0, 0.0);
    const glm::dvec2 p2(1.0, 1.0);
    memory.forEachSourceSampleIn(face, p0, p1, p2,
                                 [&](double, double, double, const SourceSample& s) {
                                   a.push_back(s.x);
                                   a.push_back(s.heightMeters);
                                 });
    mapped->forEachSourceSampleIn(face, p0, p1, p2,
                                  [&](double, double, double, const SourceSample& s) {
                                    b.push_back(s.x);
                                    b.push_back(s.heightMeters);
                                  });
    EXPECT_GT(a.size(), 1000u);
    EXPECT_TRUE(a == b) << "face " << face;
  }

  // A heights file of another lattice is refused, naming the file.
  auto other = SampleGrid::open(Lattice(32), planet, heights, samples, bucketCells, total);
  ASSERT_FALSE(other);
  EXPECT_NE(other.error().message.find("heights.f32"), std::string::npos);

  // A bucket file of an earlier version (a checkpoint of another pbdam) is refused, saying so.
  {
    std::fstream f(samples[1], std::ios::in | std::ios::out | std::ios::binary);
    const std::uint32_t version = 1;
    f.seekp(8);
    f.write(reinterpret_cast<const char*>(&version), sizeof version);
  }
  auto older = SampleGrid::open(lattice, planet, heights, samples, bucketCells, total);
  ASSERT_FALSE(older);
  EXPECT_NE(older.error().message.find("bucket file version 1"), std::string::npos)
      << older.error().message;
  EXPECT_NE(older.error().message.find("without --resume"), std::string::npos);
}

/// The (triangle, u, v, weights) visits of a leaf's triangles located through the leaf's
/// outline (forEachSourceSampleInTriangles) and through each triangle's whole box of buckets
/// (the (u, v) forEachSourceSampleIn, which reads dense buckets whole): sorted, for comparison.
using LeafVisit = std::tuple<std::size_t, float, float, double, double, double>;
std::pair<std::vector<LeafVisit>, std::vector<LeafVisit>> leafVisits(const SampleGrid& grid,
                                                                     const Lattice& lattice,
                                                                     std::uint64_t id, int depth) {
  const BinTriangle t = triangleOfNode(lattice, id, depth);
  const WorkPatch leaf = makeLeafPatch(t);
  std::vector<std::array<LatticeXY, 3>> corners;
  for (std::size_t k = 0; k < leaf.indices.size(); k += 3) {
    corners.push_back({leaf.points[leaf.indices[k]], leaf.points[leaf.indices[k + 1]],
                       leaf.points[leaf.indices[k + 2]]});
  }
  std::vector<LeafVisit> binned;
  grid.forEachSourceSampleInTriangles(
      t.face, {t.apex, t.left, t.right}, corners,
      [&](std::size_t k, double l0, double l1, double l2, const SourceSample& s) {
        binned.emplace_back(k, s.x, s.y, l0, l1, l2);
      });
  std::vector<LeafVisit> whole;
  for (std::size_t k = 0; k < corners.size(); ++k) {
    grid.forEachSourceSampleIn(t.face, lattice.uv(corners[k][0]), lattice.uv(corners[k][1]),
                               lattice.uv(corners[k][2]),
                               [&](double l0, double l1, double l2, const SourceSample& s) {
                                 whole.emplace_back(k, s.x, s.y, l0, l1, l2);
                               });
  }
  std::sort(binned.begin(), binned.end());
  std::sort(whole.begin(), whole.end());
  return {binned, whole};
}

TEST(SampleGrid, DenseBucketsAreSplitAndATriangleStillFindsEverySampleInIt) {
  // A bucket holding many more samples than a leaf reaches is split into sub-buckets, and a
  // leaf reads only those near it: the same visits as reading its buckets whole. MOLA's
  // 1440 x 720 samples in 64-cell buckets of a 512-cell lattice: about 2,700 a bucket (more near
  // the poles), so every bucket is split (4-cell sub-buckets and finer).
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const auto mars = readMars(demPath);
  ASSERT_TRUE(mars);
  const HeightGrid& dem = mars->first;
  const Planet& planet = mars->second;
  const Lattice lattice(512);
  const SampleGrid grid = SampleGrid::build(dem, planet, lattice, 64);
  EXPECT_EQ(grid.denseBuckets(), 6u * 8u * 8u);
  EXPECT_EQ(grid.sourceSampleCount(), 1440u * 720u);
  std::size_t visits = 0;
  // Leaves (32-cell legs, depth 8) of an equatorial tree and a polar one, and leaves of 4-cell
  // legs (depth 14) near a bucket's corner, where their outlines lie across sub-bucket edges.
  for (const std::uint64_t first : {std::uint64_t{0}, 8 * Lattice::nodesPerTree(8)}) {
    for (std::uint64_t id = first + Lattice::firstIndexOfLevel(8);
         id < first + Lattice::nodesPerTree(8); id += 37) {
      const auto [binned, whole] = leafVisits(grid, lattice, id, 8);
      EXPECT_EQ(binned, whole) << "leaf " << id;
      visits += binned.size();
    }
  }
  for (std::uint64_t id = Lattice::firstIndexOfLevel(14); id < Lattice::firstIndexOfLevel(15);
       id += 997) {
    const auto [binned, whole] = leafVisits(grid, lattice, id, 14);
    EXPECT_EQ(binned, whole) << "leaf " << id;
    visits += binned.size();
  }
  EXPECT_GT(visits, 4000u);
}

TEST(SampleGrid, DenseBucketFilesGiveTheInMemoryVisitsAndAreChecked) {
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const auto mars = readMars(demPath);
  ASSERT_TRUE(mars);
  const HeightGrid& dem = mars->first;
  const Planet& planet = mars->second;
  const Lattice lattice(64);
  const std::uint32_t bucketCells = 16;
  const SampleGrid memory = SampleGrid::build(dem, planet, lattice, bucketCells);
  test::TempDir dir;
  const fs::path heights = dir / "heights.f32";
  auto stats = SampleGrid::writeHeightRows(dem, planet, lattice, heights, 0, std::size_t{6} * 65);
  ASSERT_TRUE(stats) << stats.error().message;
  // Two DEM row ranges: each file splits its own dense buckets.
  const auto demRows = static_cast<std::size_t>(dem.height());
  const std::vector<fs::path> samples = {dir / "samples.0", dir / "samples.1"};
  ASSERT_TRUE(SampleGrid::writeSourceBuckets(dem, planet, lattice, bucketCells, samples[0], 0,
                                             demRows / 3));
  ASSERT_TRUE(SampleGrid::writeSourceBuckets(dem, planet, lattice, bucketCells, samples[1],
                                             demRows / 3, demRows));
  auto mapped = SampleGrid::open(lattice, planet, heights, samples, bucketCells, *stats);
  ASSERT_TRUE(mapped) << mapped.error().message;
  EXPECT_GT(mapped->denseBuckets(), memory.denseBuckets());
  EXPECT_EQ(mapped->sourceSampleCount(), memory.sourceSampleCount());
  std::size_t visits = 0;
  for (std::uint64_t id = Lattice::firstIndexOfLevel(6); id < Lattice::nodesPerTree(6); id += 7) {
    for (const std::uint64_t tree : {std::uint64_t{0}, 9 * Lattice::nodesPerTree(6)}) {
      const auto a = leafVisits(memory, lattice, tree + id, 6);
      const auto b = leafVisits(*mapped, lattice, tree + id, 6);
      EXPECT_EQ(a.first, b.first) << "leaf " << tree + id;
      EXPECT_EQ(b.first, b.second) << "leaf " << tree + id;
      visits += a.first.size();
    }
  }
  EXPECT_GT(visits, 5000u);

  // A dense bucket's sub-bucket offsets that no longer add up are refused, naming the file.
  mapped = SampleGrid::open(lattice, planet, heights, {}, bucketCells, *stats);  // unmapped
  {
    std::fstream f(samples[1], std::ios::in | std::ios::out | std::ios::binary);
    std::uint64_t dense = 0;
    f.seekg(24);
    f.read(reinterpret_cast<char*>(&dense), 8);
    ASSERT_GT(dense, 0u);
    // The first dense bucket's last sub-bucket offset (its sample count): one more.
    std::uint64_t first = 0;
    std::uint32_t side = 0;
    f.seekg(48 + 8);
    f.read(reinterpret_cast<char*>(&side), 4);
    f.seekg(48 + 16);
    f.read(reinterpret_cast<char*>(&first), 8);
    const auto at =
        static_cast<std::streamoff>(48 + dense * 24 + (first + std::uint64_t{side} * side) * 4);
    std::uint32_t count = 0;
    f.seekg(at);
    f.read(reinterpret_cast<char*>(&count), 4);
    ++count;
    f.seekp(at);
    f.write(reinterpret_cast<const char*>(&count), 4);
  }
  auto damaged = SampleGrid::open(lattice, planet, heights, samples, bucketCells, *stats);
  ASSERT_FALSE(damaged);
  EXPECT_NE(damaged.error().message.find(samples[1].string()), std::string::npos);
  EXPECT_NE(damaged.error().message.find("sub-bucket offsets"), std::string::npos)
      << damaged.error().message;
}

}  // namespace
}  // namespace pbdam::builder
