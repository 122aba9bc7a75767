// Block simplification by greedy insertion: the diamond's shared diagonal first, then each half
// (PatchBuilder.h; GreedyInsertion.h; docs/builder.md "Patches").
#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <numeric>

#include "GreedyInsertion.h"
#include "pbdam/builder/PatchBuilder.h"

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// The lattice points of the segment from → to, evenly spaced `spacing` lattice steps apart.
struct LatticeSegment {
  std::vector<LatticeXY> points;
  double stepCells = 1.0;
};

LatticeSegment latticeSegment(LatticeXY from, LatticeXY to, std::int32_t spacing) {
  const LatticeXY d = to - from;
  const int steps = std::gcd(std::abs(d.x), std::abs(d.y)) / spacing;
  assert(steps > 0);
  const LatticeXY step = d / steps;
  LatticeSegment s;
  s.stepCells = std::hypot(static_cast<double>(step.x), static_cast<double>(step.y));
  s.points.reserve(static_cast<std::size_t>(steps) + 1);
  for (int k = 0; k <= steps; ++k) s.points.push_back(from + step * k);
  return s;
}

/// The sag of flat triangles on this planet: the mean cell size and the smallest radius the
/// terrain reaches (as the measurement's chord bound uses).
ChordModel chordModel(const SampleGrid& grid) {
  const Planet& planet = grid.planet();
  return ChordModel{
      0.5 * std::numbers::pi * planet.equatorialRadiusMeters() /
          static_cast<double>(grid.lattice().sideCells()),
      std::max(1.0, planet.polarRadiusMeters() + static_cast<double>(grid.minHeightMeters()))};
}

/// The coarsest spacing of the tiles a triangle's box reaches: the diagonal of a diamond takes
/// the points both its triangles' tiles store (1 on a dense lattice).
std::int32_t coarsestSpacing(const LatticeTiles& tiles, const BinTriangle& t) {
  return tiles.coarsestSpacingIn(
      t.face, std::min({t.apex.x, t.left.x, t.right.x}), std::min({t.apex.y, t.left.y, t.right.y}),
      std::max({t.apex.x, t.left.x, t.right.x}), std::max({t.apex.y, t.left.y, t.right.y}));
}

}  // namespace

std::vector<LatticeXY> hypotenusePoints(const BinTriangle& triangle, const WorkPatch& patch) {
  std::vector<LatticeXY> out;
  const LatticeXY dir = triangle.right - triangle.left;
  const std::int64_t len2 = std::int64_t{dir.x} * dir.x + std::int64_t{dir.y} * dir.y;
  for (const LatticeXY p : patch.points) {
    if (doubleArea(triangle.left, triangle.right, p) != 0) continue;
    const LatticeXY d = p - triangle.left;
    const std::int64_t s = std::int64_t{d.x} * dir.x + std::int64_t{d.y} * dir.y;
    if (s >= 0 && s <= len2) out.push_back(p);
  }
  return out;
}

BlockResult simplifyBlock(const SampleGrid& grid, const std::array<BinTriangle, 2>& triangles,
                          const std::array<std::array<const WorkPatch*, 2>, 2>& children,
                          const BlockTargets& targets) {
  BlockResult result;
  const ChordModel chord = chordModel(grid);
  const BinTriangle& ta = triangles[0];
  const BinTriangle& tb = triangles[1];
  // The diagonal: ta's left–right is tb's right–left (the same lattice points, maybe on another
  // face, where they have the same heights).
  const std::int32_t candidates = candidateSpacing(grid, ta);
  const std::int32_t spacing =
      std::max({coarsestSpacing(grid.tiles(), ta), coarsestSpacing(grid.tiles(), tb), candidates});
  const LatticeSegment da = latticeSegment(ta.left, ta.right, spacing);
  const LatticeSegment db = latticeSegment(tb.left, tb.right, spacing);
  assert(da.points.size() == db.points.size());
  assert(grid.lattice().key(ta.face, da.points.front()) ==
         grid.lattice().key(tb.face, db.points.back()));
  std::vector<double> heights(da.points.size());
  for (std::size_t k = 0; k < heights.size(); ++k) {
    heights[k] = static_cast<double>(grid.height(ta.face, da.points[k]));
  }
  const std::vector<std::size_t> kept =
      insertAlongSegment(heights, da.stepCells, targets.latticeErrorMeters, chord);
  result.stats.diagonalPoints = static_cast<std::uint32_t>(da.points.size());
  result.stats.diagonalKept = static_cast<std::uint32_t>(kept.size());

  const std::size_t last = db.points.size() - 1;
  const InsertionLimits limits{targets.latticeErrorMeters, targets.minTriangles,
                               targets.maxVertices, candidates};
  std::array<WorkPatch*, 2> out = {&result.first, &result.second};
  for (std::size_t s = 0; s < 2; ++s) {
    const BinTriangle& t = triangles[s];
    std::vector<LatticeXY> boundary;
    boundary.reserve(kept.size() + da.points.size());
    for (const std::size_t k : kept)
      boundary.push_back(s == 0 ? da.points[k] : db.points[last - k]);
    for (std::size_t c = 0; c < 2; ++c) {
      const auto kids = Lattice::children(t);
      const std::vector<LatticeXY> leg = hypotenusePoints(kids[c], *children[s][c]);
      boundary.insert(boundary.end(), leg.begin(), leg.end());
    }
    const FaceHeights heightsOfFace = grid.heightsOf(t.face);
    InsertionResult half =
        insertGreedily(heightsOfFace, {t.apex, t.left, t.right}, boundary, limits, chord);
    result.stats.insertedPoints += half.insertedPoints;
    if (half.maxErrorMeters > targets.latticeErrorMeters &&
        half.patch.points.size() >= targets.maxVertices) {
      ++result.stats.halvesOverTarget;
    }
    *out[s] = std::move(half.patch);
  }
  return result;
}

}  // namespace pbdam::builder
