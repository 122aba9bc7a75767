// Tests for CubeMap: round trips over dense grids (edges, corners, poles), face ownership, the
// neighbour table against the geometry, lattice aliases and the tangent adjustment's cell areas.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/TerrainPoint.h"

using namespace pbdam::runtime;

namespace pbdam::runtime {
namespace {

constexpr std::array<CubeFace, 6> kFaces{CubeFace::PosX, CubeFace::PosY, CubeFace::NegX,
                                         CubeFace::NegY, CubeFace::PosZ, CubeFace::NegZ};
constexpr std::array<CubeEdge, 4> kEdges{CubeEdge::Bottom, CubeEdge::Right, CubeEdge::Top,
                                         CubeEdge::Left};

bool sameBits(const glm::dvec3& a, const glm::dvec3& b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

// Area of the spherical triangle (a, b, c) of unit vectors (Van Oosterom & Strackee).
double sphericalTriangleArea(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const double numerator = std::fabs(glm::dot(a, glm::cross(b, c)));
  const double denominator = 1.0 + glm::dot(a, b) + glm::dot(b, c) + glm::dot(c, a);
  return 2.0 * std::atan2(numerator, denominator);
}

TEST(CubeMap, FaceFramesAreAsDocumented) {
  const std::array<glm::dvec3, 6> normals{glm::dvec3(1, 0, 0),  glm::dvec3(0, 1, 0),
                                          glm::dvec3(-1, 0, 0), glm::dvec3(0, -1, 0),
                                          glm::dvec3(0, 0, 1),  glm::dvec3(0, 0, -1)};
  for (int index = 0; index < kCubeFaceCount; ++index) {
    const CubeFace face = cubeFaceFromIndex(index);
    const CubeFaceFrame frame = CubeMap::faceFrame(face);
    EXPECT_EQ(frame.normal, normals[static_cast<std::size_t>(index)]) << cubeFaceName(face);
    EXPECT_EQ(glm::cross(frame.uAxis, frame.vAxis), frame.normal) << cubeFaceName(face);
    EXPECT_EQ(CubeMap::faceUvToDirection(face, {0.5, 0.5}), frame.normal);
  }
  // Equatorial faces: u eastwards, v northwards.
  for (CubeFace face : {CubeFace::PosX, CubeFace::PosY, CubeFace::NegX, CubeFace::NegY}) {
    const LatLonDegrees centre = CubeMap::faceUvToLatLon(face, {0.5, 0.5});
    const LatLonDegrees east = CubeMap::faceUvToLatLon(face, {0.6, 0.5});
    const LatLonDegrees north = CubeMap::faceUvToLatLon(face, {0.5, 0.6});
    EXPECT_GT(std::remainder(east.lonDegrees - centre.lonDegrees, 360.0), 0.0);
    EXPECT_GT(north.latDegrees, centre.latDegrees);
  }
  EXPECT_STREQ(cubeFaceName(CubeFace::NegY), "-Y");
}

TEST(CubeMap, UvToDirectionToUvRoundTripsOnEveryFaceIncludingEdges) {
  constexpr int kSteps = 256;
  for (CubeFace face : kFaces) {
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; j <= kSteps; ++j) {
        // Dyadic lattice plus an irrational-ish offset grid so both kinds of inputs are covered.
        for (const glm::dvec2 uv : {glm::dvec2(i, j) / double(kSteps),
                                    glm::dvec2(std::min(1.0, (i + 0.318309886) / kSteps),
                                               std::min(1.0, (j + 0.707106781) / kSteps))}) {
          const glm::dvec3 direction = CubeMap::faceUvToDirection(face, uv);
          ASSERT_NEAR(glm::length(direction), 1.0, 1e-15);
          const auto onFace = CubeMap::directionToUvOnFace(face, direction);
          ASSERT_TRUE(onFace.has_value());
          ASSERT_NEAR(onFace->x, uv.x, 1e-12) << cubeFaceName(face) << " " << i << " " << j;
          ASSERT_NEAR(onFace->y, uv.y, 1e-12) << cubeFaceName(face) << " " << i << " " << j;
          // The owning face (another one only on an edge) gives back the same direction.
          const FaceUv owner = CubeMap::directionToFaceUv(direction);
          const bool interior = uv.x > 0.0 && uv.x < 1.0 && uv.y > 0.0 && uv.y < 1.0;
          if (interior) {
            ASSERT_EQ(owner.face, face);
            ASSERT_NEAR(owner.uv.x, uv.x, 1e-12);
            ASSERT_NEAR(owner.uv.y, uv.y, 1e-12);
          }
          ASSERT_LT(glm::length(CubeMap::faceUvToDirection(owner) - direction), 1e-15);
        }
      }
    }
  }
}

TEST(CubeMap, LatLonRoundTripsIncludingPoles) {
  std::vector<double> lats;
  for (int k = -360; k <= 360; ++k) lats.push_back(k * 0.25);
  for (double nearPole : {89.9999999, 89.999999999, 89.9999999999999, 45.0000000001}) {
    lats.push_back(nearPole);
    lats.push_back(-nearPole);
  }
  for (double lat : lats) {
    for (double lon = -179.75; lon <= 180.0; lon += 0.75) {
      const LatLonDegrees back = directionToPlanetocentric(planetocentricToDirection(lat, lon));
      ASSERT_NEAR(back.latDegrees, lat, 1e-12) << lat << " " << lon;
      const FaceUv faceUv = CubeMap::latLonToFaceUv(lat, lon);
      const LatLonDegrees viaCube = CubeMap::faceUvToLatLon(faceUv.face, faceUv.uv);
      ASSERT_NEAR(viaCube.latDegrees, lat, 1e-12) << lat << " " << lon;
      if (std::fabs(lat) < 90.0) {
        ASSERT_NEAR(back.lonDegrees, lon, 1e-12) << lat << " " << lon;
        // Through (u,v), whose resolution near a face centre is ~1e-16, longitude within a few
        // nanodegrees of a pole is ill-conditioned by 1/cos(lat): check it to 1e-12 away from
        // the poles, and everywhere check the east-west displacement lonError·cos(lat).
        const double lonError = std::remainder(viaCube.lonDegrees - lon, 360.0);
        if (std::fabs(lat) <= 89.0) {
          ASSERT_NEAR(lonError, 0.0, 1e-12) << lat << " " << lon;
        }
        ASSERT_LT(std::fabs(lonError) * std::cos(lat * std::numbers::pi / 180.0), 1e-12)
            << lat << " " << lon;
      }
    }
  }
  // The poles are the centres of faces 4 and 5.
  EXPECT_EQ(CubeMap::latLonToFaceUv(90.0, 123.0).face, CubeFace::PosZ);
  EXPECT_EQ(CubeMap::latLonToFaceUv(90.0, 123.0).uv, glm::dvec2(0.5, 0.5));
  EXPECT_EQ(CubeMap::latLonToFaceUv(-90.0, 0.0).face, CubeFace::NegZ);
  EXPECT_EQ(directionToPlanetocentric({0.0, 0.0, 1.0}).latDegrees, 90.0);
  EXPECT_EQ(directionToPlanetocentric({-1.0, 0.0, 0.0}).lonDegrees, 180.0);
}

TEST(CubeMap, EveryDirectionHasExactlyOneFace) {
  std::mt19937_64 random(20240611);
  std::normal_distribution<double> gaussian;
  for (int k = 0; k < 20000; ++k) {
    const glm::dvec3 direction(gaussian(random), gaussian(random), gaussian(random));
    const glm::dvec3 unit = glm::normalize(direction);
    int owners = 0;
    for (CubeFace face : kFaces) {
      const auto uv = CubeMap::directionToUvOnFace(face, direction);
      if (uv && uv->x >= 0.0 && uv->x <= 1.0 && uv->y >= 0.0 && uv->y <= 1.0) {
        ++owners;
        EXPECT_EQ(face, CubeMap::faceOfDirection(direction));
        EXPECT_LT(glm::length(CubeMap::faceUvToDirection(face, *uv) - unit), 1e-15);
      }
    }
    ASSERT_EQ(owners, 1) << direction.x << " " << direction.y << " " << direction.z;
  }
  // Ties on edges and corners resolve to x, then y.
  EXPECT_EQ(CubeMap::faceOfDirection({1.0, 1.0, 1.0}), CubeFace::PosX);
  EXPECT_EQ(CubeMap::faceOfDirection({-1.0, 1.0, 1.0}), CubeFace::NegX);
  EXPECT_EQ(CubeMap::faceOfDirection({0.0, -1.0, -1.0}), CubeFace::NegY);
  EXPECT_EQ(CubeMap::faceOfDirection({0.0, 0.5, 1.0}), CubeFace::PosZ);
  const FaceUv corner = CubeMap::directionToFaceUv({1.0, 1.0, 1.0});
  EXPECT_EQ(corner.uv, glm::dvec2(1.0, 1.0));
}

TEST(CubeMap, NeighborRelationIsSymmetric) {
  std::set<std::pair<int, int>> seen;
  for (CubeFace face : kFaces) {
    for (CubeEdge edge : kEdges) {
      const CubeEdgeNeighbor other = CubeMap::neighbor(face, edge);
      EXPECT_NE(other.face, face);
      EXPECT_NE(glm::dot(CubeMap::faceFrame(other.face).normal, CubeMap::faceFrame(face).normal),
                -1.0);  // never the opposite face
      const CubeEdgeNeighbor back = CubeMap::neighbor(other.face, other.edge);
      EXPECT_EQ(back.face, face);
      EXPECT_EQ(back.edge, edge);
      EXPECT_EQ(back.reversed, other.reversed);
      seen.insert({cubeFaceIndex(other.face), static_cast<int>(other.edge)});
    }
  }
  EXPECT_EQ(seen.size(), 24u);  // every edge of every face is some edge's neighbour exactly once
}

TEST(CubeMap, SharedEdgePointsCoincideFromBothFaces) {
  for (CubeFace face : kFaces) {
    for (CubeEdge edge : kEdges) {
      // Dyadic parameters: bit-identical directions from both faces.
      for (int k = 0; k <= 1024; ++k) {
        const double parameter = k / 1024.0;
        const glm::dvec3 ours =
            CubeMap::faceUvToDirection(face, CubeMap::edgeParameterToUv(edge, parameter));
        const FaceUv across = CubeMap::acrossEdge(face, edge, parameter);
        const glm::dvec3 theirs = CubeMap::faceUvToDirection(across);
        ASSERT_TRUE(sameBits(ours, theirs))
            << cubeFaceName(face) << " edge " << static_cast<int>(edge) << " t=" << parameter;
        // Through the direction, the neighbour's (u,v) agrees with the table.
        const auto converted =
            CubeMap::faceUvToFaceUv(face, CubeMap::edgeParameterToUv(edge, parameter), across.face);
        ASSERT_TRUE(converted.has_value());
        ASSERT_NEAR(converted->x, across.uv.x, 1e-12);
        ASSERT_NEAR(converted->y, across.uv.y, 1e-12);
      }
      // Arbitrary parameters: equal to round-off.
      for (double parameter : {0.1, 0.3333333333333333, 0.77, 0.999}) {
        const glm::dvec3 ours =
            CubeMap::faceUvToDirection(face, CubeMap::edgeParameterToUv(edge, parameter));
        const glm::dvec3 theirs =
            CubeMap::faceUvToDirection(CubeMap::acrossEdge(face, edge, parameter));
        EXPECT_LT(glm::length(ours - theirs), 1e-15);
      }
    }
  }
}

TEST(CubeMap, FaceUvToFaceUvExtendsAcrossEdges) {
  // Just inside face 0's right edge is just outside face 1's left edge, at the same height.
  const auto onPosY = CubeMap::faceUvToFaceUv(CubeFace::PosX, {0.99, 0.3}, CubeFace::PosY);
  ASSERT_TRUE(onPosY.has_value());
  EXPECT_LT(onPosY->x, 0.0);
  EXPECT_GT(onPosY->x, -0.02);
  const auto back = CubeMap::faceUvToFaceUv(CubeFace::PosY, *onPosY, CubeFace::PosX);
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR(back->x, 0.99, 1e-12);
  EXPECT_NEAR(back->y, 0.3, 1e-12);
  EXPECT_FALSE(CubeMap::faceUvToFaceUv(CubeFace::PosX, {0.5, 0.5}, CubeFace::NegX).has_value());
}

TEST(CubeMap, LatticeAliasesGiveOneKeyPerSpherePoint) {
  constexpr std::uint32_t kSide = 16;
  std::set<CubeLatticePoint> canonical;
  for (CubeFace face : kFaces) {
    for (std::uint32_t i = 0; i <= kSide; ++i) {
      for (std::uint32_t j = 0; j <= kSide; ++j) {
        const CubeLatticePoint point{face, i, j};
        const CubeLatticeAliases aliases = CubeMap::latticeAliases(point, kSide);
        const int onEdges = (i == 0 || i == kSide ? 1 : 0) + (j == 0 || j == kSide ? 1 : 0);
        // 1 inside a face, 2 on an edge, 3 at a corner.
        ASSERT_EQ(aliases.count, 1 + onEdges) << cubeFaceName(face) << " " << i << " " << j;
        const CubeLatticePoint key = CubeMap::canonicalLatticePoint(point, kSide);
        const glm::dvec3 direction =
            CubeMap::faceUvToDirection(face, glm::dvec2(i, j) / double(kSide));
        for (int k = 0; k < aliases.count; ++k) {
          const CubeLatticePoint& alias = aliases.points[static_cast<std::size_t>(k)];
          const glm::dvec3 aliasDirection =
              CubeMap::faceUvToDirection(alias.face, glm::dvec2(alias.i, alias.j) / double(kSide));
          ASSERT_TRUE(sameBits(direction, aliasDirection));
          ASSERT_EQ(CubeMap::canonicalLatticePoint(alias, kSide), key);
          ASSERT_LE(key, alias);
        }
        canonical.insert(key);
      }
    }
  }
  // A cube whose faces are split into kSide² cells has 6 kSide² + 2 distinct vertices (Euler).
  EXPECT_EQ(canonical.size(), 6u * kSide * kSide + 2u);
}

TEST(CubeMap, TangentAdjustmentGivesNearUniformCellAreas) {
  constexpr int kCells = 64;
  auto areaRatio = [](auto toDirection) {
    double minArea = 1e9;
    double maxArea = 0.0;
    double total = 0.0;
    for (int i = 0; i < kCells; ++i) {
      for (int j = 0; j < kCells; ++j) {
        const glm::dvec3 p00 = toDirection(double(i) / kCells, double(j) / kCells);
        const glm::dvec3 p10 = toDirection(double(i + 1) / kCells, double(j) / kCells);
        const glm::dvec3 p01 = toDirection(double(i) / kCells, double(j + 1) / kCells);
        const glm::dvec3 p11 = toDirection(double(i + 1) / kCells, double(j + 1) / kCells);
        const double area =
            sphericalTriangleArea(p00, p10, p11) + sphericalTriangleArea(p00, p11, p01);
        minArea = std::min(minArea, area);
        maxArea = std::max(maxArea, area);
        total += area;
      }
    }
    EXPECT_NEAR(total, 4.0 * std::numbers::pi / 6.0, 1e-12);  // a face is a sixth of the sphere
    return maxArea / minArea;
  };
  const double tangentRatio = areaRatio([](double u, double v) {
    return CubeMap::faceUvToDirection(CubeFace::PosZ, {u, v});
  });
  // The plain (gnomonic) cube map, for contrast: the bound below would catch a missing tan().
  const CubeFaceFrame frame = CubeMap::faceFrame(CubeFace::PosZ);
  const double gnomonicRatio = areaRatio([&](double u, double v) {
    return glm::normalize(frame.normal + (2 * u - 1) * frame.uAxis + (2 * v - 1) * frame.vAxis);
  });
  EXPECT_LT(tangentRatio, 1.5);
  EXPECT_GT(tangentRatio, 1.3);  // about sqrt(2) for this projection
  EXPECT_GT(gnomonicRatio, 4.0);
  RecordProperty("tangentAreaRatio", std::to_string(tangentRatio));
  RecordProperty("gnomonicAreaRatio", std::to_string(gnomonicRatio));
}

// Resampling asks for a lattice row's directions through LatticeRowDirections, patches for single
// points through latticeDirection: both must give the same doubles everywhere, face edges and
// cube corners (the canonical alias) included.
TEST(CubeMap, RowDirectionsAreLatticeDirectionsBitForBit) {
  constexpr std::uint32_t cells = 16;
  for (int face = 0; face < kCubeFaceCount; ++face) {
    for (std::int32_t y = 0; y <= static_cast<std::int32_t>(cells); ++y) {
      const LatticeRowDirections row(cells, face, y);
      for (std::int32_t x = 0; x <= static_cast<std::int32_t>(cells); ++x) {
        const glm::dvec3 a = row.at(x);
        const glm::dvec3 b = latticeDirection(cells, face, LatticeXY{x, y});
        EXPECT_TRUE(a.x == b.x && a.y == b.y && a.z == b.z)
            << "face " << face << " point " << x << "," << y;
      }
    }
  }
}

}  // namespace
}  // namespace pbdam::runtime
