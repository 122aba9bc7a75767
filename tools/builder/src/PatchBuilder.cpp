// Leaf patches and node corners (PatchBuilder.h; paper 004 §4.2 displaced triangles). The
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

void bisectToCells(const BinTriangle& t, IndexedPatch& out) {
  const LatticeXY leg = t.left - t.apex;
  if (std::abs(leg.x) + std::abs(leg.y) == 1) {  // an axis-aligned unit leg: one grid half-cell
    out.addTriangle(t.apex, t.left, t.right);
    return;
  }
  for (const BinTriangle& c : Lattice::children(t)) bisectToCells(c, out);
}

}  // namespace

WorkPatch makeLeafPatch(const BinTriangle& triangle) {
  // The bisection depends only on the triangle's shape (its legs as vectors): leaves of one
  // shape are translates of each other, so each thread builds each shape once and translates it.
  struct Shape {
    LatticeXY toLeft;
    LatticeXY toRight;
    WorkPatch relative;  // points relative to the apex
  };
  thread_local std::vector<Shape> shapes;
  const LatticeXY toLeft = triangle.left - triangle.apex;
  const LatticeXY toRight = triangle.right - triangle.apex;
  const Shape* shape = nullptr;
  for (const Shape& s : shapes) {
    if (s.toLeft == toLeft && s.toRight == toRight) shape = &s;
  }
  if (shape == nullptr) {
    IndexedPatch mesh;
    bisectToCells(triangle, mesh);
    WorkPatch patch = compact(mesh.points, mesh.indices);
    for (LatticeXY& p : patch.points) p -= triangle.apex;
    shapes.push_back(Shape{toLeft, toRight, std::move(patch)});
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
