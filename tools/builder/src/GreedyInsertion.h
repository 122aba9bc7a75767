// Error-driven TIN construction by greedy insertion (Garland & Heckbert, "Fast polygonal
// approximation of terrains and height fields", 1995: the Delaunay greedy-insertion method of
// their terra): a lattice triangle with its boundary vertices locked is triangulated (Delaunay,
// exact integer predicates), then the lattice point of largest error is inserted, again and
// again, until every triangle is within the target. Private to the builder
// (docs/builder.md "Patches").
//
// A triangle's error is the largest |height − plane| over the lattice points it covers plus its
// chord bound (the sag of a flat triangle below the planet's surface); its candidate is the point
// where height error and sag together are largest. Lattice points on the locked boundary are
// never inserted. Each triangle is scanned once when it is made, so a point is rescanned only
// when the triangle around it changes. Deterministic: no hashing, no floating-point ties broken
// by address; the same input gives the same triangulation on any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/builder/PatchBuilder.h"

namespace pbdam::builder {

/// The sag of flat triangles below the planet's surface, in metres: a triangle with
/// circumradius rc (lattice cells) lies (rc² − d²)·metresPerCell²/(2·radius) below the sphere
/// through its corners at distance d from its circumcentre. `radiusMeters` 0 turns it off.
struct ChordModel final {
  double metresPerCell = 1.0;
  double radiusMeters = 0.0;
};

/// When the insertion stops: as soon as every triangle's error is at most `targetMeters` and
/// there are at least `minTriangles` triangles, when nothing is left to insert (every covered
/// lattice point is a vertex, or all errors are 0), or at `maxVertices` vertices.
struct InsertionLimits final {
  double targetMeters = 0.0;
  std::uint32_t minTriangles = 0;
  std::uint32_t maxVertices = 65535;
  /// Candidates are the lattice points whose coordinates are multiples of this (a power of
  /// two): the last pass scans at this stride instead of every point.
  std::int32_t spacing = 1;
};

struct InsertionResult final {
  WorkPatch patch;              ///< CCW in (u, v); the boundary points first, in their order
  double maxErrorMeters = 0.0;  ///< the largest triangle error left (height error + chord)
  std::uint32_t insertedPoints = 0;
};

/// Triangulates the lattice triangle `corners` (any winding; positive area) whose edges carry
/// the locked points `boundary` (every one on an edge, corners included or not; duplicates
/// allowed), inserting interior lattice points greedily until `limits` hold.
InsertionResult insertGreedily(const FaceHeights& heights,
                               const std::array<runtime::LatticeXY, 3>& corners,
                               std::span<const runtime::LatticeXY> boundary,
                               const InsertionLimits& limits, const ChordModel& chord);

/// The 1-D analogue for a lattice segment: heights[k] at evenly spaced points k = 0..n (n ≥ 1)
/// `stepCells` apart. Returns the sorted indices of the points kept — both ends and, greedily,
/// the point of largest error (|height − linear| plus the chord's sag) until every point is
/// within `targetMeters`.
std::vector<std::size_t> insertAlongSegment(std::span<const double> heights, double stepCells,
                                            double targetMeters, const ChordModel& chord);

}  // namespace pbdam::builder
