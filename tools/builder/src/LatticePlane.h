// The plane coordinates of a lattice's lines, computed once (private to the builder).
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <utility>
#include <vector>

#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/Direction.h"
#include "pbdam/runtime/TerrainPoint.h"

namespace pbdam::builder {

/// The plane coordinates (tangents) of a lattice's columns and rows, computed once for every row
/// that resampling and the morph targets ask for: latticeDirection's directions, bit for bit,
/// without a tangent at every point.
class LatticePlane final {
 public:
  explicit LatticePlane(std::uint32_t sideCells) : cells_(sideCells), plane_(sideCells + 1) {
    for (std::uint32_t v = 0; v <= sideCells; ++v) {
      plane_[v] = runtime::CubeMap::uvToPlaneCoordinate(static_cast<double>(v) /
                                                        static_cast<double>(sideCells));
    }
  }
  std::uint32_t sideCells() const noexcept { return cells_; }
  /// latticeDirection(sideCells, face, {x, y}).
  glm::dvec3 direction(runtime::CubeFace face, std::int32_t x, std::int32_t y) const noexcept {
    // Points on a face edge take their canonical alias's direction (latticeDirection).
    if (!inside(x) || !inside(y))
      return runtime::latticeDirection(cells_, runtime::cubeFaceIndex(face), {x, y});
    return runtime::CubeMap::planeToDirection(face, plane_[static_cast<std::size_t>(x)],
                                              plane_[static_cast<std::size_t>(y)]);
  }

 private:
  bool inside(std::int32_t v) const noexcept { return v > 0 && std::cmp_less(v, cells_); }
  std::uint32_t cells_;
  std::vector<double> plane_;
};

}  // namespace pbdam::builder
