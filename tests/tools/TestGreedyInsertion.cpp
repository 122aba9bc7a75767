// Greedy insertion (GreedyInsertion.h) checked against its definition by brute force: the
// result is a Delaunay triangulation of the lattice triangle that keeps every locked boundary
// point, every covered lattice point is within the target, the 512-triangle floor and the vertex
// cap hold, and degenerate height fields (flat, one spike, extreme slopes) behave.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "GreedyInsertion.h"
#include "pbdam/builder/Lattice.h"

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// A square lattice of (n + 1)² heights.
struct Field {
  std::uint32_t n = 0;
  std::vector<float> heights;
  explicit Field(std::uint32_t cells) : n(cells), heights(std::size_t{cells + 1} * (cells + 1)) {}
  float& at(int x, int y) { return heights[index(x, y)]; }
  double h(LatticeXY p) const { return static_cast<double>(heights[index(p.x, p.y)]); }
  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * (n + 1) + static_cast<std::size_t>(x);
  }
  FaceHeights view() const { return FaceHeights{heights.data(), n}; }
};

Field roughField(std::uint32_t n, std::uint32_t seed, float amplitude) {
  Field f(n);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-amplitude, amplitude);
  for (int y = 0; y <= static_cast<int>(n); ++y) {
    for (int x = 0; x <= static_cast<int>(n); ++x) {
      f.at(x, y) = 2000.0f * std::sin(0.21f * static_cast<float>(x)) *
                       std::cos(0.13f * static_cast<float>(y)) +
                   noise(rng);
    }
  }
  return f;
}

/// Every lattice point on the segment a–b.
std::vector<LatticeXY> segmentPoints(LatticeXY a, LatticeXY b) {
  const LatticeXY d = b - a;
  const int steps = std::max(std::abs(d.x), std::abs(d.y));
  std::vector<LatticeXY> out;
  for (int k = 0; k <= steps; ++k) out.push_back(a + d / steps * k);
  return out;
}

/// The largest |height − linear interpolation| over every lattice point inside or on each
/// triangle of `patch`, by scanning bounding boxes.
double maxDeviationByScan(const Field& f, const WorkPatch& patch) {
  double worst = 0.0;
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY a = patch.points[patch.indices[k]];
    const LatticeXY b = patch.points[patch.indices[k + 1]];
    const LatticeXY c = patch.points[patch.indices[k + 2]];
    const std::int64_t total = doubleArea(a, b, c);
    for (int y = std::min({a.y, b.y, c.y}); y <= std::max({a.y, b.y, c.y}); ++y) {
      for (int x = std::min({a.x, b.x, c.x}); x <= std::max({a.x, b.x, c.x}); ++x) {
        const LatticeXY p{x, y};
        const std::int64_t w0 = doubleArea(b, c, p);
        const std::int64_t w1 = doubleArea(c, a, p);
        const std::int64_t w2 = doubleArea(a, b, p);
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double h = (static_cast<double>(w0) * f.h(a) + static_cast<double>(w1) * f.h(b) +
                          static_cast<double>(w2) * f.h(c)) /
                         static_cast<double>(total);
        worst = std::max(worst, std::abs(h - f.h(p)));
      }
    }
  }
  return worst;
}

/// Positive triangles that tile the corner triangle exactly, with no vertex strictly inside
/// another triangle's circumcircle (Delaunay), and every locked point a vertex.
void expectDelaunayTiling(const WorkPatch& patch, const std::array<LatticeXY, 3>& corners,
                          const std::vector<LatticeXY>& locked) {
  ASSERT_EQ(patch.indices.size() % 3, 0u);
  std::int64_t area = 0;
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY a = patch.points[patch.indices[k]];
    const LatticeXY b = patch.points[patch.indices[k + 1]];
    const LatticeXY c = patch.points[patch.indices[k + 2]];
    const std::int64_t twice = doubleArea(a, b, c);
    ASSERT_GT(twice, 0) << "triangle " << k / 3 << " is not counter-clockwise";
    area += twice;
    for (const LatticeXY d : patch.points) {
      const double adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y,
                   cdx = c.x - d.x, cdy = c.y - d.y;
      const double det = (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
                         (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
                         (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
      EXPECT_LE(det, 0.0) << "point (" << d.x << ", " << d.y << ") inside the circumcircle";
    }
  }
  EXPECT_EQ(area, std::abs(doubleArea(corners[0], corners[1], corners[2])));
  for (const LatticeXY p : locked) {
    EXPECT_NE(std::find(patch.points.begin(), patch.points.end(), p), patch.points.end())
        << "locked point (" << p.x << ", " << p.y << ") lost";
  }
}

/// The test triangle: a right triangle with 32-cell legs.
std::array<LatticeXY, 3> corners32() {
  return {LatticeXY{0, 0}, LatticeXY{0, 32}, LatticeXY{32, 0}};
}

/// Every lattice point of the three edges: then every covered point is checked by the target.
std::vector<LatticeXY> wholeBoundary() {
  std::vector<LatticeXY> b;
  for (std::size_t e = 0; e < 3; ++e) {
    const auto s = segmentPoints(corners32()[e], corners32()[(e + 1) % 3]);
    b.insert(b.end(), s.begin(), s.end());
  }
  return b;
}

TEST(GreedyInsertion, RoughFieldReachesTheTargetWithADelaunayTiling) {
  const Field f = roughField(32, 7, 30.0f);
  const auto boundary = wholeBoundary();
  for (const double target : {200.0, 50.0, 5.0}) {
    const InsertionResult r =
        insertGreedily(f.view(), corners32(), boundary, InsertionLimits{target, 0, 65535}, {});
    expectDelaunayTiling(r.patch, corners32(), boundary);
    EXPECT_LE(maxDeviationByScan(f, r.patch), target);
    EXPECT_LE(r.maxErrorMeters, target);
    EXPECT_GT(r.insertedPoints, 0u);
  }
}

TEST(GreedyInsertion, FinerTargetsNeedMoreTriangles) {
  const Field f = roughField(32, 11, 30.0f);
  const auto boundary = wholeBoundary();
  std::size_t previous = 0;
  for (const double target : {400.0, 100.0, 25.0, 1.0}) {
    const InsertionResult r =
        insertGreedily(f.view(), corners32(), boundary, InsertionLimits{target, 0, 65535}, {});
    EXPECT_GT(r.patch.indices.size(), previous) << "target " << target;
    previous = r.patch.indices.size();
  }
}

TEST(GreedyInsertion, FlatFieldKeepsOnlyTheBoundaryEvenBelowTheTriangleFloor) {
  Field f(32);
  std::fill(f.heights.begin(), f.heights.end(), 1234.0f);
  const std::vector<LatticeXY> boundary = {{0, 8}, {0, 16}, {8, 0}, {16, 16}};
  const InsertionResult r =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{0.0, 512, 65535}, {});
  expectDelaunayTiling(r.patch, corners32(), boundary);
  EXPECT_EQ(r.insertedPoints, 0u);
  EXPECT_EQ(r.patch.points.size(), 3u + boundary.size());
  EXPECT_EQ(r.maxErrorMeters, 0.0);
}

TEST(GreedyInsertion, ASpikeIsInsertedFirst) {
  Field f(32);
  std::fill(f.heights.begin(), f.heights.end(), 0.0f);
  f.at(9, 13) = 8000.0f;
  const auto boundary = wholeBoundary();
  const InsertionResult first =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{7999.0, 0, 65535}, {});
  EXPECT_EQ(first.insertedPoints, 1u);
  EXPECT_EQ(first.patch.points.back(), LatticeXY(9, 13));
  // Then its neighbours, which the spike's triangles lift, until the field is exact.
  const InsertionResult exact =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{0.0, 0, 65535}, {});
  EXPECT_EQ(exact.patch.points[96], LatticeXY(9, 13));  // after the 96 boundary points
  EXPECT_LE(exact.insertedPoints, 9u);
  EXPECT_EQ(maxDeviationByScan(f, exact.patch), 0.0);
}

TEST(GreedyInsertion, ExtremeSlopesStayValid) {
  Field f(32);
  for (int y = 0; y <= 32; ++y) {
    for (int x = 0; x <= 32; ++x) {
      // A cliff: 9 km up between two columns, on a steep ramp.
      f.at(x, y) = 250.0f * static_cast<float>(y) + (x > 11 ? 9000.0f : -2000.0f);
    }
  }
  const auto boundary = wholeBoundary();
  const InsertionResult r =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{0.5, 0, 65535}, {});
  expectDelaunayTiling(r.patch, corners32(), boundary);
  EXPECT_LE(maxDeviationByScan(f, r.patch), 0.5);
}

TEST(GreedyInsertion, TheTriangleFloorAndTheVertexCapHold) {
  const Field f = roughField(32, 3, 30.0f);
  const auto triangle = corners32();
  const std::vector<LatticeXY> corners(triangle.begin(), triangle.end());
  const InsertionResult floor =
      insertGreedily(f.view(), corners32(), corners, InsertionLimits{1e9, 100, 65535}, {});
  EXPECT_GE(floor.patch.indices.size() / 3, 100u);
  EXPECT_LT(floor.patch.indices.size() / 3, 104u);  // stops as soon as the floor is reached
  const InsertionResult capped =
      insertGreedily(f.view(), corners32(), corners, InsertionLimits{0.0, 0, 40}, {});
  EXPECT_EQ(capped.patch.points.size(), 40u);
  EXPECT_GT(capped.maxErrorMeters, 0.0);
  expectDelaunayTiling(capped.patch, corners32(), corners);
}

TEST(GreedyInsertion, ChordSagIsRefinedOnAFlatField) {
  Field f(32);
  std::fill(f.heights.begin(), f.heights.end(), 0.0f);
  // 10 km cells on a 3,000 km sphere: one triangle of 32 cells sags 17 km.
  const ChordModel chord{10000.0, 3.0e6};
  const auto boundary = wholeBoundary();
  const InsertionResult r =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{100.0, 0, 65535}, chord);
  EXPECT_GT(r.insertedPoints, 0u);
  EXPECT_LE(r.maxErrorMeters, 100.0);
  for (std::size_t k = 0; k < r.patch.indices.size(); k += 3) {
    // Every triangle's longest edge c sags at least c²/8R somewhere: bounded by the target.
    double longest = 0.0;
    for (std::size_t e = 0; e < 3; ++e) {
      const LatticeXY a = r.patch.points[r.patch.indices[k + e]];
      const LatticeXY b = r.patch.points[r.patch.indices[k + (e + 1) % 3]];
      longest = std::max(longest, std::hypot(a.x - b.x, a.y - b.y) * chord.metresPerCell);
    }
    EXPECT_LE(longest * longest / (8.0 * chord.radiusMeters), 100.0);
  }
}

TEST(GreedyInsertion, SameInputGivesTheSameTriangulationWhateverTheBoundaryOrder) {
  const Field f = roughField(32, 5, 30.0f);
  auto boundary = wholeBoundary();
  const InsertionResult a =
      insertGreedily(f.view(), corners32(), boundary, InsertionLimits{20.0, 64, 65535}, {});
  std::reverse(boundary.begin(), boundary.end());
  boundary.insert(boundary.end(), boundary.begin(), boundary.begin() + 5);  // duplicates
  const std::array<LatticeXY, 3> clockwise = {corners32()[0], corners32()[2], corners32()[1]};
  const InsertionResult b =
      insertGreedily(f.view(), clockwise, boundary, InsertionLimits{20.0, 64, 65535}, {});
  EXPECT_EQ(a.patch.points, b.patch.points);
  EXPECT_EQ(a.patch.indices, b.patch.indices);
}

TEST(GreedyInsertion, DiagonalTrianglesOfEveryOrientation) {
  // Odd bintree levels have diagonal legs and an axis-aligned hypotenuse.
  const Field f = roughField(32, 9, 30.0f);
  const std::array<std::array<LatticeXY, 3>, 4> triangles = {{
      {LatticeXY{16, 16}, LatticeXY{0, 0}, LatticeXY{32, 0}},
      {LatticeXY{16, 16}, LatticeXY{32, 0}, LatticeXY{32, 32}},
      {LatticeXY{16, 16}, LatticeXY{32, 32}, LatticeXY{0, 32}},
      {LatticeXY{16, 16}, LatticeXY{0, 32}, LatticeXY{0, 0}},
  }};
  for (const auto& t : triangles) {
    std::vector<LatticeXY> boundary;
    for (std::size_t e = 0; e < 3; ++e) {
      const auto s = segmentPoints(t[e], t[(e + 1) % 3]);
      boundary.insert(boundary.end(), s.begin(), s.end());
    }
    const InsertionResult r =
        insertGreedily(f.view(), t, boundary, InsertionLimits{10.0, 0, 65535}, {});
    expectDelaunayTiling(r.patch, t, boundary);
    EXPECT_LE(maxDeviationByScan(f, r.patch), 10.0);
  }
}

TEST(GreedyInsertion, LargeHalvesStartCoarseAndStillMeetTheTargetExactly) {
  // 131,841 lattice points: the first insertions choose among every 4th point of each axis.
  const Field f = roughField(512, 13, 10.0f);
  const std::array<LatticeXY, 3> corners = {LatticeXY{0, 0}, LatticeXY{512, 0}, LatticeXY{0, 512}};
  std::vector<LatticeXY> boundary;
  for (std::size_t e = 0; e < 3; ++e) {
    const auto s = segmentPoints(corners[e], corners[(e + 1) % 3]);
    boundary.insert(boundary.end(), s.begin(), s.end());
  }
  const InsertionResult r =
      insertGreedily(f.view(), corners, boundary, InsertionLimits{40.0, 0, 65535}, {});
  EXPECT_LE(maxDeviationByScan(f, r.patch), 40.0);
  EXPECT_LE(r.maxErrorMeters, 40.0);
  // Points off the coarse strides were inserted too: the last pass looks at every point.
  EXPECT_TRUE(std::any_of(r.patch.points.begin(), r.patch.points.end(),
                          [](LatticeXY p) { return p.x % 2 != 0 || p.y % 2 != 0; }));
}

TEST(GreedyInsertion, SegmentKeepsItsEndsAndMeetsTheTarget) {
  std::vector<double> h(65);
  for (std::size_t k = 0; k < h.size(); ++k) h[k] = 300.0 * std::sin(0.4 * static_cast<double>(k));
  for (const double target : {100.0, 10.0, 0.0}) {
    const auto kept = insertAlongSegment(h, 1.0, target, {});
    ASSERT_GE(kept.size(), 2u);
    EXPECT_EQ(kept.front(), 0u);
    EXPECT_EQ(kept.back(), h.size() - 1);
    for (std::size_t s = 0; s + 1 < kept.size(); ++s) {
      const std::size_t a = kept[s];
      const std::size_t b = kept[s + 1];
      for (std::size_t k = a + 1; k < b; ++k) {
        const double t = static_cast<double>(k - a) / static_cast<double>(b - a);
        EXPECT_LE(std::abs(h[k] - (h[a] + t * (h[b] - h[a]))), target + 1e-9);
      }
    }
  }
  const std::vector<double> flat(9, 5.0);
  EXPECT_EQ(insertAlongSegment(flat, 1.0, 0.0, {}).size(), 2u);
}

}  // namespace
}  // namespace pbdam::builder
