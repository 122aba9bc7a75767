// The forest a build makes (ForestPlan.h).
#include "ForestPlan.h"

#include <algorithm>
#include <bit>
#include <utility>

#include "pbdam/formats/DatasetFormat.h"

using namespace pbdam::runtime;

namespace pbdam::builder {

ForestPlan::ForestPlan(const Lattice& lattice, int depth, std::uint32_t leafCells)
    : lattice_(lattice), depth_(depth), leafCells_(leafCells) {}

ForestPlan::ForestPlan(const Lattice& lattice, std::uint32_t leafCells, ForestShape shape)
    : lattice_(lattice), depth_(shape.depth()), leafCells_(leafCells), shape_(std::move(shape)) {
  partnerless_.resize(static_cast<std::size_t>(depth_) + 1);
  for (int level = 0; level <= depth_; ++level) {
    for (const Diamond& d : diamondsOfLevel(level)) {
      if (d[1] == kNoNode) partnerless_[static_cast<std::size_t>(level)].push_back(d[0]);
    }
    std::sort(partnerless_[static_cast<std::size_t>(level)].begin(),
              partnerless_[static_cast<std::size_t>(level)].end());
  }
}

std::uint64_t ForestPlan::nodeCount() const noexcept {
  return shape_ ? shape_->nodeCount() : 12 * Lattice::nodesPerTree(depth_);
}

std::vector<std::uint64_t> ForestPlan::nodeIds() const {
  std::vector<std::uint64_t> ids;
  if (!shape_) return ids;
  ids.reserve(shape_->nodeCount());
  for (int level = 0; level <= depth_; ++level) {
    const auto& nodes = shape_->nodesOfLevel(level);
    ids.insert(ids.end(), nodes.begin(), nodes.end());
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<Diamond> ForestPlan::diamondsOfLevel(int level) const {
  if (!shape_) return builder::diamondsOfLevel(lattice_, depth_, level);
  const auto& nodes = shape_->nodesOfLevel(level);
  std::vector<std::pair<EdgeKey, std::uint64_t>> keyed(nodes.size());
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const BinTriangle t = triangleOfNode(lattice_, nodes[k], depth_);
    keyed[k] = {lattice_.edgeKey(t.face, t.left, t.right), nodes[k]};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<Diamond> diamonds;
  diamonds.reserve(keyed.size() / 2 + 1);
  for (std::size_t k = 0; k < keyed.size();) {
    if (k + 1 < keyed.size() && keyed[k + 1].first == keyed[k].first) {
      diamonds.push_back({keyed[k].second, keyed[k + 1].second});
      k += 2;
    } else {
      diamonds.push_back({keyed[k].second, kNoNode});
      ++k;
    }
  }
  return diamonds;
}

bool ForestPlan::isLeaf(int level, std::uint64_t id) const noexcept {
  return shape_ ? !shape_->isSplit(level, id) : level == depth_;
}

std::int32_t ForestPlan::leafSpacing(int level) const noexcept {
  const int shift = std::countr_zero(leafCells_) + (level + 1) / 2;
  return static_cast<std::int32_t>(lattice_.sideCells() >> shift);
}

WorkPatch ForestPlan::leafPatch(const BinTriangle& t) const {
  if (!shape_) return makeLeafPatch(t);
  // Only an odd leaf without a partner lies on a leg with half its hypotenuse's points (an even
  // one's hypotenuse lies on an odd leaf's leg of the same spacing; docs/builder.md).
  const auto& singles = partnerless_[static_cast<std::size_t>(t.level)];
  const bool coarse =
      t.level % 2 == 1 && std::binary_search(singles.begin(), singles.end(), nodeId(t, depth_));
  return makeLeafPatch(t, leafSpacing(t.level), coarse);
}

}  // namespace pbdam::builder

namespace pbdam::builder {

LatticeTiles ForestPlan::latticeTiles() const {
  const std::uint32_t n = lattice_.sideCells();
  if (!shape_) return LatticeTiles::dense(n);
  // Tiles of 8 base-leaf spacings (a base tile stores 9 × 9 points for 64 cells), at most 256 a
  // face side, at most a base leaf's square: a deep region's finest spacing then reaches at most
  // a tile beyond its leaves, not a whole base square.
  const auto baseSpacing = static_cast<std::uint32_t>(leafSpacing(shape_->baseDepth()));
  const std::uint32_t cells =
      std::min(n >> (shape_->baseDepth() / 2), std::max(8 * baseSpacing, n >> 8));
  // Every leaf finer than the base's is a region wanting its spacing; a square is cut into
  // quarters while it would hold more than kMaxTilePoints points a side at the finest spacing
  // that shares area with it, so an inset many levels finer than the base costs about its own
  // points, not a whole base square's at its spacing.
  constexpr std::uint32_t kMaxTilePoints = 1024;
  const auto log2Of = [](std::int32_t spacing) {
    return static_cast<std::uint8_t>(std::countr_zero(static_cast<std::uint32_t>(spacing)));
  };
  std::vector<LatticeTiles::Region> regions;
  for (int level = shape_->baseDepth() + 1; level <= depth_; ++level) {
    const auto& nodes = shape_->nodesOfLevel(level);
    const auto& split = shape_->splitOfLevel(level);
    const std::uint8_t s = log2Of(leafSpacing(level));
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      if (split[k]) continue;
      const BinTriangle t = triangleOfNode(lattice_, nodes[k], depth_);
      regions.push_back(LatticeTiles::Region{t.face, std::min({t.apex.x, t.left.x, t.right.x}),
                                             std::min({t.apex.y, t.left.y, t.right.y}),
                                             std::max({t.apex.x, t.left.x, t.right.x}),
                                             std::max({t.apex.y, t.left.y, t.right.y}), s});
    }
  }
  return LatticeTiles::adaptive(n, cells, log2Of(leafSpacing(shape_->baseDepth())), regions,
                                kMaxTilePoints);
}

std::vector<std::uint64_t> ForestPlan::tiles(std::uint32_t textureLevels) const {
  std::vector<std::uint64_t> keys;
  if (!shape_) return keys;
  const std::uint64_t perFace = ((std::uint64_t{1} << (2 * textureLevels)) - 1) / 3;
  const auto finest = static_cast<int>(textureLevels) - 1;
  for (std::uint64_t face = 0; face < 6; ++face) keys.push_back(face * perFace);  // the roots
  for (int level = 0; level <= depth_; ++level) {
    const auto& nodes = shape_->nodesOfLevel(level);
    const auto& split = shape_->splitOfLevel(level);
    // A leaf of level d wants tiles down to level finest − ⌊(depth − d)/2⌋ over its square (an
    // odd leaf samples the next even level's lattice).
    const int deepest = std::min(finest - (depth_ - level) / 2, level / 2);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      if (split[k]) continue;
      const BinTriangle t = triangleOfNode(lattice_, nodes[k], depth_);
      const std::int32_t minX = std::min({t.apex.x, t.left.x, t.right.x});
      const std::int32_t minY = std::min({t.apex.y, t.left.y, t.right.y});
      for (int tl = 0; tl <= deepest; ++tl) {
        const auto side = static_cast<std::int32_t>(lattice_.sideCells() >> tl);
        const auto qi = static_cast<std::uint32_t>(minX / side);
        const auto qj = static_cast<std::uint32_t>(minY / side);
        for (std::uint32_t c = 0; c < 4; ++c) {  // the square and its siblings
          const std::uint32_t si = tl == 0 ? 0 : (qi & ~1U) + (c & 1U);
          const std::uint32_t sj = tl == 0 ? 0 : (qj & ~1U) + (c >> 1);
          keys.push_back(static_cast<std::uint64_t>(t.face) * perFace +
                         formats::textureHeapIndex(static_cast<std::uint32_t>(tl), si, sj));
        }
      }
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

}  // namespace pbdam::builder
