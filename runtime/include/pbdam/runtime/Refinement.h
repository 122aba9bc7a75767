// View-dependent refinement (docs/architecture.md "Refinement and drawing", [P-BDAM 2003] §4.3): a
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
// nests (docs/decisions.md "Refinement"); since dataset format 4 the term is per bintree level,
// saturated with the dataset's error margin (DatasetView::textureTermOfLevel), so that every
// parent's error is at least (1 + r) times its children's and the geomorph's windows of
// successive levels stay apart. Each drawn patch carries the geomorph weights of its parent's
// and grandparent's diamonds (docs/architecture.md "Geomorphing"). Thread-safety: pure; the same
// camera always gives the same cut.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_set>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::runtime {

/// How refine() chooses a cut: the screen-space tolerance, culling, a level limit, the geomorph
/// window and no-stall refinement.
struct RefinementOptions final {
  /// τ: a node is refined while its screen-space error exceeds this many pixels.
  double tolerancePixels = 3.0;
  /// Drop nodes outside the frustum. Off, the cut covers the whole planet (watertight tests).
  bool frustumCulling = true;
  /// Do not refine below this level (−1: the leaves). Used to draw coarser cuts.
  int maxLevel = -1;
  /// The geomorph window (docs/architecture.md "Geomorphing"), a fraction m of the tolerance:
  /// a diamond's children are drawn at its surface where its screen error is τ and at their
  /// own from τ·(1 + m) on. 0 turns morphing off. At most the dataset's error margin, which
  /// keeps the windows of successive levels apart (checkMorphRange).
  double morphRange = 0.25;
  /// Descend only into children whose node records can be read without a disk read
  /// (FaceView::nodeRecordResident: always, unless the node tables are paged): no-stall
  /// refinement on the render thread. Where a node's children are not, it stays in the cut and
  /// Cut::unresidentRecordLevel says at which level records were missing.
  bool residentRecordsOnly = false;
  /// Vertical exaggeration F (finite, > 0): the terrain is drawn with its heights times F, and
  /// the nodes' errors and bounding spheres are widened to match (exaggerationBounds). 1 gives
  /// the cuts of the true terrain, bit for bit.
  double exaggeration = 1.0;
};

/// How vertical exaggeration F widens every node's refinement bounds. Exaggeration moves a
/// terrain point T(h) to T(F·h), |F − 1|·|h| along the surface normal: each bounding sphere
/// grows by |F − 1| times the dataset's largest |height| (the same for every node, so spheres
/// stay nested and shared by diamond partners, and cuts stay conforming), and each object-space
/// error scales by max(F, 1) (vertical differences scale by F, horizontal ones not at all), so
/// errors stay nested too. At F = 1 both are identities on the doubles.
struct ExaggerationBounds final {
  double errorScale = 1.0;          ///< max(F, 1)
  double radiusGrowthMeters = 0.0;  ///< |F − 1| · max(|lowest height|, |highest height|)
};
/// The bounds of `exaggeration` on `dataset` (its manifest's height range).
ExaggerationBounds exaggerationBounds(const DatasetView& dataset, double exaggeration) noexcept;

/// A node's bounding sphere and refinement error as refinement uses them: the record's,
/// widened by exaggerationBounds.
struct RefinementBounds final {
  glm::dvec3 centre{0.0};     ///< the sphere's centre (the record's)
  double radiusMeters = 0.0;  ///< the record's radius + radiusGrowthMeters
  double errorMeters = 0.0;   ///< refinementErrorMeters · errorScale
};

/// One patch of a cut.
struct CutPatch final {
  NodeKey node;                    ///< the bintree node drawn
  int level = 0;                   ///< its level (0 = root)
  TileKey tile;                    ///< the texture tile it is drawn with
  float screenErrorPixels = 0.0f;  ///< of max(geometry error, texture term), at its sphere
  /// 1 − f, the weight of the coarser surface, for the vertices the patch's parent diamond
  /// governs (interior and legs, [0]) and its grandparent's (hypotenuse, [1]); 0 without morph.
  std::array<float, 2> morph{0.0f, 0.0f};
  /// The parent's tile, blended in with weight morph[0] where it differs from `tile` (the
  /// texture quadtree steps at this level); equal to `tile` otherwise.
  TileKey morphTile;
  /// Whether it blends its parent's tile in (morphTile differs from tile).
  bool blendsTile() const noexcept { return !(morphTile == tile); }
};

/// A cut: the patches to draw for one camera, the texture tiles they use, and what refinement
/// cost. A plain value; refine(), IncrementalRefiner and CutSelector make one.
struct Cut final {
  std::vector<CutPatch> patches;   ///< depth-first order of the 12 trees
  std::vector<TileKey> tiles;      ///< distinct tiles of the patches, in first-use order
  std::uint64_t triangles = 0;     ///< of all patches
  std::uint64_t vertices = 0;      ///< of all patches (shared edge vertices counted per patch)
  std::uint64_t nodesVisited = 0;  ///< node records refinement read
  std::uint64_t nodesCulled = 0;   ///< nodes dropped outside the frustum
  /// With RefinementOptions::residentRecordsOnly, the shallowest level of children that were
  /// not descended into because their records were not resident; −1 when none were.
  int unresidentRecordLevel = -1;
};

/// The refinement criterion's error for a node of `level` whose saturated geometry error is
/// `geometryErrorMeters` (see the file comment).
double refinementErrorMeters(const DatasetView& dataset, int level,
                             double geometryErrorMeters) noexcept;

/// The refinement bounds of `record`, a node of `level`, under `bounds`.
RefinementBounds refinementBounds(const DatasetView& dataset, const formats::NodeRecord& record,
                                  int level, const ExaggerationBounds& bounds) noexcept;

/// Appends `patch` (`triangles` and `vertices` of its node) to `cut` and lists its tile and, where
/// it blends one in, its morph tile, each once (`seenTiles` holds the packKey()s listed).
void addCutPatch(Cut& cut, const CutPatch& patch, std::uint32_t triangles, std::uint32_t vertices,
                 std::unordered_set<std::uint64_t>& seenTiles);

/// 1 − f for a diamond with screen error `screenErrorPixels` (docs/architecture.md
/// "Geomorphing"): f = clamp((s/τ − 1)/m, 0, 1); 0 when `range` is 0 (no morph).
float morphWeight(double screenErrorPixels, double tolerancePixels, double range) noexcept;

/// Sets the morph fields of `patch` (its node, level and tile set) from its parent's and
/// grandparent's screen errors (infinite where it has none).
void setPatchMorph(const DatasetView& dataset, const RefinementOptions& options,
                   double parentScreenError, double grandparentScreenError, CutPatch& patch);

/// Recomputes the morph fields of every patch of `cut` for `camera` (its parents' and
/// grandparents' screen errors from their records) and its tiles list: the cut drawn from
/// another pose than its own, as `pbdam bench --popping` draws the previous frame's cut.
void refreshMorph(const DatasetView& dataset, const Camera& camera,
                  const RefinementOptions& options, Cut& cut);

/// What a cut's geomorph does: patches whose parent's or grandparent's weight is strictly
/// between 0 and 1, patches blending their parent's tile in, and the largest weight.
struct CutMorphSummary final {
  std::uint64_t morphingPatches = 0;  ///< with a weight strictly between 0 and 1
  std::uint64_t blendingPatches = 0;  ///< blending their parent's tile in
  double largestWeight = 0.0;         ///< the largest 1 − f of any patch
};
/// Counts what `cut`'s geomorph does (CutMorphSummary).
CutMorphSummary summarizeMorph(const Cut& cut) noexcept;

/// InvalidArgument unless 0 ≤ `range` ≤ the dataset's error margin (manifest error_margin):
/// beyond it, the morph windows of successive levels overlap and cuts crack.
formats::Result<void> checkMorphRange(const DatasetView& dataset, double range);

/// Computes the cut of `dataset` for `camera`.
Cut refine(const DatasetView& dataset, const Camera& camera, const RefinementOptions& options);

}  // namespace pbdam::runtime
