// Patch construction for P-BDAM ([P-BDAM 2003] §5 "Out-of-core Geometric Simplification";
// docs/builder.md "Patches"): regular leaf patches, the simplification of one block (the four
// children of a diamond) into the diamond's two patches by greedy insertion, and the measurement
// and encoding of a patch (exact barycentrics, quantised lattice heights,
// error against lattice and source samples, bounding sphere). Thread-safety: free functions on
// their own data; SampleGrid is read-only, so blocks may be processed concurrently.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/PatchCodec.h"

namespace pbdam::builder {

/// A patch while it is being built: lattice points of its face and a CCW (in (u,v)) triangle
/// list indexing them.
struct WorkPatch final {
  std::vector<runtime::LatticeXY> points;
  std::vector<std::uint32_t> indices;
  /// Once measured: per triangle, an upper bound (metres) of |patch − sample| over the lattice
  /// and source samples inside or on it — what the parent's error is bounded through.
  std::vector<float> sampleErrorMeters;
};

/// The regular triangulation of a leaf triangle: its longest-edge bisection down to triangles
/// with axis-aligned legs of `spacing` lattice cells (a power of two; 1: single cells), so every
/// point of the lattice of that spacing inside or on the triangle is a vertex. With
/// `coarseHypotenuse` the triangles whose hypotenuse lies on the leaf's hypotenuse and spans
/// two spacings are not split: the hypotenuse keeps every other point, the vertices of the
/// coarser leaf's leg it lies on (an odd-level leaf of an adaptive forest whose diamond partner
/// does not exist; docs/builder.md "Insets: leaves at the border").
WorkPatch makeLeafPatch(const runtime::BinTriangle& triangle, std::int32_t spacing = 1,
                        bool coarseHypotenuse = false);

/// What happened in one block.
struct BlockStats final {
  std::uint32_t diagonalPoints = 0;    ///< lattice points on the block diagonal
  std::uint32_t diagonalKept = 0;      ///< of which the diagonal keeps as vertices
  std::uint32_t insertedPoints = 0;    ///< interior points inserted into the two halves
  std::uint32_t halvesOverTarget = 0;  ///< halves that stopped at the vertex limit above target
};

/// How far a block is refined (docs/builder.md "Patches").
struct BlockTargets final {
  /// Every triangle's height error plus chord sag at most this (metres) …
  double latticeErrorMeters = 0.0;
  /// … and at least this many triangles per half, unless the half is exact with fewer …
  std::uint32_t minTriangles = 512;
  /// … but never more vertices than this (16-bit indices).
  std::uint32_t maxVertices = 65535;
};

/// The two patches of a diamond, built from its block.
struct BlockResult final {
  WorkPatch first;   ///< patch of `triangles[0]`
  WorkPatch second;  ///< patch of `triangles[1]`
  BlockStats stats;
};

/// Builds the patches of the diamond (triangles[0], triangles[1]) — two bintree triangles that
/// share their hypotenuse, possibly on different faces — whose legs keep the vertices their
/// children's patches have on their hypotenuses (children[0] are triangles[0]'s, children[1]
/// triangles[1]'s; only those points are read). The shared diagonal is refined first, by greedy
/// insertion of its lattice points to the target; then each half by greedy insertion of its
/// interior lattice points into a Delaunay triangulation (Garland & Heckbert 1995) until
/// `targets` hold.
BlockResult simplifyBlock(const SampleGrid& grid,
                          const std::array<runtime::BinTriangle, 2>& triangles,
                          const std::array<std::array<const WorkPatch*, 2>, 2>& children,
                          const BlockTargets& targets);

/// The points of `patch` on the hypotenuse of `triangle` (its ends included), in patch order:
/// what the parent's block keeps of a child.
std::vector<runtime::LatticeXY> hypotenusePoints(const runtime::BinTriangle& triangle,
                                                 const WorkPatch& patch);

/// The corner data of a node: terrain positions (double), surface normals (float-rounded, as
/// stored), in the order apex, left, right.
struct NodeCorners final {
  std::array<glm::dvec3, 3> positions{};
  std::array<glm::vec3, 3> normals{};
};
NodeCorners nodeCorners(const SampleGrid& grid, const runtime::BinTriangle& triangle);

/// A measured, encodable patch.
struct MeasuredPatch final {
  formats::PatchMesh mesh;         ///< exact barycentrics and quantised lattice heights
  double sampleErrorMeters = 0.0;  ///< max |patch − sample| over lattice and source samples
  /// the vertices' height quantisation plus the float rounding of their GPU offsets: every
  /// vertex is drawn at its terrain point (docs/builder.md "Errors")
  double representationErrorMeters = 0.0;
  double chordErrorMeters = 0.0;  ///< max sag of its flat triangles below the planet (R_min)
  /// the largest sample error plus sag over its triangles (both bound the same point), plus the
  /// representation error
  double errorMeters = 0.0;
  glm::dvec3 sphereCenter{0.0};  ///< bounding sphere of the rendered vertices
  double sphereRadiusMeters = 0.0;
  double minHeightMeters = 0.0;  ///< over its vertices
  double maxHeightMeters = 0.0;
  /// Per triangle of the patch (its WorkPatch order), the sample error bound, rounded up to
  /// float: what WorkPatch::sampleErrorMeters carries to the parent.
  std::vector<float> triangleSampleErrors;
  std::uint32_t trianglesMeasuredAgainstSamples = 0;  ///< by the samples, not the children
};

/// Measures `patch` of `triangle` (docs/builder.md "Errors") and converts it to the stored
/// representation with `heightStepMeters` quantisation.
MeasuredPatch measurePatch(const SampleGrid& grid, const runtime::BinTriangle& triangle,
                           const WorkPatch& patch, double heightStepMeters);

/// As measurePatch, with the sample error of each triangle bounded through the two children
/// that tile `triangle` (their WorkPatch::sampleErrorMeters; PatchBound.h) rather than read from
/// the samples; only a triangle whose bound plus sag plus the representation error exceeds
/// `targetMeters` (the error the diamond will store anyway) is measured against its samples,
/// keeping the smaller of the two. Either is an upper bound of the true sample error.
MeasuredPatch measurePatchFromChildren(const SampleGrid& grid, const runtime::BinTriangle& triangle,
                                       const WorkPatch& patch,
                                       const std::array<const WorkPatch*, 2>& children,
                                       double heightStepMeters, double targetMeters);

/// The coarsest lattice spacing a patch of node `triangle` considers: 1 on a dense lattice; on a
/// sparse one the power of two at most 1/512 of the triangle's extent, so that a coarse patch
/// over an inset does not scan the inset's every point at every level (its candidates stay
/// about 512 per leg, as a complete build's patch of a 512-cell leg has). The stored error
/// still bounds every source sample: those are measured in full.
std::int32_t candidateSpacing(const SampleGrid& grid, const runtime::BinTriangle& triangle);

/// The height of the patch surface (piecewise-linear over (u,v) in the vertices' lattice
/// heights) at every lattice point it covers is compared with the grid; this is the maximum.
/// Exposed for verify.
double maxLatticeDeviation(const SampleGrid& grid, int face, const WorkPatch& patch);

}  // namespace pbdam::builder
