// The shape of an adaptive forest (docs/builder.md "Insets: the forest's shape"): which bintree
// nodes exist and which of them are split, when leaves lie at the base's depth everywhere except
// near regions (insets) that want deeper ones. The set of split diamonds is closed ([Yalçın 2011]'s
// closure, at build time): both triangles of a split diamond are split, so both parents of a
// split diamond are split; every cut a top-down refinement stopping at leaves makes is then
// conforming. Thread-safety: immutable after make().
#pragma once

#include <cstdint>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// A region that wants leaves of `leafLevel` (deeper than the base's) where it lies.
struct DeepRegion final {
  formats::LatLonBounds bounds;  ///< degrees; east may exceed 180
  int leafLevel = 0;
};

class ForestShape final {
 public:
  /// The smallest closed forest whose leaves are at `baseDepth` or deeper, and at a region's
  /// leaf level near it: a node of level k < r.leafLevel is split when its diamond's centre
  /// (hypotenuse midpoint) is within `reach` of its hypotenuses of region r (chord distances on
  /// the unit sphere; 2 is nearly closed by itself; below about 0.5 a node over the region may
  /// stay unsplit, since its points lie up to half a hypotenuse from that midpoint), and the
  /// closure adds what the rule misses. The
  /// result depends only on the arguments (not on the regions' order or on threads).
  /// `lattice` is the deepest leaves' lattice: leaves of level d have legs of
  /// N / 2^(d/2) cells, so N must allow the deepest region's level.
  /// The regions' boxes are geodetic on `planet` (as DEM samples are placed).
  static ForestShape make(const Lattice& lattice, const runtime::Planet& planet, int baseDepth,
                          std::vector<DeepRegion> regions, double reach = 2.0);

  /// The deepest leaf level: the base's depth or the deepest region's leaf level.
  int depth() const noexcept { return static_cast<int>(levels_.size()) - 1; }
  int baseDepth() const noexcept { return baseDepth_; }
  /// Node ids (nodeId(t, depth())) of level `level` that exist, ascending; and whether each is
  /// split (same order).
  const std::vector<std::uint64_t>& nodesOfLevel(int level) const noexcept {
    return levels_[static_cast<std::size_t>(level)].nodes;
  }
  const std::vector<bool>& splitOfLevel(int level) const noexcept {
    return levels_[static_cast<std::size_t>(level)].split;
  }
  /// Whether node `id` of `level` exists, and whether it is split.
  bool exists(int level, std::uint64_t id) const noexcept;
  bool isSplit(int level, std::uint64_t id) const noexcept;
  /// The count of nodes and of leaves over all levels.
  std::uint64_t nodeCount() const noexcept;
  std::uint64_t leafCount() const noexcept;
  /// The nodes split for the closure only (the split rule alone left them whole).
  std::uint64_t closureSplits() const noexcept { return closureSplits_; }

 private:
  struct Level {
    std::vector<std::uint64_t> nodes;
    std::vector<bool> split;
  };
  int baseDepth_ = 0;
  std::uint64_t closureSplits_ = 0;
  std::vector<Level> levels_;
};

}  // namespace pbdam::builder
