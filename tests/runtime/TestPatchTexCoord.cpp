// Texture coordinates from position (PatchDraw.h, gpu/shaders/patch_texcoord.glsl): for terrain
// points of lattice points, built as the builder builds them (CubeMap::faceUvToDirection, then
// the ellipsoid's geodetic height), shaderTexCoord — the shader's float formula on the CPU —
// equals the lattice-linear texture coordinate tc = (border + ((x − qi·side)/side)·inner)/size
// within 1e-3 texel on a sphere and on Earth (WGS84), for coarse and fine tiles (down to texels of
// one 2^-16 lattice cell), from cameras near and a few tiles away, and for points on face edges and
// corners evaluated with the record of every face that has them. On the Mars IAU 2000 ellipsoid
// (flattening 1/170) the shader's single fixed-point step leaves up to 0.79 m of error at 21 km
// (0.064 m for Everest on WGS84; two steps would leave 5 mm), about 0.01 of its 80 m texels.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <glm/geometric.hpp>
#include <optional>
#include <random>
#include <vector>

#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Planet.h"

using namespace pbdam::runtime;

namespace pbdam::runtime {
namespace {

// A paper-scale lattice (2^16 cells per face side) with 256-texel tiles: at level 8 a texel is
// about one lattice cell (80 m on Mars, 150 m on Earth).
constexpr std::uint32_t kLatticeCells = 1u << 16;
constexpr std::uint32_t kTileTexels = 256;
constexpr std::uint32_t kBorderTexels = 2;

// The builder's terrain point (tools/builder SampleGrid::terrainPoint).
glm::dvec3 terrainPoint(const Planet& planet, const glm::dvec3& direction, double heightMeters) {
  if (planet.isSphere()) return (planet.equatorialRadiusMeters() + heightMeters) * direction;
  const GeodeticPosition g = planet.directionToGeodetic(direction);
  return planet.geodeticToEcef(g.latDegrees, g.lonDegrees, heightMeters);
}

// The texture coordinate the old lattice-linear interpolation gave a lattice point.
double latticeTexCoord(std::int64_t x, std::uint32_t q, std::uint32_t level) {
  const double side = static_cast<double>(kLatticeCells >> level);
  const double inner = kTileTexels - 2.0 * kBorderTexels;
  const double local = (static_cast<double>(x) - q * side) / side;
  return (kBorderTexels + local * inner) / kTileTexels;
}

struct LatticePoint {
  CubeFace face;
  std::int64_t x, y;
};

// Every face that has the point (1 inside a face, 2 on an edge, 3 at a corner), with its
// lattice coordinates there.
std::vector<LatticePoint> aliases(const LatticePoint& p) {
  const double cells = kLatticeCells;
  const glm::dvec2 uv(static_cast<double>(p.x) / cells, static_cast<double>(p.y) / cells);
  std::vector<LatticePoint> out;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    const CubeFace face = cubeFaceFromIndex(f);
    const std::optional<glm::dvec2> there = CubeMap::faceUvToFaceUv(p.face, uv, face);
    if (!there) continue;
    const glm::dvec2 cellsThere = *there * cells;
    const double x = std::round(cellsThere.x), y = std::round(cellsThere.y);
    if (x < 0.0 || y < 0.0 || x > cells || y > cells) continue;
    if (std::fabs(cellsThere.x - x) > 1e-6 || std::fabs(cellsThere.y - y) > 1e-6) continue;
    out.push_back({face, static_cast<std::int64_t>(x), static_cast<std::int64_t>(y)});
  }
  return out;
}

struct Worst {
  double texels = 0.0;
  std::size_t checked = 0;
};

// Checks point `p` at height `h` from every face that has it, with cameras near and far.
void checkPoint(const Planet& planet, const LatticePoint& p, double h, std::uint32_t level,
                double toleranceTexels, Worst& worst) {
  const glm::dvec2 uv(static_cast<double>(p.x) / kLatticeCells,
                      static_cast<double>(p.y) / kLatticeCells);
  const glm::dvec3 direction = CubeMap::faceUvToDirection(p.face, uv);
  const glm::dvec3 terrain = terrainPoint(planet, direction, h);
  const glm::dvec3 up = direction;
  const glm::dvec3 side = glm::normalize(glm::cross(up, glm::dvec3(0.3, 0.5, 0.8)));
  // Cameras close by, a tile away and ten tiles away (the distances from which a tile of this
  // level is drawn; from farther, the vertex's own camera-relative float rounding, which the
  // texture coordinate follows, reaches 1e-3 texel).
  const double tileMeters =
      planet.equatorialRadiusMeters() * 1.6 / static_cast<double>(1u << level);
  const std::array<glm::dvec3, 3> cameras{terrain + 150.0 * up + 40.0 * side,
                                          terrain + tileMeters * (up + side),
                                          terrain + 10.0 * tileMeters * (up - 0.5 * side)};
  const std::vector<LatticePoint> faces = aliases(p);
  ASSERT_GE(faces.size(), 1u);
  const auto tiles = std::int64_t{1} << level;
  const std::int64_t sideCells = kLatticeCells >> level;
  for (const LatticePoint& a : faces) {
    // The tile of this face that contains the point (the last one for points on its far edge).
    const auto qi = static_cast<std::uint32_t>(std::min(a.x / sideCells, tiles - 1));
    const auto qj = static_cast<std::uint32_t>(std::min(a.y / sideCells, tiles - 1));
    const PatchTextureTile tile =
        patchTextureTile(a.face, kLatticeCells, level, qi, qj, kTileTexels, kBorderTexels, 3);
    const glm::dvec2 expected(latticeTexCoord(a.x, qi, level), latticeTexCoord(a.y, qj, level));
    for (const glm::dvec3& camera : cameras) {
      PatchDrawRecord record{};
      setPatchTexture(record, planet, tile, camera);
      EXPECT_EQ(record.corner[0][3], 3.0f) << "texture layer";
      const glm::vec2 tc = shaderTexCoord(record, glm::vec3(terrain - camera));
      const double texels = std::max(std::fabs(static_cast<double>(tc.x) - expected.x),
                                     std::fabs(static_cast<double>(tc.y) - expected.y)) *
                            kTileTexels;
      worst.texels = std::max(worst.texels, texels);
      ++worst.checked;
      if (!(texels <= toleranceTexels)) {
        ADD_FAILURE() << planet.name() << " face " << cubeFaceIndex(a.face) << " level " << level
                      << " tile " << qi << "," << qj << " point " << a.x << "," << a.y << " height "
                      << h << " m: tc " << tc.x << "," << tc.y << " expected " << expected.x << ","
                      << expected.y << " (" << texels << " texels)";
        return;
      }
    }
  }
}

void checkPlanet(const Planet& planet, const std::vector<double>& heights, double toleranceTexels) {
  std::mt19937 random(7);
  Worst worst;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    const CubeFace face = cubeFaceFromIndex(f);
    for (const std::uint32_t level : {0u, 3u, 8u}) {
      const std::int64_t sideCells = kLatticeCells >> level;
      const std::int64_t last = (std::int64_t{1} << level) - 1;
      // Corner tiles of the face (their points include the face's edges and corners), a middle
      // tile and a random one.
      std::uniform_int_distribution<std::int64_t> anyTile(0, last);
      const std::vector<std::array<std::int64_t, 2>> tiles{{0, 0},
                                                           {last, 0},
                                                           {0, last},
                                                           {last, last},
                                                           {last / 2, last / 2},
                                                           {anyTile(random), anyTile(random)}};
      std::uniform_int_distribution<std::int64_t> anyCell(0, sideCells);
      for (const auto& [qi, qj] : tiles) {
        std::vector<std::array<std::int64_t, 2>> points;
        for (const std::int64_t i : {std::int64_t{0}, sideCells / 2, sideCells}) {
          for (const std::int64_t j : {std::int64_t{0}, sideCells / 2, sideCells}) {
            points.push_back({i, j});
          }
        }
        for (int n = 0; n < 8; ++n) points.push_back({anyCell(random), anyCell(random)});
        for (const auto& [i, j] : points) {
          const LatticePoint p{face, qi * sideCells + i, qj * sideCells + j};
          for (const double h : heights) {
            checkPoint(planet, p, h, level, toleranceTexels, worst);
            if (::testing::Test::HasFailure()) return;
          }
        }
      }
    }
  }
  EXPECT_GT(worst.checked, 10000u);
  std::printf("%s: worst %.2e texels over %zu evaluations\n", planet.name().c_str(), worst.texels,
              worst.checked);
}

TEST(PatchTexCoord, MatchesTheLatticeTexCoordOnASphere) {
  checkPlanet(Planet::mars(), {-8200.0, 0.0, 3000.0, 21300.0}, 1e-3);
}

TEST(PatchTexCoord, MatchesTheLatticeTexCoordOnTheMarsEllipsoid) {
  checkPlanet(Planet::marsIau2000(), {-8200.0, 0.0, 3000.0, 21300.0}, 1e-3);
}

TEST(PatchTexCoord, MatchesTheLatticeTexCoordOnTheEarthEllipsoid) {
  checkPlanet(Planet::earthWgs84(), {-11000.0, 0.0, 1500.0, 8850.0}, 1e-3);
}

TEST(PatchTexCoord, TileCentreIsHalfAndScaleIsTheLatticeFormulaSlope) {
  // Level 2 tile (1, 3) of a 1024-cell lattice: side 256 cells, centre at cells (384, 896).
  const PatchTextureTile tile = patchTextureTile(CubeFace::NegY, 1024, 2, 1, 3, 256, 2, 9);
  EXPECT_EQ(tile.face, CubeFace::NegY);
  EXPECT_DOUBLE_EQ(tile.centerFaceUv.x, 384.0 / 1024.0);
  EXPECT_DOUBLE_EQ(tile.centerFaceUv.y, 896.0 / 1024.0);
  EXPECT_DOUBLE_EQ(tile.texCoordPerFaceUv, 4.0 * 252.0 / 256.0);
  EXPECT_EQ(tile.textureLayer, 9u);
}

}  // namespace
}  // namespace pbdam::runtime
