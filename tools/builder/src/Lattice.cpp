// Bintree triangles on the cube-map lattice (Lattice.h).
#include "pbdam/builder/Lattice.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cassert>

#include "pbdam/runtime/TerrainPoint.h"

using namespace pbdam::runtime;

namespace pbdam::builder {

BinTriangle Lattice::root(int face, int tree) const noexcept {
  return bintreeRoot(sideCells_, face, tree);
}

std::array<BinTriangle, 2> Lattice::children(const BinTriangle& t) noexcept {
  return bintreeChildren(t);
}

BinTriangle Lattice::triangle(int face, int tree, int level, std::uint64_t index) const noexcept {
  BinTriangle t = bintreeTriangle(sideCells_, face, tree, index);
  assert(t.level == level);
  (void)level;
  return t;
}

PointKey Lattice::key(int face, LatticeXY p) const noexcept {
  // A point inside the face (on no edge) has no alias on another face: its key is its own.
  const auto n = static_cast<std::int32_t>(sideCells_);
  if (p.x > 0 && p.x < n && p.y > 0 && p.y < n) {
    return (static_cast<std::uint64_t>(face) << 58) | (static_cast<std::uint64_t>(p.x) << 29) |
           static_cast<std::uint64_t>(p.y);
  }
  return latticePointKey(sideCells_, face, p);
}

CubeLatticePoint Lattice::unpack(PointKey key) noexcept {
  constexpr std::uint64_t mask = (std::uint64_t{1} << 29) - 1;
  return CubeLatticePoint{cubeFaceFromIndex(static_cast<int>(key >> 58)),
                          static_cast<std::uint32_t>((key >> 29) & mask),
                          static_cast<std::uint32_t>(key & mask)};
}

EdgeKey Lattice::edgeKey(int face, LatticeXY a, LatticeXY b) const noexcept {
  const PointKey ka = key(face, a);
  const PointKey kb = key(face, b);
  return ka < kb ? EdgeKey{ka, kb} : EdgeKey{kb, ka};
}

glm::dvec2 Lattice::uv(LatticeXY p) const noexcept {
  const double n = static_cast<double>(sideCells_);
  return {static_cast<double>(p.x) / n, static_cast<double>(p.y) / n};
}

glm::dvec3 Lattice::direction(int face, LatticeXY p) const noexcept {
  return latticeDirection(sideCells_, face, p);
}

std::uint64_t nodeId(const BinTriangle& t, int depth) noexcept {
  return static_cast<std::uint64_t>(t.face * 2 + t.tree) * Lattice::nodesPerTree(depth) + t.index;
}

BinTriangle triangleOfNode(const Lattice& lattice, std::uint64_t id, int depth) noexcept {
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  const auto g = static_cast<int>(id / perTree);
  const std::uint64_t index = id % perTree;
  const int level = static_cast<int>(std::bit_width(index + 1)) - 1;
  return lattice.triangle(g / 2, g % 2, level, index);
}

std::vector<Diamond> diamondsOfLevel(const Lattice& lattice, int depth, int level) {
  const std::uint64_t first = Lattice::firstIndexOfLevel(level);
  const std::uint64_t count = std::uint64_t{1} << level;
  std::vector<std::pair<EdgeKey, std::uint64_t>> keyed(12 * count);
  tbb::parallel_for(std::uint64_t{0}, 12 * count, [&](std::uint64_t k) {
    const auto g = static_cast<int>(k / count);
    const BinTriangle t = lattice.triangle(g / 2, g % 2, level, first + k % count);
    keyed[k] = {lattice.edgeKey(t.face, t.left, t.right), nodeId(t, depth)};
  });
  std::sort(keyed.begin(), keyed.end());
  std::vector<Diamond> diamonds;
  diamonds.reserve(keyed.size() / 2);
  for (std::size_t k = 0; k + 1 < keyed.size(); k += 2) {
    assert(keyed[k].first == keyed[k + 1].first);
    diamonds.push_back({keyed[k].second, keyed[k + 1].second});
  }
  return diamonds;
}

}  // namespace pbdam::builder
