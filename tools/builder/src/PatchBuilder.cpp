// Leaf patches and node corners (PatchBuilder.h; [P-BDAM 2003] §4.2 displaced triangles). The
// block simplification is in PatchSimplifier.cpp, the measurement and encoding in
// PatchMeasure.cpp.
#include "pbdam/builder/PatchBuilder.h"

#include <cstdlib>

#include "IndexedPatch.h"

using namespace pbdam::runtime;

namespace pbdam::builder {

WorkPatch compact(const std::vector<LatticeXY>& points, const std::vector<std::uint32_t>& indices) {
  WorkPatch out;
  std::vector<std::uint32_t> remap(points.size(), std::numeric_limits<std::uint32_t>::max());
  out.indices.reserve(indices.size());
  for (std::uint32_t i : indices) {
    if (remap[i] == std::numeric_limits<std::uint32_t>::max()) {
      remap[i] = static_cast<std::uint32_t>(out.points.size());
      out.points.push_back(points[i]);
    }
    out.indices.push_back(remap[i]);
  }
  return out;
}

namespace {

/// Bisects `t` down to axis-aligned legs of `spacing` cells; a triangle whose hypotenuse lies
/// on the line of `keep` (the leaf's hypotenuse, when it is to stay coarse) and spans two
/// spacings is kept whole.
void bisectToCells(const BinTriangle& t, std::int32_t spacing, const BinTriangle* keep,
                   IndexedPatch& out) {
  const LatticeXY leg = t.left - t.apex;
  if (std::abs(leg.x) + std::abs(leg.y) == spacing) {  // an axis-aligned leg of one spacing
    out.addTriangle(t.apex, t.left, t.right);
    return;
  }
  if (keep != nullptr) {
    const LatticeXY hyp = t.right - t.left;
    const bool onLine = doubleArea(keep->left, keep->right, t.left) == 0 &&
                        doubleArea(keep->left, keep->right, t.right) == 0;
    if (onLine && std::abs(hyp.x) + std::abs(hyp.y) == 2 * spacing) {
      out.addTriangle(t.apex, t.left, t.right);
      return;
    }
  }
  for (const BinTriangle& c : Lattice::children(t)) bisectToCells(c, spacing, keep, out);
}

}  // namespace

WorkPatch makeLeafPatch(const BinTriangle& triangle, std::int32_t spacing, bool coarseHypotenuse) {
  // The bisection depends only on the triangle's shape (its legs as vectors) and how it is cut:
  // leaves of one shape are translates of each other, so each thread builds each shape once
  // and translates it.
  struct Shape {
    LatticeXY toLeft;
    LatticeXY toRight;
    std::int32_t spacing;
    bool coarseHypotenuse;
    WorkPatch relative;  // points relative to the apex
  };
  thread_local std::vector<Shape> shapes;
  const LatticeXY toLeft = triangle.left - triangle.apex;
  const LatticeXY toRight = triangle.right - triangle.apex;
  const Shape* shape = nullptr;
  for (const Shape& s : shapes) {
    if (s.toLeft == toLeft && s.toRight == toRight && s.spacing == spacing &&
        s.coarseHypotenuse == coarseHypotenuse) {
      shape = &s;
    }
  }
  if (shape == nullptr) {
    IndexedPatch mesh;
    bisectToCells(triangle, spacing, coarseHypotenuse ? &triangle : nullptr, mesh);
    WorkPatch patch = compact(mesh.points, mesh.indices);
    for (LatticeXY& p : patch.points) p -= triangle.apex;
    shapes.push_back(Shape{toLeft, toRight, spacing, coarseHypotenuse, std::move(patch)});
    shape = &shapes.back();
  }
  WorkPatch out;
  out.indices = shape->relative.indices;
  out.points.resize(shape->relative.points.size());
  for (std::size_t k = 0; k < out.points.size(); ++k) {
    out.points[k] = shape->relative.points[k] + triangle.apex;
  }
  return out;
}

NodeCorners nodeCorners(const SampleGrid& grid, const BinTriangle& t) {
  NodeCorners c;
  const std::array<LatticeXY, 3> corners = {t.apex, t.left, t.right};
  for (std::size_t k = 0; k < 3; ++k) {
    c.positions[k] = grid.terrainPoint(t.face, corners[k]);
    c.normals[k] = glm::vec3(grid.surfaceNormal(t.face, corners[k]));
  }
  return c;
}

}  // namespace pbdam::builder
