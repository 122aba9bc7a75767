// The terrain point of a lattice point (TerrainPoint.h).
#include "pbdam/runtime/TerrainPoint.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <utility>

namespace pbdam::runtime {

namespace {

/// A coordinate strictly inside the face: a point with both has no alias on another face.
bool insideFace(std::int32_t v, std::uint32_t latticeCells) noexcept {
  return v > 0 && std::cmp_less(v, latticeCells);
}

double planeCoordinate(std::uint32_t v, std::uint32_t latticeCells) noexcept {
  return CubeMap::uvToPlaneCoordinate(static_cast<double>(v) / static_cast<double>(latticeCells));
}

}  // namespace

glm::dvec3 latticeDirection(std::uint32_t latticeCells, int face, LatticeXY p) noexcept {
  CubeLatticePoint c{cubeFaceFromIndex(face), static_cast<std::uint32_t>(p.x),
                     static_cast<std::uint32_t>(p.y)};
  // A point inside the face has no alias on another face: skip the alias search.
  if (!insideFace(p.x, latticeCells) || !insideFace(p.y, latticeCells)) {
    c = CubeMap::canonicalLatticePoint(c, latticeCells);
  }
  // CubeMap::faceUvToDirection, spelled out so that LatticeRowDirections shares it.
  return CubeMap::planeToDirection(c.face, planeCoordinate(c.i, latticeCells),
                                   planeCoordinate(c.j, latticeCells));
}

LatticeRowDirections::LatticeRowDirections(std::uint32_t latticeCells, int face,
                                           std::int32_t y) noexcept
    : cells_(latticeCells),
      face_(face),
      y_(y),
      planeV_(planeCoordinate(static_cast<std::uint32_t>(y), latticeCells)) {}

glm::dvec3 LatticeRowDirections::at(std::int32_t x) const noexcept {
  if (!insideFace(x, cells_) || !insideFace(y_, cells_)) {
    return latticeDirection(cells_, face_, LatticeXY{x, y_});
  }
  return CubeMap::planeToDirection(cubeFaceFromIndex(face_),
                                   planeCoordinate(static_cast<std::uint32_t>(x), cells_), planeV_);
}

TerrainLine::TerrainLine(const Planet& planet, const glm::dvec3& d) noexcept
    : sphere_(planet.isSphere()), radius_(planet.equatorialRadiusMeters()), direction_(d) {
  if (sphere_) return;
  const double a = radius_;
  const double b = planet.polarRadiusMeters();
  const glm::dvec3 e(d.x / a, d.y / a, d.z / b);
  surface_ = d * (1.0 / std::sqrt(glm::dot(e, e)));
  const glm::dvec3& s = surface_;
  normal_ = glm::normalize(glm::dvec3(s.x / (a * a), s.y / (a * a), s.z / (b * b)));
}

glm::dvec3 terrainPointOfDirection(const Planet& planet, const glm::dvec3& d,
                                   double heightMeters) noexcept {
  return TerrainLine(planet, d).at(heightMeters);
}

glm::dvec3 latticeTerrainPoint(const Planet& planet, std::uint32_t latticeCells, int face,
                               LatticeXY p, double heightMeters) noexcept {
  return terrainPointOfDirection(planet, latticeDirection(latticeCells, face, p), heightMeters);
}

}  // namespace pbdam::runtime
