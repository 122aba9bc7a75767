// Morph targets (MorphTargets.h).
#include "pbdam/builder/MorphTargets.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <optional>
#include <utility>
#include <vector>

#include "LatticePlane.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/TerrainPoint.h"

using namespace pbdam::formats;
using pbdam::runtime::LatticeXY;

namespace pbdam::builder {
namespace {

/// Twice the signed area of (a, b, q): positive when q is left of a→b.
std::int64_t orient(LatticeXY a, LatticeXY b, LatticeXY q) noexcept {
  return (std::int64_t{b.x} - a.x) * (std::int64_t{q.y} - a.y) -
         (std::int64_t{b.y} - a.y) * (std::int64_t{q.x} - a.x);
}

/// runtime::latticeDirection through a LatticePlane kept per thread: the morph targets ask the
/// direction of every vertex of every patch and of its coarser patches' corners, two tangents
/// each, over a few thousand lines.
glm::dvec3 latticeDirectionOf(std::uint32_t cells, int face, LatticeXY q) {
  thread_local std::optional<LatticePlane> plane;
  if (!plane || plane->sideCells() != cells) plane.emplace(cells);
  return plane->direction(runtime::cubeFaceFromIndex(face), q.x, q.y);
}

/// The line of a lattice point's terrain points: T(h) = origin + h·normal.
struct HeightLine final {
  glm::dvec3 origin{0.0};
  glm::dvec3 normal{0.0};
};

HeightLine heightLine(const MorphGeometry& g, int face, LatticeXY q) {
  // latticeTerrainPoint at heights 0 and 1 from one TerrainLine (the same doubles; every patch
  // vertex asks for its line, and the ellipsoid's point and normal are then made once).
  const runtime::TerrainLine line(*g.planet, latticeDirectionOf(g.lattice->sideCells(), face, q));
  const glm::dvec3 origin = line.at(0.0);
  return {origin, line.at(1.0) - origin};
}

/// The height of the line's point closest to the segment a–b's line.
double heightNearSegment(const HeightLine& line, const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 e = b - a;
  const glm::dvec3 w = line.origin - a;
  // Minimise |w + h·n − t·e|²: [n·n, −n·e; n·e, −e·e] (h, t) = (−w·n, −w·e).
  const double nn = glm::dot(line.normal, line.normal);
  const double ne = glm::dot(line.normal, e);
  const double ee = glm::dot(e, e);
  const double wn = glm::dot(w, line.normal);
  const double we = glm::dot(w, e);
  const double det = ne * ne - nn * ee;
  return det != 0.0 ? (ee * wn - ne * we) / det : 0.0;
}

}  // namespace

std::optional<std::vector<LatticeXY>> patchLatticePoints(const runtime::BinTriangle& t,
                                                         const PatchMesh& mesh) {
  const LatticeXY e1 = t.left - t.apex;
  const LatticeXY e2 = t.right - t.apex;
  std::vector<LatticeXY> points(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const std::int64_t b1 = mesh.vertices[v].b1;
    const std::int64_t b2 = mesh.vertices[v].b2;
    const std::int64_t x = b1 * e1.x + b2 * e2.x;
    const std::int64_t y = b1 * e1.y + b2 * e2.y;
    if (x % kPatchBarycentricOne != 0 || y % kPatchBarycentricOne != 0) return std::nullopt;
    points[v] = t.apex + LatticeXY{static_cast<std::int32_t>(x / kPatchBarycentricOne),
                                   static_cast<std::int32_t>(y / kPatchBarycentricOne)};
  }
  return points;
}

CoarserSurface::CoarserSurface(const MorphGeometry& geometry, const runtime::BinTriangle& node,
                               const PatchMesh& mesh, std::vector<LatticeXY> points,
                               LatticeXY regionLow, LatticeXY regionHigh)
    : geometry_(geometry), face_(node.face), mesh_(mesh), points_(std::move(points)) {
  const std::vector<std::uint16_t>& index = mesh.indices;
  const std::size_t triangles = index.size() / 3;
  if (points_.empty() || triangles == 0) return;
  terrain_.resize(points_.size());
  hasTerrain_.assign(points_.size(), false);
  low_ = points_[0];
  high_ = points_[0];
  for (const LatticeXY& q : points_) {
    low_ = glm::min(low_, q);
    high_ = glm::max(high_, q);
  }
  low_ = glm::max(low_, regionLow);
  high_ = glm::min(high_, regionHigh);
  if (low_.x > high_.x || low_.y > high_.y) return;
  // Each triangle's box clipped to the region; empty where it does not reach it.
  std::vector<std::array<LatticeXY, 2>> boxes(triangles);
  std::size_t reaching = 0;
  for (std::size_t t = 0; t < triangles; ++t) {
    LatticeXY lo = points_[index[3 * t]];
    LatticeXY hi = lo;
    for (std::size_t k = 1; k < 3; ++k) {
      lo = glm::min(lo, points_[index[3 * t + k]]);
      hi = glm::max(hi, points_[index[3 * t + k]]);
    }
    boxes[t] = {glm::max(lo, low_), glm::min(hi, high_)};
    if (boxes[t][0].x <= boxes[t][1].x && boxes[t][0].y <= boxes[t][1].y) ++reaching;
  }
  // About two buckets per triangle: a finer grid costs the construction little and saves each
  // query triangles to test (measured against one and four buckets per triangle, and two
  // triangles per bucket).
  const std::int64_t extent = std::max<std::int64_t>(
      1, std::max(std::int64_t{high_.x} - low_.x, std::int64_t{high_.y} - low_.y));
  const auto perSide = static_cast<std::int64_t>(std::max(
      1.0, std::ceil(std::sqrt(static_cast<double>(std::max<std::size_t>(reaching, 1)) * 2.0))));
  cell_ = std::max<std::int64_t>(1, (extent + perSide - 1) / perSide);
  columns_ = (std::int64_t{high_.x} - low_.x) / cell_ + 1;
  rows_ = (std::int64_t{high_.y} - low_.y) / cell_ + 1;
  const auto buckets = static_cast<std::size_t>(columns_ * rows_);
  // Counting sort of (bucket, triangle) pairs: each triangle in every bucket its box overlaps.
  // The reaching triangles' bucket spans are found once, for both passes (offsets in the
  // region and the cell fit 32 bits: lattice coordinates do).
  struct Span {
    std::uint32_t triangle, col0, col1, row0, row1;
  };
  thread_local std::vector<Span> spans;
  spans.clear();
  const auto cell = static_cast<std::uint32_t>(cell_);
  const auto offset = [](std::int32_t v, std::int32_t from) {
    return static_cast<std::uint32_t>(std::int64_t{v} - from);
  };
  for (std::size_t t = 0; t < triangles; ++t) {
    const auto& [lo, hi] = boxes[t];
    if (lo.x > hi.x || lo.y > hi.y) continue;  // the triangle does not reach the region
    spans.push_back({static_cast<std::uint32_t>(t), offset(lo.x, low_.x) / cell,
                     offset(hi.x, low_.x) / cell, offset(lo.y, low_.y) / cell,
                     offset(hi.y, low_.y) / cell});
  }
  const auto columns = static_cast<std::size_t>(columns_);
  std::vector<std::uint32_t> count(buckets + 1, 0);
  for (const Span& span : spans) {
    for (std::size_t row = span.row0; row <= span.row1; ++row) {
      for (std::size_t col = span.col0; col <= span.col1; ++col) ++count[row * columns + col + 1];
    }
  }
  for (std::size_t b = 0; b < buckets; ++b) count[b + 1] += count[b];
  first_ = count;
  triangles_.resize(count[buckets]);
  for (const Span& span : spans) {
    for (std::size_t row = span.row0; row <= span.row1; ++row) {
      for (std::size_t col = span.col0; col <= span.col1; ++col) {
        triangles_[count[row * columns + col]++] = span.triangle;
      }
    }
  }
}

const glm::dvec3& CoarserSurface::terrainOf(std::size_t v) const {
  if (!hasTerrain_[v]) {
    // runtime::latticeTerrainPoint, with the direction from the table.
    terrain_[v] = runtime::terrainPointOfDirection(
        *geometry_.planet, latticeDirectionOf(geometry_.lattice->sideCells(), face_, points_[v]),
        static_cast<double>(mesh_.vertices[v].heightSteps) * geometry_.heightStepMeters);
    hasTerrain_[v] = true;
  }
  return terrain_[v];
}

std::optional<std::int32_t> CoarserSurface::targetAt(LatticeXY q) const {
  if (first_.empty() || q.x < low_.x || q.y < low_.y || q.x > high_.x || q.y > high_.y) {
    return std::nullopt;
  }
  const std::int64_t col = (std::int64_t{q.x} - low_.x) / cell_;
  const std::int64_t row = (std::int64_t{q.y} - low_.y) / cell_;
  const auto b = static_cast<std::size_t>(row * columns_ + col);
  const std::vector<std::uint16_t>& index = mesh_.indices;
  const double step = geometry_.heightStepMeters;
  const auto steps = [&](double h) { return static_cast<std::int32_t>(std::lround(h / step)); };
  for (std::uint32_t k = first_[b]; k < first_[b + 1]; ++k) {
    const std::size_t t = triangles_[k];
    const std::array<std::size_t, 3> v = {index[3 * t], index[3 * t + 1], index[3 * t + 2]};
    // Weights: twice the sub-areas opposite each corner, signed like the area.
    std::array<std::int64_t, 3> w = {orient(points_[v[1]], points_[v[2]], q),
                                     orient(points_[v[2]], points_[v[0]], q),
                                     orient(points_[v[0]], points_[v[1]], q)};
    std::int64_t area = w[0] + w[1] + w[2];
    if (area == 0) continue;  // degenerate
    if (area < 0) {
      for (std::int64_t& x : w) x = -x;
      area = -area;
    }
    if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
    for (std::size_t c = 0; c < 3; ++c) {
      if (points_[v[c]] == q) return mesh_.vertices[v[c]].heightSteps;  // a vertex: its own
    }
    const HeightLine line = heightLine(geometry_, face_, q);
    for (std::size_t c = 0; c < 3; ++c) {
      if (w[c] != 0) continue;
      // On the edge opposite corner c: that segment alone decides, in key order.
      std::size_t a = v[(c + 1) % 3], e = v[(c + 2) % 3];
      const Lattice& lattice = *geometry_.lattice;
      if (lattice.key(face_, points_[e]) < lattice.key(face_, points_[a])) std::swap(a, e);
      return steps(heightNearSegment(line, terrainOf(a), terrainOf(e)));
    }
    // Inside: where the line meets the triangle's plane.
    const glm::dvec3& t0 = terrainOf(v[0]);
    const glm::dvec3 normal = glm::cross(terrainOf(v[1]) - t0, terrainOf(v[2]) - t0);
    const double along = glm::dot(line.normal, normal);
    if (along == 0.0) return std::nullopt;
    return steps(glm::dot(t0 - line.origin, normal) / along);
  }
  return std::nullopt;
}

NodeAncestors nodeAncestors(std::uint64_t id, std::uint64_t nodesPerTree) noexcept {
  const std::uint64_t heap = id % nodesPerTree;
  const std::uint64_t tree = id - heap;
  NodeAncestors a;
  if (heap >= 1) a.parent = tree + (heap - 1) / 2;
  if (heap >= 3) a.grandparent = tree + ((heap - 1) / 2 - 1) / 2;
  return a;
}

std::optional<std::vector<std::int32_t>> nodeMorphTargets(
    const MorphGeometry& geometry, std::uint64_t id, int depth, const PatchMesh& mesh,
    const PatchMesh* parent, const PatchMesh* grandparent, std::uint64_t& missed) {
  if (parent == nullptr) return std::vector<std::int32_t>{};
  const Lattice& lattice = *geometry.lattice;
  const NodeAncestors ancestors = nodeAncestors(id, Lattice::nodesPerTree(depth));
  const runtime::BinTriangle self = triangleOfNode(lattice, id, depth);
  // The boxes of what each ancestor is asked: the parent the node's interior and leg vertices
  // (its whole box), the grandparent its hypotenuse vertices (the box of its hypotenuse).
  const LatticeXY nodeLow = glm::min(self.apex, glm::min(self.left, self.right));
  const LatticeXY nodeHigh = glm::max(self.apex, glm::max(self.left, self.right));
  const auto surface = [&](std::uint64_t nodeId, const PatchMesh& patch, LatticeXY low,
                           LatticeXY high) -> std::optional<CoarserSurface> {
    const runtime::BinTriangle t = triangleOfNode(lattice, nodeId, depth);
    auto corners = patchLatticePoints(t, patch);
    if (!corners) return std::nullopt;
    return std::optional<CoarserSurface>(std::in_place, geometry, t, patch, std::move(*corners),
                                         low, high);
  };
  const std::optional<CoarserSurface> up = surface(*ancestors.parent, *parent, nodeLow, nodeHigh);
  if (!up) return std::nullopt;
  const bool hasGrandparent = grandparent != nullptr && ancestors.grandparent.has_value();
  const std::optional<CoarserSurface> upUp =
      hasGrandparent ? surface(*ancestors.grandparent, *grandparent,
                               glm::min(self.left, self.right), glm::max(self.left, self.right))
                     : std::nullopt;
  if (hasGrandparent && !upUp) return std::nullopt;
  return nodeMorphTargets(self, mesh, *up, upUp ? &*upUp : nullptr, missed);
}

std::optional<std::vector<std::int32_t>> nodeMorphTargets(const runtime::BinTriangle& self,
                                                          const PatchMesh& mesh,
                                                          const CoarserSurface& parent,
                                                          const CoarserSurface* grandparent,
                                                          std::uint64_t& missed) {
  const auto points = patchLatticePoints(self, mesh);
  if (!points) return std::nullopt;
  std::vector<std::int32_t> targets(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const PatchVertex& vertex = mesh.vertices[v];
    const bool hypotenuse = std::uint32_t{vertex.b1} + vertex.b2 == kPatchBarycentricOne;
    const CoarserSurface* governing = hypotenuse ? grandparent : &parent;
    std::optional<std::int32_t> h;
    if (governing != nullptr) {
      h = governing->targetAt((*points)[v]);
      if (!h) ++missed;
    }
    targets[v] = h.value_or(vertex.heightSteps);
  }
  return targets;
}

}  // namespace pbdam::builder
