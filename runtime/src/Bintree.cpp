// Bintree triangles on the cube-map lattice (Bintree.h).
#include "pbdam/runtime/Bintree.h"

#include <cassert>

namespace pbdam::runtime {

BinTriangle bintreeRoot(std::uint32_t sideCells, int face, int tree) noexcept {
  const auto n = static_cast<std::int32_t>(sideCells);
  BinTriangle t;
  t.face = face;
  t.tree = tree;
  if (tree == 0) {
    t.apex = {n, 0};
    t.left = {0, 0};
    t.right = {n, n};
  } else {
    t.apex = {0, n};
    t.left = {n, n};
    t.right = {0, 0};
  }
  return t;
}

std::array<BinTriangle, 2> bintreeChildren(const BinTriangle& t) noexcept {
  const LatticeXY sum = t.left + t.right;
  assert(sum.x % 2 == 0 && sum.y % 2 == 0);
  const LatticeXY m = sum / 2;
  BinTriangle first = t;
  first.level = t.level + 1;
  first.index = 2 * t.index + 1;
  first.apex = m;
  first.left = t.left;
  first.right = t.apex;
  BinTriangle second = first;
  second.index = 2 * t.index + 2;
  second.left = t.apex;
  second.right = t.right;
  return {first, second};
}

int bintreeChildContaining(const BinTriangle& t, const glm::dvec2& xy) noexcept {
  const glm::dvec2 a(t.apex), l(t.left);
  const glm::dvec2 m = 0.5 * (glm::dvec2(t.left) + glm::dvec2(t.right));
  const auto side = [&](const glm::dvec2& q) {
    return (m.x - a.x) * (q.y - a.y) - (m.y - a.y) * (q.x - a.x);
  };
  return side(xy) * side(l) >= 0.0 ? 0 : 1;
}

BinTriangle bintreeTriangle(std::uint32_t sideCells, int face, int tree,
                            std::uint64_t index) noexcept {
  BinTriangle t = bintreeRoot(sideCells, face, tree);
  // index + 1 in binary is 1 followed by the child choices, most significant first.
  const std::uint64_t path = index + 1;
  for (int bit = bintreeLevel(index) - 1; bit >= 0; --bit) {
    t = bintreeChildren(t)[(path >> bit) & 1U];
  }
  assert(t.index == index);
  return t;
}

PointKey latticePointKey(std::uint32_t sideCells, int face, LatticeXY p) noexcept {
  const CubeLatticePoint point{cubeFaceFromIndex(face), static_cast<std::uint32_t>(p.x),
                               static_cast<std::uint32_t>(p.y)};
  const CubeLatticePoint c = CubeMap::canonicalLatticePoint(point, sideCells);
  return (static_cast<std::uint64_t>(cubeFaceIndex(c.face)) << 58) |
         (static_cast<std::uint64_t>(c.i) << 29) | static_cast<std::uint64_t>(c.j);
}

}  // namespace pbdam::runtime
