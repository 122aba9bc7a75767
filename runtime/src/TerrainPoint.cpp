// The terrain point of a lattice point (TerrainPoint.h).
#include "pbdam/runtime/TerrainPoint.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <utility>

namespace pbdam::runtime {

glm::dvec3 latticeDirection(std::uint32_t latticeCells, int face, LatticeXY p) noexcept {
  const double n = static_cast<double>(latticeCells);
  CubeLatticePoint c{cubeFaceFromIndex(face), static_cast<std::uint32_t>(p.x),
                     static_cast<std::uint32_t>(p.y)};
  // A point inside the face has no alias on another face: skip the alias search.
  const bool interior =
      p.x > 0 && p.y > 0 && std::cmp_less(p.x, latticeCells) && std::cmp_less(p.y, latticeCells);
  if (!interior) c = CubeMap::canonicalLatticePoint(c, latticeCells);
  return CubeMap::faceUvToDirection(c.face,
                                    {static_cast<double>(c.i) / n, static_cast<double>(c.j) / n});
}

glm::dvec3 terrainPointOfDirection(const Planet& planet, const glm::dvec3& d,
                                   double heightMeters) noexcept {
  const double a = planet.equatorialRadiusMeters();
  if (planet.isSphere()) return (a + heightMeters) * d;
  const double b = planet.polarRadiusMeters();
  const glm::dvec3 e(d.x / a, d.y / a, d.z / b);
  const glm::dvec3 s = d * (1.0 / std::sqrt(glm::dot(e, e)));
  const glm::dvec3 n = glm::normalize(glm::dvec3(s.x / (a * a), s.y / (a * a), s.z / (b * b)));
  return s + heightMeters * n;
}

glm::dvec3 latticeTerrainPoint(const Planet& planet, std::uint32_t latticeCells, int face,
                               LatticeXY p, double heightMeters) noexcept {
  return terrainPointOfDirection(planet, latticeDirection(latticeCells, face, p), heightMeters);
}

}  // namespace pbdam::runtime
