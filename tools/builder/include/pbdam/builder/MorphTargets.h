// Morph targets (docs/builder.md "Morph targets"): for each vertex of a patch, the height at which
// the coarser patch's drawn surface crosses the vertex's line (its terrain point's line along the
// surface normal, TerrainPoint.h), which the runtime's geomorph moves the vertex from.
//
// Which coarser surface: the one of the diamond that governs the vertex. A patch's interior and
// leg vertices take its parent's patch; its hypotenuse vertices (w_apex = 0) its grandparent's
// (their own heights on level 1, which has none). Every patch that draws an edge derives the same
// governing diamond for the edge's vertices, and the two patches of a diamond share its
// diagonal's polyline. The coarser patch is drawn as flat triangles between its vertices'
// terrain points, so the target is where the vertex's line meets that triangle (not the
// interpolated height, which lies on the curved reference surface: kilometres above the chords
// of coarse patches). A vertex on an edge of the coarser TIN takes it from that edge's segment
// alone (the point of the line closest to it, endpoints in canonical key order), so both
// triangles of the edge, both partners of a diamond and both faces of a cube edge compute the
// same doubles and the same target. Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <optional>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// The lattice points of `mesh`'s vertices on the node triangle `t`: apex + (b1·(left − apex) +
/// b2·(right − apex))/2^15, exactly; nullopt when a vertex is not a lattice point.
std::optional<std::vector<runtime::LatticeXY>> patchLatticePoints(const runtime::BinTriangle& t,
                                                                  const formats::PatchMesh& mesh);

/// Where the geometry lives: the planet, the lattice and the height step.
struct MorphGeometry final {
  const runtime::Planet* planet = nullptr;
  const Lattice* lattice = nullptr;
  double heightStepMeters = 1.0;
};

/// A coarser patch as drawn: its vertices' lattice points, canonical keys and terrain points,
/// and a bucket grid over its triangles' bounding boxes to find the one that holds a point.
class CoarserSurface final {
 public:
  /// Only points of the box [regionLow, regionHigh] will be asked for: the grid covers the
  /// triangles that reach it (a finer patch's own box in its parent, its hypotenuse in its
  /// grandparent). Every triangle holding such a point reaches the box and keeps its order,
  /// so the answers are those of a grid over the whole patch.
  CoarserSurface(const MorphGeometry& geometry, const runtime::BinTriangle& node,
                 const formats::PatchMesh& mesh, std::vector<runtime::LatticeXY> points,
                 runtime::LatticeXY regionLow, runtime::LatticeXY regionHigh);
  /// The target of lattice point `q` of the node's face, in height steps; nullopt when no
  /// triangle holds q or q is outside the region. Not thread-safe: it fills the corners'
  /// terrain points as it meets them.
  std::optional<std::int32_t> targetAt(runtime::LatticeXY q) const;

 private:
  /// Vertex v's terrain point, computed on first use: a grandparent's surface answers only a
  /// grandchild's few hypotenuse vertices, so most of its corners are never asked for.
  const glm::dvec3& terrainOf(std::size_t v) const;

  const MorphGeometry& geometry_;
  int face_ = 0;
  const formats::PatchMesh& mesh_;
  std::vector<runtime::LatticeXY> points_;
  mutable std::vector<glm::dvec3> terrain_;
  mutable std::vector<bool> hasTerrain_;
  runtime::LatticeXY low_{0};
  runtime::LatticeXY high_{0};
  std::int64_t cell_ = 1;
  std::int64_t columns_ = 1;
  std::int64_t rows_ = 1;
  std::vector<std::uint32_t> first_;      ///< per bucket: its first entry in triangles_
  std::vector<std::uint32_t> triangles_;  ///< triangle numbers, bucket by bucket
};

/// The ids of a node's parent and grandparent in the same tree (Lattice.h's node ids), where
/// the node has them.
struct NodeAncestors final {
  std::optional<std::uint64_t> parent;
  std::optional<std::uint64_t> grandparent;
};
NodeAncestors nodeAncestors(std::uint64_t id, std::uint64_t nodesPerTree) noexcept;

/// The morph targets of node `id` (a forest of `depth`) with patch `mesh`, given its parent's
/// and grandparent's patches (null where the node has none; a root has no targets and gets an
/// empty vector). nullopt when a patch's vertex is not a lattice point. A vertex no triangle of
/// its governing patch holds (a malformed patch) keeps its own height; `missed` counts those.
std::optional<std::vector<std::int32_t>> nodeMorphTargets(
    const MorphGeometry& geometry, std::uint64_t id, int depth, const formats::PatchMesh& mesh,
    const formats::PatchMesh* parent, const formats::PatchMesh* grandparent, std::uint64_t& missed);

/// The same targets from coarser surfaces already made, which siblings can share: node triangle
/// `self` with patch `mesh`, its parent's surface over (at least) the node's box and its
/// grandparent's over (at least) its hypotenuse's box (null where it has none). A surface's
/// answers do not depend on its region beyond that (CoarserSurface), so the bytes are those of
/// the overload above. Not thread-safe for the surfaces it is given.
std::optional<std::vector<std::int32_t>> nodeMorphTargets(const runtime::BinTriangle& self,
                                                          const formats::PatchMesh& mesh,
                                                          const CoarserSurface& parent,
                                                          const CoarserSurface* grandparent,
                                                          std::uint64_t& missed);

}  // namespace pbdam::builder
