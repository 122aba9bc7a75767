// View-dependent refinement (docs/architecture.md "Refinement and drawing", paper 004 §4.3): a
// stateless top-down walk of the 12 bintrees that yields the cut — the patches to draw, each with
// the texture tile it is drawn with. A node is split while its screen-space error exceeds the
// tolerance and it is not a leaf (a flag of its record: leaves may lie at any level); nodes whose
// bounding sphere is outside the frustum are dropped.
//
// The error of a node is max(geometry error, texture term). The geometry error is the builder's
// saturated error (equal for both triangles of a diamond, parent ≥ child) and the bounding
// spheres are shared by diamond partners and nested, so the split decision is the same for both
// triangles of a diamond and implies the parents' split: every cut is conforming, with no
// neighbour bookkeeping. The texture term keeps that property: a patch of level L is drawn with
// the tile of level t = min(L/2, T−1) that contains it (DatasetView::tileOf), and while a finer
// tile level exists its term is the largest texture error of level t over the whole dataset — a
// function of the level only, so diamond partners agree, and it halves per tile level, so it
// nests (docs/decisions.md "Refinement"). Thread-safety: pure; the same camera always gives the
// same cut.
#pragma once

#include <cstdint>
#include <vector>

#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::runtime {

struct RefinementOptions final {
  double tolerancePixels = 3.0;
  /// Drop nodes outside the frustum. Off, the cut covers the whole planet (watertight tests).
  bool frustumCulling = true;
  /// Do not refine below this level (−1: the leaves). Used to draw coarser cuts.
  int maxLevel = -1;
};

/// One patch of a cut.
struct CutPatch final {
  NodeKey node;
  int level = 0;
  TileKey tile;                    ///< the texture tile it is drawn with
  float screenErrorPixels = 0.0f;  ///< of max(geometry error, texture term), at its sphere
};

struct Cut final {
  std::vector<CutPatch> patches;  ///< depth-first order of the 12 trees
  std::vector<TileKey> tiles;     ///< distinct tiles of the patches, in first-use order
  std::uint64_t triangles = 0;
  std::uint64_t vertices = 0;
  std::uint64_t nodesVisited = 0;
  std::uint64_t nodesCulled = 0;
};

/// The refinement criterion's error for a node of `level` whose saturated geometry error is
/// `geometryErrorMeters` (see the file comment).
double refinementErrorMeters(const DatasetView& dataset, int level,
                             double geometryErrorMeters) noexcept;

/// Computes the cut of `dataset` for `camera`.
Cut refine(const DatasetView& dataset, const Camera& camera, const RefinementOptions& options);

}  // namespace pbdam::runtime
