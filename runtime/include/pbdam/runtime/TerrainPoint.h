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
