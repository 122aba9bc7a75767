// Texture tile generation (TextureBuilder.h): texel placement, ramps, hillshade direction,
// border continuity across face edges, Earth and Mars content on real data, imagery, nesting
// texture errors, determinism under concurrency.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <map>
#include <memory>
#include <numbers>
#include <thread>
#include <tuple>

#include "TestData.h"
#include "pbdam/builder/TextureBuilder.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/NormalMap.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

using Colour = std::array<double, 3>;

constexpr const char* kEarthImage = "/usr/share/xplanet/images/earth.jpg";

Colour texelAt(const TextureTileImage& tile, int x, int y) {
  const std::uint8_t* texel =
      tile.data.data() +
      (static_cast<std::size_t>(y) * tile.sizeTexels + static_cast<std::size_t>(x)) * 4;
  return {static_cast<double>(texel[0]), static_cast<double>(texel[1]),
          static_cast<double>(texel[2])};
}

// Bilinear colour at continuous texel coordinates (texel centres at integers).
Colour sampleTile(const TextureTileImage& tile, double x, double y) {
  const int size = static_cast<int>(tile.sizeTexels);
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, size - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, size - 2);
  const double fx = x - x0;
  const double fy = y - y0;
  Colour out{};
  for (std::size_t c = 0; c < 3; ++c) {
    out[c] = (1 - fx) * (1 - fy) * texelAt(tile, x0, y0)[c] +
             fx * (1 - fy) * texelAt(tile, x0 + 1, y0)[c] +
             (1 - fx) * fy * texelAt(tile, x0, y0 + 1)[c] +
             fx * fy * texelAt(tile, x0 + 1, y0 + 1)[c];
  }
  return out;
}

Colour toColour(const Rgb8& rgb) {
  return {static_cast<double>(rgb[0]), static_cast<double>(rgb[1]), static_cast<double>(rgb[2])};
}

double maxChannelDifference(const Colour& a, const Colour& b) {
  return std::max({std::fabs(a[0] - b[0]), std::fabs(a[1] - b[1]), std::fabs(a[2] - b[2])});
}

Colour meanInnerColour(const TextureTileImage& tile) {
  Colour sum{};
  const int border = static_cast<int>(tile.borderTexels);
  const int size = static_cast<int>(tile.sizeTexels);
  for (int y = border; y < size - border; ++y) {
    for (int x = border; x < size - border; ++x) {
      const Colour c = texelAt(tile, x, y);
      for (std::size_t i = 0; i < 3; ++i) sum[i] += c[i];
    }
  }
  const double count = static_cast<double>((size - 2 * border) * (size - 2 * border));
  for (double& c : sum) c /= count;
  return sum;
}

// The request for the level-`level` node containing (lat, lon), and the texel coordinates of
// that point inside its tile.
struct Located final {
  TextureTileRequest request;
  double x = 0.0;
  double y = 0.0;
};

Located locate(double latDegrees, double lonDegrees, int level, std::uint32_t size) {
  const FaceUv point = CubeMap::latLonToFaceUv(latDegrees, lonDegrees);
  const double scale = std::ldexp(1.0, level);
  const auto last = static_cast<std::uint32_t>(scale) - 1;
  Located located;
  located.request.face = cubeFaceIndex(point.face);
  located.request.level = level;
  located.request.qi = std::min(static_cast<std::uint32_t>(point.uv.x * scale), last);
  located.request.qj = std::min(static_cast<std::uint32_t>(point.uv.y * scale), last);
  located.request.sizeTexels = size;
  const double inner = size - 2.0 * located.request.borderTexels;
  located.x =
      (point.uv.x * scale - located.request.qi) * inner + located.request.borderTexels - 0.5;
  located.y =
      (point.uv.y * scale - located.request.qj) * inner + located.request.borderTexels - 0.5;
  return located;
}

TextureTileImage buildOrDie(const TextureSource& source, const TextureTileRequest& request) {
  auto result = buildTextureTile(source, request);
  EXPECT_TRUE(result) << result.error().message;
  return result ? std::move(result).value().image : TextureTileImage{};
}

// Shared, lazily read data sets (each read once per test binary run).
struct Datasets final {
  static const HeightGrid* mola() {
    static const std::unique_ptr<HeightGrid> grid = read(test::dataDir() / "mars/megt90n000cb.lbl");
    return grid.get();
  }
  static const HeightGrid* etopo5() {
    static const std::unique_ptr<HeightGrid> grid = read(PBDAM_ETOPO5_PATH);
    return grid.get();
  }
  static std::unique_ptr<HeightGrid> read(const std::filesystem::path& path) {
    auto grid = readDem(path);
    EXPECT_TRUE(grid) << grid.error().message;
    return grid ? std::make_unique<HeightGrid>(std::move(grid).value()) : nullptr;
  }
};

TextureSource marsSource(const HeightGrid& grid) {
  TextureSource source;
  source.heightMeters = heightFunctionFromGrid(grid);
  source.planet = Planet::mars();
  source.ramp = {false, -8068.0, 21134.0};
  return source;
}

TextureSource earthSource(const HeightGrid& grid) {
  TextureSource source;
  source.heightMeters = heightFunctionFromGrid(grid);
  source.planet = Planet::earthWgs84();
  source.ramp = {true, -10376.0, 7833.0};
  return source;
}

TEST(TextureBuilder, InnerTexelsCoverTheNodeSquareExactly) {
  const TextureTileRequest request{3, 2, 1, 3, 16, 2};
  // Inner texel edges (half a texel outside the first and last inner centres) are the square.
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 1.5, 1.5).x, 0.25);
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 1.5, 1.5).y, 0.75);
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 13.5, 13.5).x, 0.5);
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 13.5, 13.5).y, 1.0);
  // Centres are (k + 0.5)/inner of the square, borders continue the spacing.
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 2, 2).x, 0.25 + 0.5 / 12 / 4);
  EXPECT_DOUBLE_EQ(textureTexelFaceUv(request, 0, 0).y, 0.75 - 1.5 / 12 / 4);
  EXPECT_GT(textureTexelFaceUv(request, 15, 15).y, 1.0);
}

TEST(TextureBuilder, RejectsInvalidRequestsAndSources) {
  TextureSource source;
  source.heightMeters = [](double, double) { return std::optional<double>(0.0); };
  EXPECT_FALSE(buildTextureTile(source, {6, 0, 0, 0, 32, 2}));   // face
  EXPECT_FALSE(buildTextureTile(source, {0, 1, 2, 0, 32, 2}));   // qi outside level 1
  EXPECT_FALSE(buildTextureTile(source, {0, 25, 0, 0, 32, 2}));  // level
  EXPECT_FALSE(buildTextureTile(source, {0, 0, 0, 0, 4, 2}));    // no inner texels
  EXPECT_FALSE(buildTextureTile(source, {0, 0, 0, 0, 5000, 2}));
  EXPECT_FALSE(buildTextureTile(source, {0, 0, 0, 0, 16, 5}));  // border beyond the next face
  auto error = buildTextureTile(TextureSource{}, {0, 0, 0, 0, 32, 2});
  ASSERT_FALSE(error);
  EXPECT_EQ(error.error().code, ErrorCode::InvalidArgument);
  EXPECT_TRUE(buildTextureTile(source, {5, 3, 7, 0, 8, 2}));
}

TEST(TextureBuilder, RampsAreReadable) {
  const HypsometricRamp earth{true, -11000.0, 9000.0};
  // Water is blue, deeper is darker; land is not blue; high peaks are snow.
  const Rgb8 shelf = hypsometricTint(-100.0, earth);
  const Rgb8 abyss = hypsometricTint(-6000.0, earth);
  EXPECT_GT(shelf[2], std::max(shelf[0], shelf[1]));
  EXPECT_GT(abyss[2], std::max(abyss[0], abyss[1]));
  EXPECT_LT(abyss[0] + abyss[1] + abyss[2], shelf[0] + shelf[1] + shelf[2]);
  for (const double land : {0.0, 300.0, 1000.0, 2500.0, 4000.0}) {
    const Rgb8 c = hypsometricTint(land, earth);
    EXPECT_LE(c[2], std::max(c[0], c[1])) << land;
  }
  EXPECT_GE(hypsometricTint(8000.0, earth)[2], 250);
  // The dry ramp spans the range: deep blue at the minimum, white at the maximum, and small
  // height steps give small colour steps (no bands).
  const HypsometricRamp mars{false, -8000.0, 21000.0};
  const Rgb8 low = hypsometricTint(-8000.0, mars);
  EXPECT_GT(low[2], 2 * std::max(low[0], low[1]));
  EXPECT_EQ(hypsometricTint(21000.0, mars), (Rgb8{255, 255, 255}));
  EXPECT_EQ(hypsometricTint(99000.0, mars), (Rgb8{255, 255, 255}));
  for (double h = -8000.0; h < 21000.0; h += 50.0) {
    const Rgb8 a = hypsometricTint(h, mars);
    const Rgb8 b = hypsometricTint(h + 50.0, mars);
    for (std::size_t c = 0; c < 3; ++c) ASSERT_LE(std::abs(a[c] - b[c]), 4) << h;
  }
  EXPECT_EQ(hypsometricTint(std::nan(""), mars), kNoDataTint);
}

TEST(TextureBuilder, HillshadeLightsSlopesFacingTheNorthWest) {
  // Heights rising eastwards face west (lit from the north-west), rising westwards face east.
  const auto tileMean = [](double metresPerDegreeEast) {
    TextureSource source;
    source.planet = Planet::mars();
    source.ramp = {false, -1.0e6, 1.0e6};
    source.heightMeters = [metresPerDegreeEast](double, double lonDegrees) {
      return std::optional<double>(metresPerDegreeEast * lonDegrees);
    };
    // A tile on face 0 around lat 0, lon 0 (away from the longitude seam).
    const TextureSource& s = source;
    return meanInnerColour(buildOrDie(s, {0, 2, 1, 1, 16, 2}));
  };
  const Colour flat = tileMean(0.0);
  const Colour facingWest = tileMean(2000.0);
  const Colour facingEast = tileMean(-2000.0);
  EXPECT_GT(facingWest[1], flat[1] + 10.0);
  EXPECT_LT(facingEast[1], flat[1] - 10.0);

  TextureSource none;
  none.heightMeters = [](double, double) { return std::optional<double>(); };
  const TextureTileImage grey = buildOrDie(none, {1, 0, 0, 0, 16, 2});
  EXPECT_EQ(texelAt(grey, 3, 3), (Colour{128.0, 128.0, 128.0}));
}

// For every border texel of `tile` that lies beyond exactly one face edge, the colour of the
// same direction in the neighbouring face's tile (bilinear); returns {max, mean} of the
// channel differences, and the mean difference to the clamped edge texel for comparison.
struct BorderReport final {
  double maxDifference = 0.0;
  double meanDifference = 0.0;
  double meanClampDifference = 0.0;
  int count = 0;
};

BorderReport compareBorders(const TextureSource& source, int level, std::uint32_t size) {
  BorderReport report;
  std::map<std::tuple<int, std::uint32_t, std::uint32_t>, TextureTileImage> neighbours;
  const auto tiles = std::uint32_t{1} << level;
  const int last = static_cast<int>(size) - 1;
  for (int face = 0; face < kCubeFaceCount; ++face) {
    for (std::uint32_t qj = 0; qj < tiles; ++qj) {
      for (std::uint32_t qi = 0; qi < tiles; ++qi) {
        if (qi != 0 && qj != 0 && qi + 1 != tiles && qj + 1 != tiles) continue;
        const TextureTileRequest request{face, level, qi, qj, size, 2};
        const TextureTileImage tile = buildOrDie(source, request);
        for (int y = 0; y < static_cast<int>(size); ++y) {
          for (int x = 0; x < static_cast<int>(size); ++x) {
            const glm::dvec2 uv = textureTexelFaceUv(request, x, y);
            const bool outU = uv.x < 0.0 || uv.x > 1.0;
            const bool outV = uv.y < 0.0 || uv.y > 1.0;
            if (outU == outV) continue;  // inside, or beyond a cube corner
            const glm::dvec3 direction = CubeMap::faceUvToDirection(cubeFaceFromIndex(face), uv);
            const FaceUv other = CubeMap::directionToFaceUv(direction);
            EXPECT_NE(cubeFaceIndex(other.face), face);
            const Located where = [&] {
              Located l;
              const double scale = std::ldexp(1.0, level);
              l.request = {cubeFaceIndex(other.face),
                           level,
                           std::min(static_cast<std::uint32_t>(other.uv.x * scale), tiles - 1),
                           std::min(static_cast<std::uint32_t>(other.uv.y * scale), tiles - 1),
                           size,
                           2};
              const double inner = size - 4.0;
              l.x = (other.uv.x * scale - l.request.qi) * inner + 1.5;
              l.y = (other.uv.y * scale - l.request.qj) * inner + 1.5;
              return l;
            }();
            const auto key =
                std::make_tuple(where.request.face, where.request.qi, where.request.qj);
            auto found = neighbours.find(key);
            if (found == neighbours.end()) {
              found = neighbours.emplace(key, buildOrDie(source, where.request)).first;
            }
            const double difference = maxChannelDifference(
                texelAt(tile, x, y), sampleTile(found->second, where.x, where.y));
            const Colour clamped =
                texelAt(tile, std::clamp(x, 2, last - 2), std::clamp(y, 2, last - 2));
            report.maxDifference = std::max(report.maxDifference, difference);
            report.meanDifference += difference;
            report.meanClampDifference += maxChannelDifference(texelAt(tile, x, y), clamped);
            ++report.count;
          }
        }
      }
    }
  }
  report.meanDifference /= report.count;
  report.meanClampDifference /= report.count;
  return report;
}

TEST(TextureBuilder, BorderTexelsShowTheNeighbouringFaces) {
  // A smooth synthetic planet: borders match the neighbours' interiors closely on all 24 edges.
  TextureSource smooth;
  smooth.planet = Planet::mars();
  smooth.ramp = {false, -6000.0, 6000.0};
  smooth.heightMeters = [](double latDegrees, double lonDegrees) {
    // Smooth on the sphere (a function of the direction, no pole singularity).
    const glm::dvec3 d = planetocentricToDirection(latDegrees, lonDegrees);
    return std::optional<double>(4000.0 * std::sin(3.0 * d.x + 1.0) * std::cos(2.0 * d.y) +
                                 1500.0 * std::cos(4.0 * d.z + d.x));
  };
  const BorderReport synthetic = compareBorders(smooth, 1, 64);
  EXPECT_GT(synthetic.count, 6 * 4 * 2 * 2 * 60);
  EXPECT_LE(synthetic.maxDifference, 3.0);
  EXPECT_LE(synthetic.meanDifference, 0.6);
  EXPECT_GT(synthetic.meanClampDifference, 2.0 * synthetic.meanDifference);

  // Real MOLA relief: rougher, so bilinear interpolation differs more, but far less than a
  // border that merely repeats the edge texels would.
  PBDAM_REQUIRE_DATA(mola, test::dataDir() / "mars/megt90n000cb.lbl");
  ASSERT_NE(Datasets::mola(), nullptr);
  const BorderReport real = compareBorders(marsSource(*Datasets::mola()), 2, 32);
  EXPECT_LE(real.meanDifference, 5.0);
  EXPECT_LT(real.meanDifference, 0.5 * real.meanClampDifference);
}

TEST(TextureBuilder, EarthTintSeparatesOceanFromLand) {
  PBDAM_REQUIRE_DATA(etopo, PBDAM_ETOPO5_PATH);
  ASSERT_NE(Datasets::etopo5(), nullptr);
  const TextureSource source = earthSource(*Datasets::etopo5());
  const auto meanAt = [&](double lat, double lon) {
    return meanInnerColour(buildOrDie(source, locate(lat, lon, 4, 32).request));
  };
  const Colour pacific = meanAt(0.0, -150.0);
  EXPECT_GT(pacific[2], pacific[0] + 40.0);
  EXPECT_GT(pacific[2], pacific[1] + 20.0);
  for (const Colour& land : {meanAt(23.0, 10.0), meanAt(31.0, 86.0)}) {  // Sahara, Himalaya
    EXPECT_LT(land[2], std::max(land[0], land[1]));
  }
}

TEST(TextureBuilder, OlympusMonsSummitHasTheRampsHighColour) {
  PBDAM_REQUIRE_DATA(mola, test::dataDir() / "mars/megt90n000cb.lbl");
  ASSERT_NE(Datasets::mola(), nullptr);
  // The MOLA maximum, 21,134 m at 17.375°N 226.875°E (data README), on the caldera rim.
  const Located summit = locate(17.375, 226.875 - 360.0, 4, 64);
  const Colour top = toColour(hypsometricTint(21134.0, {false, -8068.0, 21134.0}));
  const auto texelNear = [](const TextureTileImage& tile, const Located& where, int dx, int dy) {
    return texelAt(tile, static_cast<int>(std::lround(where.x)) + dx,
                   static_cast<int>(std::lround(where.y)) + dy);
  };
  // The tint alone: the summit texel is the ramp's top colour.
  TextureSource flat = marsSource(*Datasets::mola());
  flat.shading.strength = 0.0;
  const TextureTileImage tinted = buildOrDie(flat, summit.request);
  const Colour atSummit = texelNear(tinted, summit, 0, 0);
  EXPECT_LE(maxChannelDifference(atSummit, top), 25.0)
      << atSummit[0] << " " << atSummit[1] << " " << atSummit[2];
  // Shaded: the rim's slopes darken or lighten texels, but the near-flat summit area keeps the
  // top colour; 400 km west, on the plains at the foot of the volcano, nothing is close to it.
  const TextureTileImage shaded = buildOrDie(marsSource(*Datasets::mola()), summit.request);
  double closest = 255.0;
  for (int dy = -2; dy <= 2; ++dy) {
    for (int dx = -2; dx <= 2; ++dx) {
      closest = std::min(closest, maxChannelDifference(texelNear(shaded, summit, dx, dy), top));
    }
  }
  EXPECT_LE(closest, 25.0);
  const Located plains = locate(17.375, 218.5 - 360.0, 4, 64);
  const Colour foot = texelNear(buildOrDie(flat, plains.request), plains, 0, 0);
  EXPECT_GE(maxChannelDifference(foot, top), 100.0);
}

TEST(TextureBuilder, TextureErrorsHalvePerLevelAndNest) {
  const Planet planet = Planet::mars();
  const std::uint32_t size = 32;
  const double nominal = planet.equatorialRadiusMeters() * std::numbers::pi / 2.0 / (size - 4);
  for (int face = 0; face < kCubeFaceCount; ++face) {
    const double root = textureTileErrorMeters(planet, {face, 0, 0, 0, size, 2});
    EXPECT_GT(root, 0.9 * nominal);
    EXPECT_LT(root, 1.5 * nominal);
    for (int level = 0; level < 4; ++level) {
      const auto tiles = std::uint32_t{1} << level;
      for (std::uint32_t qj = 0; qj < tiles; ++qj) {
        for (std::uint32_t qi = 0; qi < tiles; ++qi) {
          const double parent = textureTileErrorMeters(planet, {face, level, qi, qj, size, 2});
          for (std::uint32_t child = 0; child < 4; ++child) {
            const double error = textureTileErrorMeters(
                planet, {face, level + 1, 2 * qi + (child & 1u), 2 * qj + (child >> 1), size, 2});
            ASSERT_GE(parent, error);
            EXPECT_GT(error / parent, 0.4);
            EXPECT_LT(error / parent, 0.56);
          }
        }
      }
    }
  }
  // The tile builder reports the same error.
  TextureSource source;
  source.heightMeters = [](double, double) { return std::optional<double>(0.0); };
  const TextureTileRequest request{4, 3, 5, 2, 16, 2};
  auto built = buildTextureTile(source, request);
  ASSERT_TRUE(built);
  EXPECT_EQ(built->textureErrorMeters, textureTileErrorMeters(source.planet, request));
}

TEST(TextureBuilder, IsDeterministicAcrossRunsAndThreads) {
  PBDAM_REQUIRE_DATA(mola, test::dataDir() / "mars/megt90n000cb.lbl");
  ASSERT_NE(Datasets::mola(), nullptr);
  const TextureSource source = marsSource(*Datasets::mola());
  const TextureTileRequest request{3, 2, 0, 2, 64, 2};
  const TextureTileImage first = buildOrDie(source, request);
  EXPECT_EQ(buildOrDie(source, request), first);
  std::array<TextureTileImage, 4> concurrent;
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < concurrent.size(); ++i) {
    threads.emplace_back([&, i] {
      // Interleave other tiles so the threads really overlap different work.
      const TextureTileRequest other{static_cast<int>(i), 1, 1, 0, 64, 2};
      (void)buildTextureTile(source, other);
      concurrent[i] = buildTextureTile(source, request)->image;
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const TextureTileImage& tile : concurrent) EXPECT_EQ(tile, first);
}

TEST(TextureBuilder, ImageryOverThePacificIsBlue) {
  PBDAM_REQUIRE_DATA(path, kEarthImage);
  auto image = readImage(path);
  ASSERT_TRUE(image) << image.error().message;
  TextureSource source;
  source.planet = Planet::earthWgs84();
  source.imagery = &*image;
  const Colour pacific = meanInnerColour(buildOrDie(source, locate(0.0, -150.0, 3, 32).request));
  EXPECT_GT(pacific[2], pacific[0] + 20.0);
  const Colour sahara = meanInnerColour(buildOrDie(source, locate(23.0, 10.0, 3, 32).request));
  EXPECT_GT(sahara[0], sahara[2] + 30.0);

  // A coarse texel averages the image over its footprint (supersampling): compared with a dense
  // 16×16 average over each texel, it is much closer than a point sample at the centre.
  const TextureTileRequest coarseRequest{1, 0, 0, 0, 16, 2};
  const TextureTileImage coarse = buildOrDie(source, coarseRequest);
  const auto imageAt = [&](const glm::dvec2& uv) {
    const GeodeticPosition p =
        source.planet.directionToGeodetic(CubeMap::faceUvToDirection(CubeFace::PosY, uv));
    const auto rgba = *image->sampleBilinear(p.latDegrees, p.lonDegrees);
    return Colour{static_cast<double>(rgba[0]), static_cast<double>(rgba[1]),
                  static_cast<double>(rgba[2])};
  };
  double tileError = 0.0;
  double pointError = 0.0;
  for (int y = 2; y < 14; ++y) {
    for (int x = 2; x < 14; ++x) {
      Colour dense{};
      for (int b = 0; b < 16; ++b) {
        for (int a = 0; a < 16; ++a) {
          const Colour c = imageAt(textureTexelFaceUv(coarseRequest, x - 0.5 + (a + 0.5) / 16.0,
                                                      y - 0.5 + (b + 0.5) / 16.0));
          for (std::size_t i = 0; i < 3; ++i) dense[i] += c[i] / 256.0;
        }
      }
      tileError += maxChannelDifference(texelAt(coarse, x, y), dense);
      pointError += maxChannelDifference(imageAt(textureTexelFaceUv(coarseRequest, x, y)), dense);
    }
  }
  EXPECT_LT(tileError, 0.3 * pointError) << tileError << " vs " << pointError;

  // Shaded imagery darkens slopes facing away from the light, keeps flat ground unchanged.
  TextureSource shaded = source;
  shaded.heightMeters = [](double, double lonDegrees) {
    return std::optional<double>(-3000.0 * lonDegrees);
  };
  shaded.imageryShadingStrength = 1.0;
  const TextureTileRequest sahel = locate(15.0, 5.0, 3, 32).request;
  const Colour plain = meanInnerColour(buildOrDie(source, sahel));
  const Colour dark = meanInnerColour(buildOrDie(shaded, sahel));
  EXPECT_LT(dark[0], plain[0] - 10.0);
}

TEST(TextureBuilder, ImageryLayersBlendOverTheReliefByTheirWeightAndAlpha) {
  // A flat grey base tint under a local red image over 10..20°N 10..20°E, whose west half has
  // alpha 0 (no source there, as a warped image's corners).
  const int w = 64;
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(w * w * 4), 0);
  for (int y = 0; y < w; ++y) {
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = &rgba[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                               static_cast<std::size_t>(x)) *
                              4];
      p[0] = 255;
      p[3] = x < w / 2 ? 0 : 255;
    }
  }
  const GeoImage image(w, w, std::move(rgba), LatLonBounds{10.0, 10.0, 20.0, 20.0}, true);
  TextureSource source;
  source.planet = Planet::earthWgs84();
  source.heightMeters = [](double, double) { return std::optional<double>(100.0); };
  source.ramp = {false, 0.0, 200.0};
  source.shading.strength = 0.0;
  const TextureTileRequest east = locate(15.0, 18.0, 6, 16).request;
  const TextureTileRequest west = locate(15.0, 12.0, 6, 16).request;
  const Colour tint = meanInnerColour(buildOrDie(source, east));

  double weight = 1.0;
  source.layers.push_back({&image, [&weight](double lat, double lon) {
                             return lat > 10.0 && lat < 20.0 && lon > 10.0 && lon < 20.0 ? weight
                                                                                         : 0.0;
                           }});
  const Colour full = meanInnerColour(buildOrDie(source, east));
  EXPECT_NEAR(full[0], 255.0, 0.5);
  EXPECT_NEAR(full[1], 0.0, 0.5);
  // Where the image has alpha 0, what lies below shows unchanged.
  const Colour hidden = meanInnerColour(buildOrDie(source, west));
  for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(hidden[c], tint[c], 0.5);
  // Half the weight: halfway between the tint and the image.
  weight = 0.5;
  const Colour half = meanInnerColour(buildOrDie(source, east));
  for (std::size_t c = 0; c < 3; ++c) {
    EXPECT_NEAR(half[c], 0.5 * (tint[c] + (c == 0 ? 255.0 : 0.0)), 1.0) << c;
  }
  // Outside the layer's weight, the tint.
  const Colour outside = meanInnerColour(buildOrDie(source, locate(30.0, 18.0, 6, 16).request));
  for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(outside[c], tint[c], 0.5);
}

}  // namespace
}  // namespace pbdam::builder

namespace pbdam::builder {
namespace {

// The unit normal normal-map texel (x, y) of `tile` (built for `colour`) holds.
glm::dvec3 normalAt(const TextureTileImage& tile, const TextureTileRequest& colour, int x, int y,
                    const Planet& planet) {
  TextureTileRequest half = colour;
  half.sizeTexels /= 2;
  half.borderTexels /= 2;
  const glm::dvec2 uv = textureTexelFaceUv(half, x, y);
  const CubeFace face = cubeFaceFromIndex(colour.face);
  const GeodeticPosition p = planet.directionToGeodetic(CubeMap::faceUvToDirection(face, uv));
  const glm::dvec3 up = planet.surfaceNormal(p.latDegrees, p.lonDegrees);
  const std::size_t at =
      2 * (static_cast<std::size_t>(y) * tile.sizeTexels + static_cast<std::size_t>(x));
  return decodeNormalTexel(normalMapFrame(face, up), tile.data[at], tile.data[at + 1]);
}

double degreesBetween(const glm::dvec3& a, const glm::dvec3& b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

}  // namespace

// A normal-map tile is half the colour tile, in two channels, and holds the true relief's
// normal: flat ground gives the surface normal, a slope rising eastwards tilts it west by the
// slope's angle (no hillshade exaggeration).
TEST(TextureBuilder, NormalMapHoldsTheTrueSlope) {
  const TextureTileRequest colour{0, 2, 1, 1, 32, 2};  // face 0 around lat 0, lon 0
  for (const double slope : {0.0, 0.02, 0.3, -0.3}) {
    TextureSource source;
    source.planet = Planet::mars();
    const double metresPerDegree =
        slope * source.planet.equatorialRadiusMeters() * std::numbers::pi / 180.0;
    source.heightMeters = [metresPerDegree](double, double lonDegrees) {
      return std::optional<double>(metresPerDegree * lonDegrees);
    };
    auto tile = buildNormalTile(source, colour);
    ASSERT_TRUE(tile) << tile.error().message;
    EXPECT_EQ(tile->format, TexelFormat::Rg8);
    EXPECT_EQ(tile->sizeTexels, 16u);
    EXPECT_EQ(tile->borderTexels, 1u);
    double worst = 0.0;
    for (int y = 1; y < 15; ++y) {
      for (int x = 1; x < 15; ++x) {
        TextureTileRequest half = colour;
        half.sizeTexels = 16;
        half.borderTexels = 1;
        const glm::dvec2 uv = textureTexelFaceUv(half, x, y);
        const GeodeticPosition p =
            source.planet.directionToGeodetic(CubeMap::faceUvToDirection(CubeFace::PosX, uv));
        const glm::dvec3 up = source.planet.surfaceNormal(p.latDegrees, p.lonDegrees);
        // East at the texel; the slope is along east only, by metres per metre of parallel.
        const double lon = p.lonDegrees * std::numbers::pi / 180.0;
        const glm::dvec3 east(-std::sin(lon), std::cos(lon), 0.0);
        const double along = slope / std::cos(p.latDegrees * std::numbers::pi / 180.0);
        const glm::dvec3 expected = glm::normalize(up - along * east);
        worst =
            std::max(worst, degreesBetween(normalAt(*tile, colour, x, y, source.planet), expected));
      }
    }
    EXPECT_LT(worst, slope == 0.0 ? 0.02 : 0.8) << "slope " << slope;
  }
  // Odd sizes cannot be halved.
  TextureSource flat;
  flat.heightMeters = [](double, double) { return std::optional<double>(0.0); };
  EXPECT_FALSE(buildNormalTile(flat, {0, 0, 0, 0, 30, 3}));
  EXPECT_FALSE(buildNormalTile(flat, {0, 0, 0, 0, 31, 2}));
}

// On real data: around Olympus Mons (MOLA), the flanks' normals lean away from the summit, and
// the normal map is the same bytes on every run.
TEST(TextureBuilder, NormalMapLeansAwayFromOlympusMons) {
  PBDAM_REQUIRE_DATA(mola, test::dataDir() / "mars/megt90n000cb.lbl");
  ASSERT_NE(Datasets::mola(), nullptr);
  const Located summit = locate(18.65, 226.2 - 360.0, 3, 128);
  const TextureSource source = marsSource(*Datasets::mola());
  auto tile = buildNormalTile(source, summit.request);
  ASSERT_TRUE(tile) << tile.error().message;
  auto again = buildNormalTile(source, summit.request);
  ASSERT_TRUE(again);
  EXPECT_EQ(*tile, *again);
  const glm::dvec3 top = source.planet.geodeticToEcef(18.65, 226.2 - 360.0, 0.0);
  int flank = 0;
  int away = 0;
  const int size = static_cast<int>(tile->sizeTexels);
  for (int y = 1; y < size - 1; ++y) {
    for (int x = 1; x < size - 1; ++x) {
      TextureTileRequest half = summit.request;
      half.sizeTexels /= 2;
      half.borderTexels /= 2;
      const glm::dvec2 uv = textureTexelFaceUv(half, x, y);
      const glm::dvec3 here = source.planet.directionToSurfaceEcef(
          CubeMap::faceUvToDirection(cubeFaceFromIndex(summit.request.face), uv));
      const double km = glm::distance(here, top) / 1000.0;
      if (km < 60.0 || km > 250.0) continue;  // the flanks, not the caldera nor the scarp
      const glm::dvec3 n = normalAt(*tile, summit.request, x, y, source.planet);
      const glm::dvec3 up = glm::normalize(here);
      const glm::dvec3 outward = glm::normalize((here - top) - glm::dot(here - top, up) * up);
      ++flank;
      if (glm::dot(n, outward) > 0.0) ++away;
    }
  }
  ASSERT_GT(flank, 20);
  EXPECT_GT(static_cast<double>(away) / flank, 0.9) << away << " of " << flank;
}

}  // namespace pbdam::builder
