// The bintree forest on the cube-map lattice, as the runtime and the builder both see it
// (docs/builder.md "Lattice and bintrees"): each face's lattice of N × N cells, two root
// triangles per face, children by hypotenuse bisection, heap numbering, and canonical keys of
// lattice points shared by several faces. The runtime derives a node's lattice triangle from its
// heap index, so the face files store no coordinates. Thread-safety: pure functions and values.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <glm/ext/vector_double2.hpp>
#include <glm/vec2.hpp>

#include "pbdam/runtime/CubeMap.h"

namespace pbdam::runtime {

/// A lattice point of one face: (i, j) in [0, N]².
using LatticeXY = glm::i32vec2;

/// A key identifying a point of the sphere on the lattice: the canonical (smallest) alias
/// packed as face·2^58 + i·2^29 + j. Equal keys ⇔ the same point, on any face.
using PointKey = std::uint64_t;

/// One bintree triangle: face, tree (0 or 1: which half of the face the root is), level (0 =
/// root), heap index within its tree, and its corners. The hypotenuse is left–right; the right
/// angle is at the apex.
struct BinTriangle final {
  int face = 0;             ///< 0..5 (CubeMap.h)
  int tree = 0;             ///< 0 or 1
  int level = 0;            ///< 0 = root
  std::uint64_t index = 0;  ///< heap index within its tree
  LatticeXY apex{0};        ///< the right-angle corner, in lattice cells
  LatticeXY left{0};        ///< one end of the hypotenuse, in lattice cells
  LatticeXY right{0};       ///< the other end of the hypotenuse, in lattice cells
};

/// The root of tree `tree` (0 or 1) of `face` on a lattice of `sideCells` cells: tree 0 =
/// ((N,0),(0,0),(N,N)), tree 1 = ((0,N),(N,N),(0,0)); both split the face along its
/// (0,0)–(N,N) diagonal.
BinTriangle bintreeRoot(std::uint32_t sideCells, int face, int tree) noexcept;

/// The two children: first (m, left, apex), second (m, apex, right), m = hypotenuse midpoint.
/// The triangle's legs must be at least 2 cells long (axis-aligned) or 1 cell (diagonal).
std::array<BinTriangle, 2> bintreeChildren(const BinTriangle& t) noexcept;

/// Which child of `t` (0: first, 1: second; bintreeChildren) contains lattice position `xy`:
/// the first (m, left, apex) lies on the left's side of the line apex–m (points on it go first).
int bintreeChildContaining(const BinTriangle& t, const glm::dvec2& xy) noexcept;

/// The level of heap index `index` (0 for the root, 1 for 1 and 2, …).
inline int bintreeLevel(std::uint64_t index) noexcept {
  return static_cast<int>(std::bit_width(index + 1)) - 1;
}

/// The triangle with heap `index` of tree `tree` of `face`, found by descending from the root.
BinTriangle bintreeTriangle(std::uint32_t sideCells, int face, int tree,
                            std::uint64_t index) noexcept;

/// The canonical key of lattice point `p` of `face` on a lattice of `sideCells` cells.
PointKey latticePointKey(std::uint32_t sideCells, int face, LatticeXY p) noexcept;

}  // namespace pbdam::runtime
