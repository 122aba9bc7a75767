// Cuts selected by a predicate and closed upward (docs/architecture.md "Selection by
// predicate", [Yalçın 2011] §6–7): the one cut definition that any predicate — not only the
// screen-space error the saturated errors make conforming by themselves — turns into a
// conforming mesh.
//
// 1. Predicate. Every inner node above the level cap is asked whether it wants to be split: its
//    screen error exceeds the tolerance, or its bounding sphere comes within a focus region's
//    width of the region's centre line and its geometry error exceeds the region's error, or a
//    caller's predicate says so.
// 2. Closure. The split set is the smallest set that holds every node that wants to be split
//    and, with each node, its parent and its diamond partner (the triangle across its
//    hypotenuse, on another face for the level-1 diamonds on cube edges): the split diamonds
//    then form a set closed under the diamond DAG's parent relation, so no split edge meets an
//    unsplit one (no T-junction).
// 3. The cut. From the roots down, the first node of each branch that is not split, dropped
//    when its sphere is outside the frustum (with culling on).
// With no focus region the predicate is refine()'s and its set is already closed (saturated
// errors, nested shared spheres): select() then gives refine()'s cut. This is the reference the
// data-parallel passes are to match; here it evaluates every node of the dataset on the CPU.
// Thread-safety: CutSelector is immutable after construction; select() is const.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <glm/vec3.hpp>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Refinement.h"

namespace pbdam::runtime {

/// Full detail near a circle (one point) or a path (a polyline) on the planet: nodes whose
/// sphere comes within `widthMeters` of the centre line are split while their geometry error
/// exceeds `errorMeters` (0: down to the leaves).
struct FocusRegion final {
  std::vector<glm::dvec3> line;  ///< planetocentric metres; consecutive points form segments
  double widthMeters = 0.0;      ///< the circle's radius, the path's half width
  double errorMeters = 0.0;      ///< split nodes near it while their error exceeds this (0: all)

  /// Whether a sphere comes within the width of the centre line (the predicate's test).
  bool reaches(const glm::dvec3& centre, double radius) const noexcept;
};

/// The focus region of the circle of `radiusMeters` around (lat, lon) on `planet`'s reference
/// surface; InvalidArgument for a latitude outside ±90° or a radius ≤ 0 or beyond half the
/// planet's circumference.
formats::Result<FocusRegion> focusCircle(const Planet& planet, double latDegrees, double lonDegrees,
                                         double radiusMeters, double errorMeters);

/// The focus region of a path: the polyline through `latLonDegrees` (lat, lon pairs) on the
/// reference surface, `halfWidthMeters` to each side. InvalidArgument for an empty path, a
/// latitude outside ±90°, a width ≤ 0 or an error < 0.
formats::Result<FocusRegion> focusPath(const Planet& planet,
                                       const std::vector<std::array<double, 2>>& latLonDegrees,
                                       double halfWidthMeters, double errorMeters);

/// What CutSelector::select() splits: the refinement's criterion, focus regions, and any
/// further predicate.
struct SelectionOptions final {
  RefinementOptions refinement;    ///< tolerance, culling, level cap, morph range
  std::vector<FocusRegion> focus;  ///< any number; a node near any of them is split
  /// Any further predicate (unset: none): a node it returns true for wants to be split. It
  /// need not agree between diamond partners nor with a node's parent: the closure makes the
  /// cut conforming.
  std::function<bool(const NodeKey&, const formats::NodeRecord&)> split;
};

/// How a selection went, beside its cut.
struct SelectionStats final {
  std::uint64_t predicateSplits = 0;  ///< nodes the predicate split
  std::uint64_t closureSplits = 0;    ///< nodes split by the closure only
};

/// The dataset's nodes in one index space (face by face, in node-table order), each with its key,
/// level, leaf flag, first child, parent and diamond partner: the partner is the node across its
/// hypotenuse, found by the hypotenuse's canonical corner keys, so across cube faces too. What
/// the closure walks, on the host and on the device.
struct DiamondIndex final {
  /// One node of the index.
  struct Node final {
    NodeKey key;                   ///< the node in the dataset
    std::uint32_t parent = 0;      ///< index into nodes (a root: itself)
    std::uint32_t partner = 0;     ///< the node across the hypotenuse (itself when none)
    std::uint32_t firstChild = 0;  ///< index into nodes of its first child (the second follows)
    bool leaf = true;              ///< whether it has no children (firstChild unused)
    int level = 0;                 ///< its bintree level (0 = root)
  };
  /// Indexes every node of `dataset` (reads each face's whole node table).
  explicit DiamondIndex(const DatasetView& dataset);
  std::vector<Node> nodes;           ///< face by face, each in node-table order
  std::vector<std::uint32_t> roots;  ///< the 12 roots, face by face, tree 0 then 1
};

/// Cuts selected by a predicate and closed upward (the file comment): the host's refinement
/// when focus regions or a caller's predicate decide too. Holds the dataset's DiamondIndex and a
/// pointer to the dataset, which must outlive it; select() is const and may run on any thread.
class CutSelector final {
 public:
  /// Indexes the dataset's nodes (DiamondIndex).
  explicit CutSelector(const DatasetView& dataset);

  /// The cut of `options` for `camera` (the file comment). Patches split by a focus region or
  /// by the closure get no geomorph from that split (their weight of it is 0): a morph window
  /// is a range of screen errors.
  Cut select(const Camera& camera, const SelectionOptions& options,
             SelectionStats* stats = nullptr) const;

 private:
  const DatasetView* dataset_;
  DiamondIndex index_;
};

/// The cut of `focus` alone over the whole planet (no screen error, no culling, no geomorph),
/// closed upward: what the terrain queries extract (line of sight, viewshed).
Cut selectFocus(const DatasetView& dataset, std::vector<FocusRegion> focus);

}  // namespace pbdam::runtime
