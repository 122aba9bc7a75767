// The P-BDAM bintree forest on the cube-map lattice (docs/builder.md "Lattice and bintrees";
// [P-BDAM 2003] §3, §4.1): bintree triangles as lattice-point triples, heap numbering, canonical
// keys of lattice points shared by several faces, and edge keys that identify diamonds across
// faces. Thread-safety: pure functions and plain values.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec2.hpp>
#include <utility>
#include <vector>

#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/CubeMap.h"

namespace pbdam::builder {

using pbdam::runtime::LatticeXY;
using pbdam::runtime::PointKey;

/// An unordered pair of point keys (smaller first): the key of an edge across faces.
using EdgeKey = std::pair<runtime::PointKey, runtime::PointKey>;

using pbdam::runtime::BinTriangle;

/// The lattice of one dataset: N cells per face side (a power of two ≤ 2^28).
class Lattice final {
 public:
  explicit Lattice(std::uint32_t sideCells) noexcept : sideCells_(sideCells) {}
  std::uint32_t sideCells() const noexcept { return sideCells_; }

  /// The root of tree `tree` (0 or 1) of `face`: tree 0 = ((N,0),(0,0),(N,N)), tree 1 =
  /// ((0,N),(N,N),(0,0)); both split the face along its (0,0)–(N,N) diagonal.
  runtime::BinTriangle root(int face, int tree) const noexcept;

  /// The two children: first (m, left, apex), second (m, apex, right), m = hypotenuse midpoint.
  /// The triangle's legs must be at least 2 cells long (axis-aligned) or 1 cell (diagonal).
  static std::array<runtime::BinTriangle, 2> children(const runtime::BinTriangle& t) noexcept;

  /// The triangle with heap `index` at `level` of tree `tree` of `face`, found by descending.
  runtime::BinTriangle triangle(int face, int tree, int level, std::uint64_t index) const noexcept;

  /// The canonical key of lattice point `p` of `face`.
  runtime::PointKey key(int face, runtime::LatticeXY p) const noexcept;
  /// The canonical (face, i, j) of a key.
  static runtime::CubeLatticePoint unpack(runtime::PointKey key) noexcept;
  /// The key of the edge a–b of `face`.
  EdgeKey edgeKey(int face, runtime::LatticeXY a, runtime::LatticeXY b) const noexcept;

  /// (u, v) of a lattice point.
  glm::dvec2 uv(runtime::LatticeXY p) const noexcept;
  /// The geocentric unit direction of a lattice point, computed from its canonical alias so that
  /// every face gives bit-identical results.
  glm::dvec3 direction(int face, runtime::LatticeXY p) const noexcept;

  /// Heap index of the first node of `level` (2^level − 1) and the node count of a tree of
  /// depth `levels` (2^(levels+1) − 1).
  static std::uint64_t firstIndexOfLevel(int level) noexcept {
    return (std::uint64_t{1} << level) - 1;
  }
  static std::uint64_t nodesPerTree(int depth) noexcept {
    return (std::uint64_t{1} << (depth + 1)) - 1;
  }

 private:
  std::uint32_t sideCells_;
};

/// Dataset-wide node ids: (face·2 + tree)·nodesPerTree(depth) + heap index — also the order of
/// the node tables of the six face files concatenated.
std::uint64_t nodeId(const runtime::BinTriangle& t, int depth) noexcept;
/// The triangle of a node id.
runtime::BinTriangle triangleOfNode(const Lattice& lattice, std::uint64_t id, int depth) noexcept;

/// The two node ids of one diamond (the triangles sharing a hypotenuse).
using Diamond = std::array<std::uint64_t, 2>;

/// Every diamond of `level` in a deterministic order (sorted by spine key). Across face edges
/// too: the cube-map surface is closed, so every hypotenuse has exactly two triangles.
std::vector<Diamond> diamondsOfLevel(const Lattice& lattice, int depth, int level);

/// Twice the signed area of the lattice triangle (a, b, c) (positive counter-clockwise).
inline std::int64_t doubleArea(runtime::LatticeXY a, runtime::LatticeXY b,
                               runtime::LatticeXY c) noexcept {
  return static_cast<std::int64_t>(b.x - a.x) * (c.y - a.y) -
         static_cast<std::int64_t>(b.y - a.y) * (c.x - a.x);
}

}  // namespace pbdam::builder
