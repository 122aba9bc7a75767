// Patch measurement and lattice keys checked against the plain definitions they are fast forms
// of: the lattice deviation and the source-sample error against a scan of every lattice point
// and every source sample of each triangle's bounding box, and the lattice's point keys against
// the cube map's canonical keys (docs/builder.md "Errors", "Lattice and bintrees").
#include <gtest/gtest.h>

#include <limits>

#include <map>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "RoughDem.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/runtime/Bintree.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// A whole-planet DEM of 3° cells with rough, deterministic relief (no two neighbours alike).
using test::roughDem;

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

/// Calls f(triangle, half) for both halves of every block of level 3 on a depth-4 lattice of 64
/// cells, simplified from their leaves to 200 m with at least 40 triangles.
template <class F>
void forEachBlockHalf(const SampleGrid& grid, F&& f) {
  const Lattice& lattice = grid.lattice();
  for (const Diamond& d : diamondsOfLevel(lattice, 4, 3)) {
    const std::array<BinTriangle, 2> tri = {triangleOfNode(lattice, d[0], 4),
                                            triangleOfNode(lattice, d[1], 4)};
    const DiamondLeaves kids(tri);
    const BlockResult block =
        simplifyBlock(grid, tri, kids.children, BlockTargets{200.0, 40, 65535});
    f(tri[0], block.first);
    f(tri[1], block.second);
  }
}

/// Triangle k of `patch` alone (the same points).
WorkPatch triangleAlone(const WorkPatch& patch, std::size_t k) {
  WorkPatch one;
  one.points = patch.points;
  one.indices = {patch.indices[3 * k], patch.indices[3 * k + 1], patch.indices[3 * k + 2]};
  return one;
}

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

TEST(PatchBuilder, ErrorsBoundedThroughTheChildrenAreAtLeastThoseOfTheSamples) {
  // Each triangle's bound through its children (PatchBound.h) is at least its sample error by
  // definition; where in doubt the samples decide, and with every triangle in doubt the result
  // is the full measurement's.
  const HeightGrid dem = roughDem();
  const Lattice lattice(64);
  const SampleGrid grid = SampleGrid::build(dem, Planet::mars(), lattice, 1);
  int looser = 0;
  for (const Diamond& d : diamondsOfLevel(lattice, 4, 3)) {
    const std::array<BinTriangle, 2> tri = {triangleOfNode(lattice, d[0], 4),
                                            triangleOfNode(lattice, d[1], 4)};
    DiamondLeaves kids(tri);
    for (std::size_t s = 0; s < 2; ++s) {
      const auto leaves = Lattice::children(tri[s]);
      for (std::size_t c = 0; c < 2; ++c) {
        WorkPatch& leaf = kids.leaves[s][c];
        leaf.sampleErrorMeters =
            measurePatch(grid, leaves[c], leaf, 1.0 / 64.0).triangleSampleErrors;
        ASSERT_EQ(leaf.sampleErrorMeters.size(), leaf.indices.size() / 3);
      }
    }
    const BlockResult block =
        simplifyBlock(grid, tri, kids.children, BlockTargets{200.0, 40, 65535});
    const std::array<const WorkPatch*, 2> halves = {&block.first, &block.second};
    for (std::size_t s = 0; s < 2; ++s) {
      const WorkPatch& patch = *halves[s];
      const std::array<const WorkPatch*, 2> children = {&kids.leaves[s][0], &kids.leaves[s][1]};
      const MeasuredPatch exact = measurePatch(grid, tri[s], patch, 1.0 / 64.0);
      const MeasuredPatch bound = measurePatchFromChildren(
          grid, tri[s], patch, children, 1.0 / 64.0, std::numeric_limits<double>::infinity());
      EXPECT_EQ(bound.trianglesMeasuredAgainstSamples, 0u);
      ASSERT_EQ(bound.triangleSampleErrors.size(), patch.indices.size() / 3);
      for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
        WorkPatch one;
        one.points = patch.points;
        one.indices = {patch.indices[k], patch.indices[k + 1], patch.indices[k + 2]};
        EXPECT_GE(static_cast<double>(bound.triangleSampleErrors[k / 3]),
                  sampleErrorByScan(grid, tri[s].face, one));
      }
      EXPECT_GE(bound.errorMeters, exact.errorMeters);
      if (bound.errorMeters > exact.errorMeters) ++looser;
      const MeasuredPatch doubted =
          measurePatchFromChildren(grid, tri[s], patch, children, 1.0 / 64.0, 0.0);
      EXPECT_EQ(doubted.trianglesMeasuredAgainstSamples, patch.indices.size() / 3);
      EXPECT_EQ(doubted.errorMeters, exact.errorMeters);
      EXPECT_EQ(doubted.triangleSampleErrors, exact.triangleSampleErrors);
    }
  }
  EXPECT_GT(looser, 0);  // the bound is an upper bound, not the measurement again
}

TEST(PatchBuilder, AFewTrianglesMeasuredAloneHaveTheErrorsOfTheWholePatch) {
  // A patch's few doubtful triangles are walked one by one over their own buckets, a whole
  // patch's in one binned walk over the samples under it: the two walks make the same visits,
  // so each triangle's sample error is the same double either way.
  const HeightGrid dem = roughDem();
  for (const std::uint32_t bucketCells : {1u, 4u}) {
    const SampleGrid grid = SampleGrid::build(dem, Planet::mars(), Lattice(64), bucketCells);
    int compared = 0;
    forEachBlockHalf(grid, [&](const BinTriangle& t, const WorkPatch& patch) {
      ASSERT_GE(patch.indices.size() / 3, 40u);
      const MeasuredPatch whole = measurePatch(grid, t, patch, 1.0 / 64.0);
      for (std::size_t k = 0; k < patch.indices.size() / 3; ++k) {
        const MeasuredPatch alone = measurePatch(grid, t, triangleAlone(patch, k), 1.0 / 64.0);
        ASSERT_EQ(alone.triangleSampleErrors.size(), 1u);
        EXPECT_EQ(alone.triangleSampleErrors[0], whole.triangleSampleErrors[k]);
        ++compared;
      }
    });
    EXPECT_GT(compared, 1000);
  }
}

TEST(PatchBuilder, SampleErrorAndSagAddPerTriangle) {
  // A point of a triangle is off by its sample error plus that triangle's own sag: the stored
  // error is the largest such sum, at most (and on rough data less than) the two maxima added.
  const HeightGrid dem = roughDem();
  const SampleGrid grid = SampleGrid::build(dem, Planet::mars(), Lattice(64), 1);
  int tighter = 0;
  forEachBlockHalf(grid, [&](const BinTriangle& t, const WorkPatch& patch) {
    const MeasuredPatch m = measurePatch(grid, t, patch, 1.0 / 64.0);
    double worst = 0.0;
    for (std::size_t k = 0; k < patch.indices.size() / 3; ++k) {
      const WorkPatch one = triangleAlone(patch, k);
      const double sag = measurePatch(grid, t, one, 1.0 / 64.0).chordErrorMeters;
      worst = std::max(worst, sampleErrorByScan(grid, t.face, one) + sag);
    }
    EXPECT_EQ(m.errorMeters, worst + m.representationErrorMeters);
    const double sumOfMaxima =
        m.sampleErrorMeters + m.chordErrorMeters + m.representationErrorMeters;
    EXPECT_LE(m.errorMeters, sumOfMaxima);
    if (m.errorMeters < sumOfMaxima) ++tighter;
  });
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

/// Checks that `patch` tiles the triangle `t` exactly: counter-clockwise triangles (in (u, v))
/// whose areas
/// add up to t's, every edge inside used by two triangles and on the outline by one (no
/// T-junction), and returns the vertices on each side of t: apex–left, apex–right, left–right.
std::array<std::size_t, 3> expectTiles(const BinTriangle& t, const WorkPatch& patch) {
  std::int64_t area = 0;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const std::array<std::uint32_t, 3> v{patch.indices[k], patch.indices[k + 1],
                                         patch.indices[k + 2]};
    const std::int64_t a = doubleArea(patch.points[v[0]], patch.points[v[1]], patch.points[v[2]]);
    EXPECT_GT(a, 0) << "triangle " << k / 3;  // counter-clockwise in (u, v)
    area += a;
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t p = v[static_cast<std::size_t>(e)],
                          q = v[static_cast<std::size_t>((e + 1) % 3)];
      ++edges[{std::min(p, q), std::max(p, q)}];
    }
  }
  EXPECT_EQ(area, std::abs(doubleArea(t.apex, t.left, t.right)));
  const auto onSide = [](LatticeXY a, LatticeXY b, LatticeXY p) {
    return doubleArea(a, b, p) == 0 && glm::min(a, b) == glm::min(glm::min(a, b), p) &&
           glm::max(a, b) == glm::max(glm::max(a, b), p);
  };
  for (const auto& [edge, uses] : edges) {
    const LatticeXY p = patch.points[edge.first], q = patch.points[edge.second];
    const bool outline = (onSide(t.apex, t.left, p) && onSide(t.apex, t.left, q)) ||
                         (onSide(t.apex, t.right, p) && onSide(t.apex, t.right, q)) ||
                         (onSide(t.left, t.right, p) && onSide(t.left, t.right, q));
    EXPECT_EQ(uses, outline ? 1 : 2);
  }
  std::array<std::size_t, 3> sides{};
  for (const LatticeXY& p : patch.points) {
    sides[0] += onSide(t.apex, t.left, p) ? 1U : 0U;
    sides[1] += onSide(t.apex, t.right, p) ? 1U : 0U;
    sides[2] += onSide(t.left, t.right, p) ? 1U : 0U;
  }
  return sides;
}

TEST(PatchBuilder, LeavesOfAnySpacingAndTheCoarseHypotenuseOfABorderLeaf) {
  const Lattice lattice(64);
  // A level-3 triangle: diagonal legs of 16 × 16 cells, an axis-aligned hypotenuse of 32.
  const BinTriangle odd = lattice.triangle(0, 0, 3, Lattice::firstIndexOfLevel(3) + 5);
  // At spacing 2: 8 steps along each leg, 16 along the hypotenuse; all points on the grid.
  const WorkPatch regular = makeLeafPatch(odd, 2);
  EXPECT_EQ(regular.indices.size(), 3u * 2u * 8u * 8u);
  for (const LatticeXY& p : regular.points) EXPECT_TRUE(p.x % 2 == 0 && p.y % 2 == 0);
  const auto regularSides = expectTiles(odd, regular);
  EXPECT_EQ(regularSides[0], 9u);
  EXPECT_EQ(regularSides[1], 9u);
  EXPECT_EQ(regularSides[2], 17u);
  // With a coarse hypotenuse: every other point of it, the legs unchanged, still a tiling.
  const WorkPatch border = makeLeafPatch(odd, 2, true);
  const auto borderSides = expectTiles(odd, border);
  EXPECT_EQ(borderSides[0], 9u);
  EXPECT_EQ(borderSides[1], 9u);
  EXPECT_EQ(borderSides[2], 9u);
  EXPECT_EQ(border.points.size(), regular.points.size() - 8u);
  // Spacing 1 is the single-cell leaf of the uniform forest.
  const BinTriangle even = lattice.triangle(0, 0, 4, Lattice::firstIndexOfLevel(4) + 3);
  const WorkPatch cells = makeLeafPatch(even, 1);
  EXPECT_EQ(cells.indices.size(), 3u * 16u * 16u);
  const auto cellSides = expectTiles(even, cells);
  EXPECT_EQ(cellSides[0], 17u);
  EXPECT_EQ(cellSides[2], 17u);
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
