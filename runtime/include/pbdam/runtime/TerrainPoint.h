// The terrain point of a lattice point: where the builder measures a vertex and where the runtime
// draws it (docs/builder.md "Errors and bounding spheres", docs/architecture.md "Refinement and
// drawing"). One definition shared by the builder's SampleGrid and the runtime's patch decode, so
// the two agree bit for bit. Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>

#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// The unit geocentric direction of lattice point `p` of `face` on a lattice of `latticeCells`
/// cells, computed from its canonical alias (CubeMap::canonicalLatticePoint), so a point on a
/// face edge or cube corner gets bit-identical doubles from every face it belongs to. p's
/// coordinates must lie in [0, latticeCells].
glm::dvec3 latticeDirection(std::uint32_t latticeCells, int face, LatticeXY p) noexcept;

/// latticeDirection for the points of one lattice row: the same doubles, with the row's plane
/// coordinate (a tangent) computed once instead of at every point. For resampling, which asks
/// for every point of a row in turn.
class LatticeRowDirections final {
 public:
  /// The directions of row `y` of face `face`'s lattice of `latticeCells` cells a side.
  LatticeRowDirections(std::uint32_t latticeCells, int face, std::int32_t y) noexcept;
  /// latticeDirection(latticeCells, face, {x, y}).
  glm::dvec3 at(std::int32_t x) const noexcept;

 private:
  std::uint32_t cells_;
  int face_;
  std::int32_t y_;
  double planeV_;
};

/// The line of terrain points of one direction, h ↦ T(h): (R + h)·d on a sphere; on an
/// ellipsoid S + h·n(S) with S = d / |(dx/a, dy/a, dz/b)| and n(S) ∝ (Sx/a², Sy/a², Sz/b²).
/// Made once for a direction whose points at several heights are wanted (the builder's morph
/// targets): `at` is terrainPointOfDirection's arithmetic, so the same doubles.
class TerrainLine final {
 public:
  /// The line of `unitDirection` (unit length) on `planet`'s reference surface.
  TerrainLine(const Planet& planet, const glm::dvec3& unitDirection) noexcept;
  /// The terrain point at `heightMeters`.
  glm::dvec3 at(double heightMeters) const noexcept {
    return sphere_ ? (radius_ + heightMeters) * direction_ : surface_ + heightMeters * normal_;
  }

 private:
  bool sphere_ = true;
  double radius_ = 0.0;        // a sphere's
  glm::dvec3 direction_{0.0};  // a sphere's
  glm::dvec3 surface_{0.0};    // an ellipsoid's S
  glm::dvec3 normal_{0.0};     // an ellipsoid's n(S)
};

/// The reference-surface point on the ray along `unitDirection` raised by `heightMeters` along
/// the planet's surface normal there: (R + h)·d on a sphere; on an ellipsoid S + h·n(S) with
/// S = d / |(dx/a, dy/a, dz/b)| and n(S) ∝ (Sx/a², Sy/a², Sz/b²), closed form (no trigonometry).
glm::dvec3 terrainPointOfDirection(const Planet& planet, const glm::dvec3& unitDirection,
                                   double heightMeters) noexcept;

/// terrainPointOfDirection(latticeDirection(latticeCells, face, p), heightMeters): the terrain
/// point of a lattice point at a height. The builder's SampleGrid::terrainPoint and the runtime's
/// decode (PatchDraw.h, PatchVertexPlacement) both call this.
glm::dvec3 latticeTerrainPoint(const Planet& planet, std::uint32_t latticeCells, int face,
                               LatticeXY p, double heightMeters) noexcept;

}  // namespace pbdam::runtime
