// The forest a build makes, level by level (docs/builder.md "Insets: the forest's shape"): the
// complete forest of the build's depth, or an adaptive ForestShape. What the level loop, the
// per-diamond work and the assembly ask of it: the diamonds of a level that exist (a leaf whose
// diamond partner does not exist is a diamond of one), which nodes are leaves, and each leaf's
// regular patch. Private to the builder. Thread-safety: immutable after construction.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "pbdam/builder/ForestShape.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/builder/PatchBuilder.h"

namespace pbdam::builder {

class ForestPlan final {
 public:
  /// The second node of a diamond of one.
  static constexpr std::uint64_t kNoNode = ~std::uint64_t{0};

  /// The complete forest of `depth` on `lattice`, leaves of `leafCells` cells.
  ForestPlan(const Lattice& lattice, int depth, std::uint32_t leafCells);
  /// An adaptive forest; `shape` is of `lattice` (the deepest leaves' lattice).
  ForestPlan(const Lattice& lattice, std::uint32_t leafCells, ForestShape shape);

  int depth() const noexcept { return depth_; }
  bool complete() const noexcept { return !shape_.has_value(); }
  /// The nodes of all levels.
  std::uint64_t nodeCount() const noexcept;
  /// Every node's id, ascending (the order of the face files' tables); empty for a complete
  /// forest, whose ids are 0 .. nodeCount() − 1.
  std::vector<std::uint64_t> nodeIds() const;

  /// The diamonds of `level` that exist, sorted by their spine's key (the order of
  /// diamondsOfLevel for a complete forest): both node ids, or a leaf's and kNoNode.
  std::vector<Diamond> diamondsOfLevel(int level) const;
  /// Whether node `id` of `level` is a leaf.
  bool isLeaf(int level, std::uint64_t id) const noexcept;
  /// The lattice spacing (cells) of the leaves of `level`: N / (L·2^⌈level/2⌉), so an odd
  /// level's leaves take the next even level's points.
  std::int32_t leafSpacing(int level) const noexcept;
  /// The regular patch of leaf `t`, with a coarse hypotenuse when its partner does not exist.
  WorkPatch leafPatch(const runtime::BinTriangle& t) const;

  /// The lattice points the forest's patches use: every point for a complete forest; for an
  /// adaptive one, squares of 8 base-leaf spacings (at least N/256, at most a base leaf's
  /// square), each at the spacing of the finest leaf whose box shares area with it.
  LatticeTiles latticeTiles() const;

  /// The texture tiles that exist, as face · tilesPerFace + heap index, ascending, for a
  /// quadtree of `textureLevels` levels; empty for a complete forest, whose quadtree is complete.
  /// A tile of level t exists where a leaf of level d with t ≤ textureLevels − 1 −
  /// ⌊(depth − d)/2⌋ lies in its square (texels as dense as the leaves under it), with its three
  /// siblings (a tile has none or four children) and its ancestors; every face has its root.
  std::vector<std::uint64_t> tiles(std::uint32_t textureLevels) const;

 private:
  const Lattice& lattice_;
  int depth_;
  std::uint32_t leafCells_;
  std::optional<ForestShape> shape_;
  /// Per level, the ids of leaves whose diamond partner does not exist, ascending.
  std::vector<std::vector<std::uint64_t>> partnerless_;
};

}  // namespace pbdam::builder
