// CubeMap: the tangent-adjusted cube map that partitions the planet into 6 faces
// (docs/architecture.md "Geometry", P-BDAM paper Sec. 3): face + (u,v) <-> geocentric unit
// direction <-> lat/lon, face-edge neighbours, and canonical keys for lattice points shared by 2 or
// 3 faces.
//
// Face frames. Every face has an outward axis n and in-plane axes U, V with U x V = n, so (u,v)
// is counter-clockwise seen from outside on every face (a triangle wound counter-clockwise in
// (u,v) is front-facing from outside, on all faces). With s = 2u - 1, t = 2v - 1 in [-1, 1]:
//     direction = normalize(n + tan(pi/4 s) U + tan(pi/4 t) V)
//
//     face  n    U (u grows)  V (v grows)   covers
//     0 +X  +x   +y           +z            lon -45..45, the equatorial ring: u eastwards,
//     1 +Y  +y   -x           +z            lon 45..135   v northwards
//     2 -X  -x   -y           +z            lon 135..-135
//     3 -Y  -y   +x           +z            lon -135..-45
//     4 +Z  +z   +y           -x            north cap; v = 0 edge touches face 0
//     5 -Z  -z   +y           +x            south cap; v = 1 edge touches face 0
//
// Unfolded (each face drawn with u to the right, v up; faces 4 and 5 attach to face 0):
//
//              [4 +Z]
//     [3 -Y]   [0 +X]   [1 +Y]   [2 -X]
//              [5 -Z]
//
// Edges: Bottom is v = 0, Right u = 1, Top v = 1, Left u = 0 (counter-clockwise order). The
// parameter along an edge is u on Bottom/Top and v on Left/Right. `reversed` means the neighbour's
// parameter is 1 - ours; otherwise the two are equal.
//
//     face  Bottom (v=0)       Right (u=1)        Top (v=1)          Left (u=0)
//     0 +X  5 Top              1 Left             4 Bottom           3 Right
//     1 +Y  5 Right, reversed  2 Left             4 Right            0 Right
//     2 -X  5 Bottom, reversed 3 Left             4 Top, reversed    1 Right
//     3 -Y  5 Left             0 Left             4 Left, reversed   2 Right
//     4 +Z  0 Top              1 Top              2 Top, reversed    3 Top, reversed
//     5 -Z  2 Bottom, reversed 1 Bottom, reversed 0 Bottom           3 Bottom
//
// Directions are geocentric: on a sphere lat/lon here are the usual ones; on an ellipsoid they
// are planetocentric, and Planet::directionToGeodetic / geodeticToDirection convert (Planet.h).
// Points on a shared edge or corner at dyadic (u,v) (any lattice of side 2^n) give bit-identical
// directions from every face they belong to. All functions are pure and thread-safe.
#pragma once

#include <array>
#include <compare>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>

#include "pbdam/runtime/Direction.h"

namespace pbdam::runtime {

/// One of the six cube faces; the numeric value is the face index used in datasets.
enum class CubeFace : std::uint8_t { PosX = 0, PosY = 1, NegX = 2, NegY = 3, PosZ = 4, NegZ = 5 };

/// Faces of the cube map.
inline constexpr int kCubeFaceCount = 6;

/// Returns the face with index `index`, which must be in [0, 6).
CubeFace cubeFaceFromIndex(int index) noexcept;
/// Returns the face index in [0, 6).
constexpr int cubeFaceIndex(CubeFace face) noexcept { return static_cast<int>(face); }
/// Returns "+X", "+Y", "-X", "-Y", "+Z" or "-Z".
const char* cubeFaceName(CubeFace face) noexcept;

/// A face edge, in counter-clockwise order around the face.
enum class CubeEdge : std::uint8_t {
  Bottom = 0,  ///< v = 0, parameter u
  Right = 1,   ///< u = 1, parameter v
  Top = 2,     ///< v = 1, parameter u
  Left = 3,    ///< u = 0, parameter v
};

/// A point of the cube map: a face and (u,v) in [0, 1]².
struct FaceUv final {
  CubeFace face = CubeFace::PosX;  ///< the face
  glm::dvec2 uv{0.0};              ///< (u, v) on it
};

/// The axes of a face (see the table at the top of this file).
struct CubeFaceFrame final {
  glm::dvec3 normal{0.0};  ///< outward axis through the face centre
  glm::dvec3 uAxis{0.0};   ///< direction in which u grows
  glm::dvec3 vAxis{0.0};   ///< direction in which v grows
};

/// The face on the other side of an edge, which of its edges it is, and whether the parameter
/// along the edge runs the other way there (neighbour parameter = 1 - ours).
struct CubeEdgeNeighbor final {
  CubeFace face = CubeFace::PosX;    ///< the neighbouring face
  CubeEdge edge = CubeEdge::Bottom;  ///< the shared edge, as that face names it
  bool reversed = false;             ///< whether the parameter along it runs the other way
};

/// A point of a face's integer lattice of side `sideCells` cells: i along u, j along v, both in
/// [0, sideCells]; (u, v) = (i, j) / sideCells.
struct CubeLatticePoint final {
  CubeFace face = CubeFace::PosX;  ///< the face
  std::uint32_t i = 0;             ///< cells along u
  std::uint32_t j = 0;             ///< cells along v

  // clang-tidy 14 mistakes the 0 its defaulted <=> compares against for a null pointer.
  /// Ordered by face, then i, then j.
  friend auto operator<=>(const CubeLatticePoint&,
                          const CubeLatticePoint&) = default;  // NOLINT(modernize-use-nullptr)
};

/// The (one to three) lattice points, on different faces, that are the same point of the sphere.
struct CubeLatticeAliases final {
  std::array<CubeLatticePoint, 3> points{};  ///< the first `count` are used
  int count = 0;                             ///< 1 inside a face, 2 on an edge, 3 at a cube corner
};

/// The tangent-adjusted cube map. Stateless: every member is static.
class CubeMap final {
 public:
  CubeMap() = delete;

  /// Returns the frame of `face`.
  static CubeFaceFrame faceFrame(CubeFace face) noexcept;

  /// Returns the unit geocentric direction of (u,v) on `face`. (u,v) is normally in [0, 1]²;
  /// values in (-0.5, 1.5) extend the face beyond its edges (past the neighbour's area).
  /// @{
  static glm::dvec3 faceUvToDirection(CubeFace face, const glm::dvec2& uv) noexcept;
  static glm::dvec3 faceUvToDirection(const FaceUv& point) noexcept {
    return faceUvToDirection(point.face, point.uv);
  }
  /// @}

  /// The plane coordinate tan(π/4·(2u − 1)) of face coordinate u (exactly ±1 at the edges).
  static double uvToPlaneCoordinate(double uv) noexcept;
  /// faceUvToDirection from the plane coordinates of u and v (uvToPlaneCoordinate): the same
  /// bits, for callers that reuse plane coordinates along a lattice row or column.
  static glm::dvec3 planeToDirection(CubeFace face, double planeU, double planeV) noexcept;

  /// Returns the face that owns `direction` (non-zero, need not be unit): the axis of the
  /// largest-magnitude component, with ties (points on face edges) resolved towards x, then y.
  static CubeFace faceOfDirection(const glm::dvec3& direction) noexcept;
  /// Returns faceOfDirection(direction) and the (u,v) in [0, 1]² there.
  static FaceUv directionToFaceUv(const glm::dvec3& direction) noexcept;
  /// Returns the (u,v) of `direction` on `face` even if the face does not own it (u or v then
  /// lie outside [0, 1]), or nullopt if `direction` is not in the face's open hemisphere.
  static std::optional<glm::dvec2> directionToUvOnFace(CubeFace face,
                                                       const glm::dvec3& direction) noexcept;
  /// Converts (u,v) on `fromFace` to `toFace`'s (u,v) through the direction (see
  /// directionToUvOnFace); e.g. for points on or near a shared edge.
  static std::optional<glm::dvec2> faceUvToFaceUv(CubeFace fromFace, const glm::dvec2& uv,
                                                  CubeFace toFace) noexcept;

  /// Returns the neighbour across `edge` of `face` (the table at the top of this file).
  static CubeEdgeNeighbor neighbor(CubeFace face, CubeEdge edge) noexcept;
  /// Returns the (u,v) of the point at `parameter` in [0, 1] along `edge` (u on Bottom/Top, v on
  /// Left/Right).
  static glm::dvec2 edgeParameterToUv(CubeEdge edge, double parameter) noexcept;
  /// Returns the neighbour's (face, u, v) of the point at `parameter` along `edge` of `face`,
  /// computed from the table (exact: 1 - parameter where reversed, no trigonometry).
  static FaceUv acrossEdge(CubeFace face, CubeEdge edge, double parameter) noexcept;

  /// Returns every lattice point (on any face) equal to `point` on the sphere, `point` first.
  /// `sideCells` must be > 0 and the point's i, j must be <= sideCells.
  static CubeLatticeAliases latticeAliases(const CubeLatticePoint& point,
                                           std::uint32_t sideCells) noexcept;
  /// Returns the smallest (face, i, j) of latticeAliases(point): one key per sphere point.
  static CubeLatticePoint canonicalLatticePoint(const CubeLatticePoint& point,
                                                std::uint32_t sideCells) noexcept;

  /// Planetocentric lat/lon <-> face (u,v) shortcuts (Direction.h for the angle conventions).
  /// @{
  static FaceUv latLonToFaceUv(double latDegrees, double lonDegrees) noexcept;
  static LatLonDegrees faceUvToLatLon(CubeFace face, const glm::dvec2& uv) noexcept;
  /// @}
};

}  // namespace pbdam::runtime
