// CubeMap: tangent-adjusted cube map (docs/architecture.md "Geometry"; P-BDAM paper Sec. 3, the
// cube-map partition). Face frames and the edge table are documented in CubeMap.h; the tests check
// the table against the geometry.
#include "pbdam/runtime/CubeMap.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <glm/common.hpp>
#include <numbers>

namespace pbdam::runtime {
namespace {

constexpr double kQuarterPi = std::numbers::pi / 4.0;

// A face frame as (axis index, sign) pairs: axis 0 = x, 1 = y, 2 = z.
struct SignedAxis final {
  int axis;
  double sign;
};
struct FaceAxes final {
  SignedAxis normal;
  SignedAxis u;
  SignedAxis v;
};

constexpr std::array<FaceAxes, kCubeFaceCount> kFaceAxes{{
    {{0, +1.0}, {1, +1.0}, {2, +1.0}},  // 0 +X: U = +y, V = +z
    {{1, +1.0}, {0, -1.0}, {2, +1.0}},  // 1 +Y: U = -x, V = +z
    {{0, -1.0}, {1, -1.0}, {2, +1.0}},  // 2 -X: U = -y, V = +z
    {{1, -1.0}, {0, +1.0}, {2, +1.0}},  // 3 -Y: U = +x, V = +z
    {{2, +1.0}, {1, +1.0}, {0, -1.0}},  // 4 +Z: U = +y, V = -x
    {{2, -1.0}, {1, +1.0}, {0, +1.0}},  // 5 -Z: U = +y, V = +x
}};

using E = CubeEdge;
using F = CubeFace;
// kNeighbors[face][edge], edges in the order Bottom, Right, Top, Left.
constexpr std::array<std::array<CubeEdgeNeighbor, 4>, kCubeFaceCount> kNeighbors{{
    {{{F::NegZ, E::Top, false},
      {F::PosY, E::Left, false},
      {F::PosZ, E::Bottom, false},
      {F::NegY, E::Right, false}}},
    {{{F::NegZ, E::Right, true},
      {F::NegX, E::Left, false},
      {F::PosZ, E::Right, false},
      {F::PosX, E::Right, false}}},
    {{{F::NegZ, E::Bottom, true},
      {F::NegY, E::Left, false},
      {F::PosZ, E::Top, true},
      {F::PosY, E::Right, false}}},
    {{{F::NegZ, E::Left, false},
      {F::PosX, E::Left, false},
      {F::PosZ, E::Left, true},
      {F::NegX, E::Right, false}}},
    {{{F::PosX, E::Top, false},
      {F::PosY, E::Top, false},
      {F::NegX, E::Top, true},
      {F::NegY, E::Top, true}}},
    {{{F::NegX, E::Bottom, true},
      {F::PosY, E::Bottom, true},
      {F::PosX, E::Bottom, false},
      {F::NegY, E::Bottom, false}}},
}};

glm::dvec3 axisVector(SignedAxis axis) noexcept {
  glm::dvec3 vector{0.0};
  vector[axis.axis] = axis.sign;
  return vector;
}

// Face coordinate in [0, 1] -> point on the face plane in [-1, 1]: tan(pi/4 (2u - 1)). Odd by
// construction and exactly ±1 at the edges, so a point on a shared edge at dyadic (u,v) produces
// the same plane coordinates, hence the same bits, from both faces.
double uvToPlane(double uv) noexcept {
  const double s = 2.0 * uv - 1.0;
  const double magnitude = std::fabs(s);
  if (magnitude == 1.0) return s;
  return std::copysign(std::tan(kQuarterPi * magnitude), s);
}

// Inverse of uvToPlane.
double planeToUv(double plane) noexcept {
  const double magnitude = std::fabs(plane);
  const double s =
      magnitude == 1.0 ? plane : std::copysign(std::atan(magnitude) / kQuarterPi, plane);
  return 0.5 * s + 0.5;
}

const FaceAxes& axesOf(CubeFace face) noexcept {
  const int index = cubeFaceIndex(face);
  assert(index >= 0 && index < kCubeFaceCount);
  return kFaceAxes[static_cast<std::size_t>(index)];
}

CubeLatticePoint latticePointOnEdge(CubeFace face, CubeEdge edge, std::uint32_t parameter,
                                    std::uint32_t sideCells) noexcept {
  switch (edge) {
    case CubeEdge::Bottom:
      return {face, parameter, 0};
    case CubeEdge::Right:
      return {face, sideCells, parameter};
    case CubeEdge::Top:
      return {face, parameter, sideCells};
    case CubeEdge::Left:
      return {face, 0, parameter};
  }
  return {face, 0, 0};
}

}  // namespace

CubeFace cubeFaceFromIndex(int index) noexcept {
  assert(index >= 0 && index < kCubeFaceCount);
  return static_cast<CubeFace>(index);
}

const char* cubeFaceName(CubeFace face) noexcept {
  switch (face) {
    case CubeFace::PosX:
      return "+X";
    case CubeFace::PosY:
      return "+Y";
    case CubeFace::NegX:
      return "-X";
    case CubeFace::NegY:
      return "-Y";
    case CubeFace::PosZ:
      return "+Z";
    case CubeFace::NegZ:
      return "-Z";
  }
  return "?";
}

CubeFaceFrame CubeMap::faceFrame(CubeFace face) noexcept {
  const FaceAxes& axes = axesOf(face);
  return {axisVector(axes.normal), axisVector(axes.u), axisVector(axes.v)};
}

glm::dvec3 CubeMap::faceUvToDirection(CubeFace face, const glm::dvec2& uv) noexcept {
  return planeToDirection(face, uvToPlane(uv.x), uvToPlane(uv.y));
}

double CubeMap::uvToPlaneCoordinate(double uv) noexcept { return uvToPlane(uv); }

glm::dvec3 CubeMap::planeToDirection(CubeFace face, double planeU, double planeV) noexcept {
  const FaceAxes& axes = axesOf(face);
  // Each component is exactly one of ±1, ±a, ±b: no rounding before the normalisation.
  glm::dvec3 point{0.0};
  point[axes.normal.axis] = axes.normal.sign;
  point[axes.u.axis] = axes.u.sign * planeU;
  point[axes.v.axis] = axes.v.sign * planeV;
  const double length = std::sqrt(point.x * point.x + point.y * point.y + point.z * point.z);
  return point / length;
}

CubeFace CubeMap::faceOfDirection(const glm::dvec3& direction) noexcept {
  const double ax = std::fabs(direction.x);
  const double ay = std::fabs(direction.y);
  const double az = std::fabs(direction.z);
  if (ax >= ay && ax >= az) return direction.x > 0.0 ? CubeFace::PosX : CubeFace::NegX;
  if (ay >= az) return direction.y > 0.0 ? CubeFace::PosY : CubeFace::NegY;
  return direction.z > 0.0 ? CubeFace::PosZ : CubeFace::NegZ;
}

std::optional<glm::dvec2> CubeMap::directionToUvOnFace(CubeFace face,
                                                       const glm::dvec3& direction) noexcept {
  const FaceAxes& axes = axesOf(face);
  const double alongNormal = axes.normal.sign * direction[axes.normal.axis];
  if (!(alongNormal > 0.0)) return std::nullopt;
  const double a = axes.u.sign * direction[axes.u.axis] / alongNormal;
  const double b = axes.v.sign * direction[axes.v.axis] / alongNormal;
  return glm::dvec2(planeToUv(a), planeToUv(b));
}

FaceUv CubeMap::directionToFaceUv(const glm::dvec3& direction) noexcept {
  const CubeFace face = faceOfDirection(direction);
  const std::optional<glm::dvec2> uv = directionToUvOnFace(face, direction);
  assert(uv.has_value());  // the owning face always has the direction in its hemisphere
  const glm::dvec2 clamped = glm::clamp(uv.value_or(glm::dvec2(0.5)), 0.0, 1.0);
  return {face, clamped};
}

std::optional<glm::dvec2> CubeMap::faceUvToFaceUv(CubeFace fromFace, const glm::dvec2& uv,
                                                  CubeFace toFace) noexcept {
  if (fromFace == toFace) return uv;
  return directionToUvOnFace(toFace, faceUvToDirection(fromFace, uv));
}

CubeEdgeNeighbor CubeMap::neighbor(CubeFace face, CubeEdge edge) noexcept {
  const auto faceIndex = static_cast<std::size_t>(cubeFaceIndex(face));
  const auto edgeIndex = static_cast<std::size_t>(edge);
  assert(faceIndex < kNeighbors.size() && edgeIndex < 4);
  return kNeighbors[faceIndex][edgeIndex];
}

glm::dvec2 CubeMap::edgeParameterToUv(CubeEdge edge, double parameter) noexcept {
  switch (edge) {
    case CubeEdge::Bottom:
      return {parameter, 0.0};
    case CubeEdge::Right:
      return {1.0, parameter};
    case CubeEdge::Top:
      return {parameter, 1.0};
    case CubeEdge::Left:
      return {0.0, parameter};
  }
  return {0.0, 0.0};
}

FaceUv CubeMap::acrossEdge(CubeFace face, CubeEdge edge, double parameter) noexcept {
  const CubeEdgeNeighbor other = neighbor(face, edge);
  const double otherParameter = other.reversed ? 1.0 - parameter : parameter;
  return {other.face, edgeParameterToUv(other.edge, otherParameter)};
}

CubeLatticeAliases CubeMap::latticeAliases(const CubeLatticePoint& point,
                                           std::uint32_t sideCells) noexcept {
  assert(sideCells > 0 && point.i <= sideCells && point.j <= sideCells);
  CubeLatticeAliases aliases;
  aliases.points[0] = point;
  aliases.count = 1;
  // Walk across every edge each known alias lies on; a corner reaches its third face through
  // either neighbour.
  for (int k = 0; k < aliases.count; ++k) {
    const CubeLatticePoint p = aliases.points[static_cast<std::size_t>(k)];
    struct OnEdge final {
      bool on;
      CubeEdge edge;
      std::uint32_t parameter;
    };
    const std::array<OnEdge, 4> edges{{
        {p.j == 0, CubeEdge::Bottom, p.i},
        {p.i == sideCells, CubeEdge::Right, p.j},
        {p.j == sideCells, CubeEdge::Top, p.i},
        {p.i == 0, CubeEdge::Left, p.j},
    }};
    for (const OnEdge& e : edges) {
      if (!e.on) continue;
      const CubeEdgeNeighbor other = neighbor(p.face, e.edge);
      const std::uint32_t parameter = other.reversed ? sideCells - e.parameter : e.parameter;
      const CubeLatticePoint alias =
          latticePointOnEdge(other.face, other.edge, parameter, sideCells);
      const auto end = aliases.points.begin() + aliases.count;
      const bool known = std::any_of(aliases.points.begin(), end, [&](const CubeLatticePoint& q) {
        return q.face == alias.face;
      });
      if (!known && aliases.count < 3) {
        aliases.points[static_cast<std::size_t>(aliases.count++)] = alias;
      }
    }
  }
  return aliases;
}

CubeLatticePoint CubeMap::canonicalLatticePoint(const CubeLatticePoint& point,
                                                std::uint32_t sideCells) noexcept {
  const CubeLatticeAliases aliases = latticeAliases(point, sideCells);
  return *std::min_element(aliases.points.begin(), aliases.points.begin() + aliases.count);
}

FaceUv CubeMap::latLonToFaceUv(double latDegrees, double lonDegrees) noexcept {
  return directionToFaceUv(planetocentricToDirection(latDegrees, lonDegrees));
}

LatLonDegrees CubeMap::faceUvToLatLon(CubeFace face, const glm::dvec2& uv) noexcept {
  return directionToPlanetocentric(faceUvToDirection(face, uv));
}

}  // namespace pbdam::runtime
