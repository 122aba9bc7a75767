// Patch measurement and lattice keys checked against the plain definitions they are fast forms
// of: the lattice deviation and the source-sample error against a scan of every lattice point
// and every source sample of each triangle's bounding box, and the lattice's point keys against
// the cube map's canonical keys (docs/builder.md "Errors", "Lattice and bintrees").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/runtime/Bintree.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// A whole-planet DEM of 3° cells with rough, deterministic relief (no two neighbours alike).
HeightGrid roughDem() {
  GridGeometry g;
  g.width = 120;
  g.height = 60;
  g.firstLatDegrees = 88.5;
  g.firstLonDegrees = 1.5;
  g.latSpacingDegrees = 3.0;
  g.lonSpacingDegrees = 3.0;
  g.pixelIsArea = true;
  std::vector<float> heights(static_cast<std::size_t>(g.width * g.height));
  for (std::size_t k = 0; k < heights.size(); ++k) {
    const double x = static_cast<double>(k);
    heights[k] = static_cast<float>(3000.0 * std::sin(0.37 * x) + 1700.0 * std::cos(1.91 * x));
  }
  return HeightGrid(g, std::move(heights), GridSource{});
}

/// maxLatticeDeviation by its definition: every lattice point of each triangle's bounding box
/// tested for being inside or on it.
double latticeDeviationByScan(const SampleGrid& grid, int face, const WorkPatch& patch) {
  double worst = 0.0;
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY a = patch.points[patch.indices[k]];
    const LatticeXY b = patch.points[patch.indices[k + 1]];
    const LatticeXY c = patch.points[patch.indices[k + 2]];
    const std::int64_t total = doubleArea(a, b, c);
    if (total <= 0) continue;
    for (int y = std::min({a.y, b.y, c.y}); y <= std::max({a.y, b.y, c.y}); ++y) {
      for (int x = std::min({a.x, b.x, c.x}); x <= std::max({a.x, b.x, c.x}); ++x) {
        const LatticeXY p{x, y};
        const std::int64_t w0 = doubleArea(b, c, p);
        const std::int64_t w1 = doubleArea(c, a, p);
        const std::int64_t w2 = doubleArea(a, b, p);
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double hp = (static_cast<double>(w0) *
                               static_cast<double>(static_cast<double>(grid.height(face, a))) +
                           static_cast<double>(w1) *
                               static_cast<double>(static_cast<double>(grid.height(face, b))) +
                           static_cast<double>(w2) * static_cast<double>(grid.height(face, c))) /
                          static_cast<double>(total);
        worst = std::max(worst, std::abs(hp - static_cast<double>(grid.height(face, p))));
      }
    }
  }
  return worst;
}

/// The sample error by its definition: the lattice scan and every source sample that
/// SampleGrid::forEachSourceSampleIn finds in each triangle's bounding box of buckets.
double sampleErrorByScan(const SampleGrid& grid, int face, const WorkPatch& patch) {
  double worst = latticeDeviationByScan(grid, face, patch);
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY a = patch.points[patch.indices[k]];
    const LatticeXY b = patch.points[patch.indices[k + 1]];
    const LatticeXY c = patch.points[patch.indices[k + 2]];
    const double ha = static_cast<double>(static_cast<double>(grid.height(face, a)));
    const double hb = static_cast<double>(static_cast<double>(grid.height(face, b)));
    const double hc = static_cast<double>(static_cast<double>(grid.height(face, c)));
    grid.forEachSourceSampleIn(
        face, grid.lattice().uv(a), grid.lattice().uv(b), grid.lattice().uv(c),
        [&](double l0, double l1, double l2, const SourceSample& s) {
          const double hp = l0 * ha + l1 * hb + l2 * hc;
          worst = std::max(worst, std::abs(hp - static_cast<double>(s.heightMeters)));
        });
  }
  return worst;
}

/// One triangle covering the whole bintree triangle: the widest case for the row spans.
WorkPatch wholeTriangle(const BinTriangle& t) {
  WorkPatch p;
  p.points = {t.apex, t.left, t.right};
  p.indices = doubleArea(t.apex, t.left, t.right) > 0 ? std::vector<std::uint32_t>{0, 1, 2}
                                                      : std::vector<std::uint32_t>{0, 2, 1};
  return p;
}

/// The four leaf patches under a diamond's two triangles, and the pointers simplifyBlock takes.
struct DiamondLeaves final {
  explicit DiamondLeaves(const std::array<BinTriangle, 2>& tri) {
    for (std::size_t s = 0; s < 2; ++s) {
      const auto kids = Lattice::children(tri[s]);
      for (std::size_t c = 0; c < 2; ++c) {
        leaves[s][c] = makeLeafPatch(kids[c]);
        children[s][c] = &leaves[s][c];
      }
    }
  }
  DiamondLeaves(const DiamondLeaves&) = delete;
  DiamondLeaves& operator=(const DiamondLeaves&) = delete;
  std::array<std::array<WorkPatch, 2>, 2> leaves;
  std::array<std::array<const WorkPatch*, 2>, 2> children{};
};

TEST(PatchBuilder, MeasuredSampleErrorEqualsAScanOfEveryCandidate) {
  const HeightGrid dem = roughDem();
  const Lattice lattice(64);
  // Buckets of one cell: source samples (3° apart) are far sparser than the lattice, and of
  // 4 cells: triangles then share buckets.
  for (const std::uint32_t bucketCells : {1u, 4u}) {
    const SampleGrid grid = SampleGrid::build(dem, Planet::mars(), lattice, bucketCells);
    ASSERT_GT(grid.sourceSampleCount(), 0u);
    // Depth 4 with 17-vertex leaves (legs of 16 cells); blocks of level 3 across all faces.
    for (const Diamond& d : diamondsOfLevel(lattice, 4, 3)) {
      const std::array<BinTriangle, 2> tri = {triangleOfNode(lattice, d[0], 4),
                                              triangleOfNode(lattice, d[1], 4)};
      const DiamondLeaves kids(tri);
      for (std::size_t s = 0; s < 2; ++s) {
        for (const WorkPatch& leaf : kids.leaves[s]) {
          EXPECT_EQ(leaf.points.size(), 17u * 18u / 2u);
          // A leaf lies on its parent's face.
          EXPECT_EQ(maxLatticeDeviation(grid, tri[s].face, leaf),
                    latticeDeviationByScan(grid, tri[s].face, leaf));
        }
      }
      const BlockResult block =
          simplifyBlock(grid, tri, kids.children, BlockTargets{200.0, 40, 65535});
      const std::array<const WorkPatch*, 2> halves = {&block.first, &block.second};
      for (std::size_t s = 0; s < 2; ++s) {
        for (const WorkPatch& patch : {*halves[s], wholeTriangle(tri[s])}) {
          EXPECT_EQ(maxLatticeDeviation(grid, tri[s].face, patch),
                    latticeDeviationByScan(grid, tri[s].face, patch));
          const MeasuredPatch m = measurePatch(grid, tri[s], patch, 1.0 / 64.0);
          EXPECT_EQ(m.sampleErrorMeters, sampleErrorByScan(grid, tri[s].face, patch));
        }
      }
    }
  }
}

TEST(PatchBuilder, SampleErrorAndSagAddPerTriangle) {
  // A point of a triangle is off by its sample error plus that triangle's own sag: the stored
  // error is the largest such sum, at most (and on rough data less than) the two maxima added.
  const HeightGrid dem = roughDem();
  const Lattice lattice(64);
  const SampleGrid grid = SampleGrid::build(dem, Planet::mars(), lattice, 1);
  int tighter = 0;
  for (const Diamond& d : diamondsOfLevel(lattice, 4, 3)) {
    const std::array<BinTriangle, 2> tri = {triangleOfNode(lattice, d[0], 4),
                                            triangleOfNode(lattice, d[1], 4)};
    const DiamondLeaves kids(tri);
    const BlockResult block =
        simplifyBlock(grid, tri, kids.children, BlockTargets{200.0, 40, 65535});
    const std::array<const WorkPatch*, 2> halves = {&block.first, &block.second};
    for (std::size_t s = 0; s < 2; ++s) {
      const WorkPatch& patch = *halves[s];
      const MeasuredPatch m = measurePatch(grid, tri[s], patch, 1.0 / 64.0);
      double worst = 0.0;
      for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
        WorkPatch one;
        one.points = patch.points;
        one.indices = {patch.indices[k], patch.indices[k + 1], patch.indices[k + 2]};
        const double sag = measurePatch(grid, tri[s], one, 1.0 / 64.0).chordErrorMeters;
        worst = std::max(worst, sampleErrorByScan(grid, tri[s].face, one) + sag);
      }
      EXPECT_EQ(m.errorMeters, worst + m.representationErrorMeters);
      const double sumOfMaxima =
          m.sampleErrorMeters + m.chordErrorMeters + m.representationErrorMeters;
      EXPECT_LE(m.errorMeters, sumOfMaxima);
      if (m.errorMeters < sumOfMaxima) ++tighter;
    }
  }
  EXPECT_GT(tighter, 0);
}

TEST(PatchBuilder, LeavesOfOneShapeAreTranslates) {
  const Lattice lattice(64);
  // Every level-4 triangle of one tree against the first one of the same shape.
  const std::uint64_t first = Lattice::firstIndexOfLevel(4);
  int pairs = 0;
  for (std::uint64_t k = 1; k < 16; ++k) {
    for (std::uint64_t m = 0; m < k; ++m) {
      const BinTriangle a = lattice.triangle(2, 1, 4, first + m);
      const BinTriangle b = lattice.triangle(2, 1, 4, first + k);
      if (a.left - a.apex != b.left - b.apex || a.right - a.apex != b.right - b.apex) continue;
      const WorkPatch pa = makeLeafPatch(a);
      const WorkPatch pb = makeLeafPatch(b);
      ASSERT_EQ(pa.points.size(), pb.points.size());
      EXPECT_EQ(pa.indices, pb.indices);
      for (std::size_t v = 0; v < pa.points.size(); ++v) {
        EXPECT_TRUE(pa.points[v] - a.apex == pb.points[v] - b.apex);
      }
      ++pairs;
      break;
    }
  }
  EXPECT_GT(pairs, 0);
}

TEST(Lattice, PointKeysAreTheCubeMapsCanonicalKeys) {
  for (const std::uint32_t n : {1u, 2u, 8u}) {
    const Lattice lattice(n);
    for (int face = 0; face < 6; ++face) {
      for (std::uint32_t j = 0; j <= n; ++j) {
        for (std::uint32_t i = 0; i <= n; ++i) {
          const LatticeXY p{static_cast<std::int32_t>(i), static_cast<std::int32_t>(j)};
          EXPECT_EQ(lattice.key(face, p), latticePointKey(n, face, p)) << face << " " << i << j;
        }
      }
    }
  }
}

}  // namespace
}  // namespace pbdam::builder
