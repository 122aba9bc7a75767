// The terrain point of a lattice point (TerrainPoint.h).
#include "pbdam/runtime/TerrainPoint.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <new>
#include <utility>
#include <vector>

namespace pbdam::runtime {

namespace {

/// A coordinate strictly inside the face: a point with both has no alias on another face.
bool insideFace(std::int32_t v, std::uint32_t latticeCells) noexcept {
  return v > 0 && std::cmp_less(v, latticeCells);
}

double planeCoordinateOf(std::uint32_t v, std::uint32_t latticeCells) noexcept {
  return CubeMap::uvToPlaneCoordinate(static_cast<double>(v) / static_cast<double>(latticeCells));
}

/// Lattices up to this many cells a side keep their plane coordinates in a table per thread
/// (8 bytes a lattice line: 512 KiB at most); finer ones compute each.
constexpr std::uint32_t kTabulatedCells = 1U << 16;

/// The plane coordinate of lattice line v: a tangent, the same double whether computed or
/// looked up (the table holds exactly what planeCoordinateOf returns), so the terrain points
/// are bit-identical either way; a builder places tens of millions of lattice points.
double planeCoordinate(std::uint32_t v, std::uint32_t latticeCells) noexcept {
  if (latticeCells > kTabulatedCells) return planeCoordinateOf(v, latticeCells);
  struct Table {
    std::uint32_t cells = 0;
    std::vector<double> values;
  };
  thread_local Table table;
  if (table.cells != latticeCells) {
    try {
      table.values.resize(std::size_t{latticeCells} + 1);
    } catch (const std::bad_alloc&) {
      return planeCoordinateOf(v, latticeCells);  // no table: computed, the same double
    }
    for (std::uint32_t k = 0; k <= latticeCells; ++k) {
      table.values[k] = planeCoordinateOf(k, latticeCells);
    }
    table.cells = latticeCells;
  }
  return table.values[v];
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
