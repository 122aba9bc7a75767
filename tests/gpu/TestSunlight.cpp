// The sun where it is: Mars and Earth rendered whole with no ambient light under the sun of an
// instant, the boundary of direct light on the equator row found in the image, and its longitude
// compared with the terminator of a published subsolar point — 90° east of it on the equator,
// whatever the season. Published points: the two worked examples of Mars24 (NASA GISS) and the
// first of them 6 h later (Mars turns 360° in a mean sol of 88,775.244 s; the equation of time
// moves by hundredths of a degree in that time); for Earth, Meeus's equation of time on 1992
// October 13.0 TD (Astronomical Algorithms, Example 28.b: E = +13m42.6s) at three times of that
// day (E moves by 0.1 min in it). The image's sun comes from the runtime's ephemeris.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <memory>
#include <vector>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/Atmosphere.h"
#include "pbdam/runtime/Sun.h"

using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kSize = 512;

struct PublishedSun {
  const char* dataset;
  const char* utc;
  double subsolarLonDegrees;  ///< east
};

/// Longitude 180° − 15°·UT − E of the sun over a UTC instant, E the equation of time in minutes.
double lonFromEquationOfTime(double hoursUt, double equationOfTimeMinutes) {
  return 180.0 - 15.0 * hoursUt - equationOfTimeMinutes / 4.0;
}

double wrap180(double degrees) {
  double d = std::fmod(degrees + 180.0, 360.0);
  if (d < 0.0) d += 360.0;
  return d - 180.0;
}

class Sunlight : public test::GpuTest, public ::testing::WithParamInterface<PublishedSun> {};

TEST_P(Sunlight, TheTerminatorOnTheEquatorIsNinetyDegreesFromThePublishedSubsolarPoint) {
  const PublishedSun& published = GetParam();
  PBDAM_REQUIRE_DATASET(dir, published.dataset);
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  const Planet& planet = view.planet();
  auto t = parseUtcTime(published.utc);
  ASSERT_TRUE(t.ok()) << t.error().message;
  auto subsolar = subsolarPoint(planet, *t);
  ASSERT_TRUE(subsolar.ok()) << subsolar.error().message;
  // The terminator's evening side crosses the equator 90° east of the subsolar point; the camera
  // looks straight down on it from 2.2 radii, north up, so the day is on the left.
  const double terminatorLon = wrap180(published.subsolarLonDegrees + 90.0);
  const double radius = planet.equatorialRadiusMeters();
  const Camera camera =
      test::cameraAt(view, {0.0, terminatorLon, 2.2 * radius, 0.0, -90.0, 0.0}, kSize, kSize, 50.0);
  TerrainRendererOptions options;
  options.widthPixels = kSize;
  options.heightPixels = kSize;
  auto renderer = TerrainRenderer::create(context(), view, options);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  FrameSettings settings;
  settings.ambient = 0.0f;
  settings.sunDirectionEcef = sunDirectionEcef(planet, *subsolar);
  settings.sunAngularRadiusRadians =
      static_cast<float>(sunAngularRadiusRadians(subsolar->distanceAu));
  auto frame = renderer->render(refine(view, camera, RefinementOptions{}), camera, settings);
  ASSERT_TRUE(frame.ok()) << frame.error().message;

  // The row through the equator: the one whose pixel centres lie closest to latitude 0.
  const std::uint32_t row = kSize / 2;
  double lastLitLon = -1000.0;
  std::uint32_t planetPixels = 0;
  std::uint32_t litPixels = 0;
  std::uint32_t litFarOnTheDaySide = 0;
  std::uint32_t farOnTheDaySide = 0;
  for (std::uint32_t x = 0; x < kSize; ++x) {
    const glm::dvec3 ray = test::pixelRay(camera, x, row);
    const glm::dvec3 origin = camera.position();
    // The reference surface along the ray (a sphere through the equator is exact on the
    // equator row: the ellipsoid's equator is a circle of the equatorial radius).
    const double b = glm::dot(origin, ray);
    const double c = glm::dot(origin, origin) - radius * radius;
    if (b * b - c < 0.0) continue;
    const glm::dvec3 hit = origin + (-b - std::sqrt(b * b - c)) * ray;
    const double lon = std::atan2(hit.y, hit.x) * 180.0 / M_PI;
    const std::size_t i = (static_cast<std::size_t>(row) * kSize + x) * 4;
    const auto& rgba = frame->image.rgba;
    const bool lit = rgba[i] + rgba[i + 1] + rgba[i + 2] > 0;
    ++planetPixels;
    if (lit) {
      ++litPixels;
      lastLitLon = lon;
    }
    if (wrap180(lon - terminatorLon) < -10.0) {
      ++farOnTheDaySide;
      if (lit) ++litFarOnTheDaySide;
    }
  }
  ASSERT_GT(planetPixels, kSize / 3);
  ASSERT_GT(litPixels, 0u) << "no direct light on the equator row";
  // More than 10° into the day, the sun is high enough that nearly all the surface is lit.
  EXPECT_GT(litFarOnTheDaySide, farOnTheDaySide * 9 / 10);
  EXPECT_LT(std::abs(wrap180(lastLitLon - terminatorLon)), 1.0)
      << "the boundary of direct light is at longitude " << lastLitLon << "°, the terminator at "
      << terminatorLon << "° (ephemeris' subsolar longitude " << subsolar->lonDegrees << "°)";
}

INSTANTIATE_TEST_SUITE_P(
    PublishedSubsolarPoints, Sunlight,
    ::testing::Values(
        // Mars24 examples A and B: subsolar longitudes 174.727° W and 4.706° W; A + 6 h is
        // 6 · 3600 / 88775.244 · 360° = 87.60° further west.
        PublishedSun{"mola", "2000-01-06T00:00:00Z", -174.727},
        PublishedSun{"mola", "2004-01-03T13:46:31Z", -4.706},
        PublishedSun{"mola", "2000-01-06T06:00:00Z", -174.727 - 87.60},
        // Meeus: 1992 Oct 13.0 TD is 23:59:00.816 UT on Oct 12; E = +13.709 min.
        PublishedSun{"earth", "1992-10-12T23:59:00.816Z",
                     lonFromEquationOfTime(23.0 + 59.0 / 60.0 + 0.816 / 3600.0, 13.709)},
        PublishedSun{"earth", "1992-10-13T07:59:00.816Z",
                     lonFromEquationOfTime(7.0 + 59.0 / 60.0 + 0.816 / 3600.0, 13.709)},
        PublishedSun{"earth", "1992-10-13T15:59:00.816Z",
                     lonFromEquationOfTime(15.0 + 59.0 / 60.0 + 0.816 / 3600.0, 13.709)}),
    [](const ::testing::TestParamInfo<PublishedSun>& param) {
      std::string name = std::string(param.param.dataset) + "_" + param.param.utc;
      for (char& c : name) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return name;
    });

/// Small atmosphere tables (quick under the sanitizers): what the tests check holds at any size.
std::shared_ptr<const AtmosphereTables> smallAtmosphere(const Planet& planet) {
  AtmosphereTableSizes sizes;
  sizes.scatteringR = 8;
  sizes.scatteringMu = 32;
  sizes.scatteringMuS = 8;
  sizes.scatteringNu = 4;
  return std::make_shared<const AtmosphereTables>(
      AtmosphereTables::compute(*AtmosphereParameters::of(planet), sizes));
}

/// The mean RGB of row y over the middle half of the columns.
glm::dvec3 rowMean(const RgbaImage& image, std::uint32_t y) {
  glm::dvec3 sum(0.0);
  const std::uint32_t from = image.widthPixels / 4;
  const std::uint32_t to = image.widthPixels * 3 / 4;
  for (std::uint32_t x = from; x < to; ++x) {
    const std::size_t i = (static_cast<std::size_t>(y) * image.widthPixels + x) * 4;
    sum += glm::dvec3(image.rgba[i], image.rgba[i + 1], image.rgba[i + 2]);
  }
  return sum / static_cast<double>(to - from);
}

class Atmosphere : public test::GpuTest {
 protected:
  /// A frame of `pose` over `dataset` with its planet's atmosphere (small tables) under a sun at
  /// `azimuth`, `elevation` over the point below the camera; `exposure` 0: no atmosphere.
  RgbaImage frame(const DatasetView& view, const CameraPose& pose, double azimuth, double elevation,
                  float exposure, std::uint32_t width, std::uint32_t height) {
    return rendered(view, pose, azimuth, elevation, exposure, width, height, false).image;
  }

  /// As frame(), the whole RenderedFrame, with its radiance when `radiance`.
  RenderedFrame rendered(const DatasetView& view, const CameraPose& pose, double azimuth,
                         double elevation, float exposure, std::uint32_t width,
                         std::uint32_t height, bool radiance) {
    TerrainRendererOptions options;
    options.widthPixels = width;
    options.heightPixels = height;
    options.atmosphere = smallAtmosphere(view.planet());
    auto renderer = TerrainRenderer::create(context(), view, options);
    EXPECT_TRUE(renderer.ok()) << renderer.error().message;
    if (!renderer.ok()) return RenderedFrame{};
    const Camera camera = test::cameraAt(view, pose, width, height);
    FrameSettings settings;
    settings.sunDirectionEcef = sunDirectionFromHorizon(view.planet(), pose.latDegrees,
                                                        pose.lonDegrees, azimuth, elevation);
    settings.sunAngularRadiusRadians = static_cast<float>(sunAngularRadiusRadians(1.0));
    settings.ambient = 0.0f;
    settings.atmosphereExposure = exposure;
    settings.readRadiance = radiance;
    auto drawn = renderer->render(refine(view, camera, RefinementOptions{}), camera, settings);
    EXPECT_TRUE(drawn.ok()) << drawn.error().message;
    return drawn.ok() ? std::move(*drawn) : RenderedFrame{};
  }
};

// Aerial perspective grows with distance: looking out over the Pacific from 2 km under a high
// sun, the rows of ocean farther away (the ray's distance to the sea, from the pixel's ray) are
// ever closer to the colour of the sky just above the horizon; without the atmosphere the sky
// is the black background.
TEST_F(Atmosphere, FarTerrainIsSeenThroughMoreAirAndNearerTheSkyColour) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr std::uint32_t kW = 256;
  constexpr std::uint32_t kH = 256;
  const CameraPose pose{-30.0, -130.0, 2000.0, 0.0, -4.0, 0.0};
  const RgbaImage image = frame(view, pose, 90.0, 50.0, 10.0f, kW, kH);
  ASSERT_EQ(image.rgba.size(), std::size_t{kW} * kH * 4);
  const Camera camera = test::cameraAt(view, pose, kW, kH);
  const double radius =
      glm::length(view.planet().geodeticToEcef(pose.latDegrees, pose.lonDegrees, 0.0));
  // Each row's distance to the sea along the centre column's ray (0: above the horizon).
  std::vector<double> distance(kH, 0.0);
  std::uint32_t horizonRow = 0;
  for (std::uint32_t y = 0; y < kH; ++y) {
    const glm::dvec3 ray = test::pixelRay(camera, kW / 2, y);
    const double b = glm::dot(camera.position(), ray);
    const double c = glm::dot(camera.position(), camera.position()) - radius * radius;
    if (b * b - c >= 0.0 && -b - std::sqrt(b * b - c) > 0.0) {
      distance[y] = -b - std::sqrt(b * b - c);
    } else {
      horizonRow = y;
    }
  }
  ASSERT_GT(horizonRow, 8u);
  ASSERT_LT(horizonRow, kH - 8);
  const glm::dvec3 sky = rowMean(image, horizonRow - 6);
  EXPECT_GT(sky.z, sky.x) << "the sky above the horizon is blue";
  double previous = 1e9;
  for (const double km : {3.0, 8.0, 20.0, 60.0}) {
    std::uint32_t row = kH - 1;
    while (row > horizonRow && distance[row] < km * 1e3) --row;
    ASSERT_GT(row, horizonRow) << km;
    const double towardsSky = glm::length(rowMean(image, row) - sky);
    EXPECT_LT(towardsSky, previous) << km << " km (row " << row << ")";
    previous = towardsSky;
  }
  const RgbaImage bare = frame(view, pose, 90.0, 50.0, 0.0f, kW, kH);
  EXPECT_EQ(rowMean(bare, horizonRow - 6), glm::dvec3(0.0));
}

// From orbit the day side's limb glows: just outside Mars's disc on the sunward side the sky is
// lit; far from the disc, and beyond the night side's limb, space is black.
TEST_F(Atmosphere, TheDayLimbGlowsAndSpaceIsBlack) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr std::uint32_t kW = 320;
  constexpr std::uint32_t kH = 320;
  // Looking down on the terminator: the sun in the west, low over the camera's nadir.
  const CameraPose pose{0.0, 0.0, 4000e3, 0.0, -90.0, 0.0};
  const RgbaImage image = frame(view, pose, 270.0, 1.0, 23.0f, kW, kH);
  ASSERT_EQ(image.rgba.size(), std::size_t{kW} * kH * 4);
  const Camera camera = test::cameraAt(view, pose, kW, kH);
  const double radius = view.planet().equatorialRadiusMeters() + 25e3;  // above the highest land
  const std::uint32_t row = kH / 2;
  // The first column (from the left: west, the day side) whose ray meets the planet.
  std::uint32_t edge = 0;
  while (edge < kW &&
         !test::rayHitsSphere(camera.position(), test::pixelRay(camera, edge, row), radius)) {
    ++edge;
  }
  ASSERT_GT(edge, 12u);
  const auto brightness = [&](std::uint32_t x) {
    const std::size_t i = (static_cast<std::size_t>(row) * kW + x) * 4;
    return image.rgba[i] + image.rgba[i + 1] + image.rgba[i + 2];
  };
  EXPECT_GT(brightness(edge - 2) + brightness(edge - 3), 0) << "no glow beyond the day limb";
  EXPECT_EQ(brightness(edge - 12), 0) << "space is not black";
  EXPECT_EQ(brightness(2), 0);
}

// The night side seen from above the air, the sun on the far side of the planet: the terrain is
// dark (the ambient share of its texel, 0 here, and no more than a faint glow of the air), and
// never the flat grey that a NaN in the tone curve made of it (lavapipe's pow(0, y)).
TEST_F(Atmosphere, TheNightSideFromAboveTheAirIsDark) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr std::uint32_t kW = 96;
  constexpr std::uint32_t kH = 64;
  const CameraPose pose{-6.0, -100.0, 500e3, 99.0, -72.0, 0.0};
  const RgbaImage image = frame(view, pose, 90.0, -89.0, 23.0f, kW, kH);
  ASSERT_EQ(image.rgba.size(), std::size_t{kW} * kH * 4);
  int brightest = 0;
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
    brightest =
        std::max({brightest, int{image.rgba[i]}, int{image.rgba[i + 1]}, int{image.rgba[i + 2]}});
  }
  EXPECT_LE(brightest, 16) << "the night side is lit";
}

// A frame with the atmosphere is drawn as radiance and tone-mapped once per pixel: the linear
// radiance read back is finite and not negative, brighter than display white where the sun's
// disc is, and its own tone curve (1 − e^(−radiance · exposure), sRGB) is the frame's colour to
// within the half floats' rounding, sky and terrain, day and night side alike.
TEST_F(Atmosphere, TheFramesRadianceToneMapsToItsColour) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr std::uint32_t kW = 160;
  constexpr std::uint32_t kH = 96;
  constexpr double kExposure = 23.0;
  // Over the terminator, looking at the horizon towards the low sun (its disc in the frame).
  const CameraPose pose{0.0, 0.0, 30e3, 90.0, 0.0, 0.0};
  const RenderedFrame frame =
      rendered(view, pose, 90.0, 2.0, static_cast<float>(kExposure), kW, kH, true);
  ASSERT_EQ(frame.image.rgba.size(), std::size_t{kW} * kH * 4);
  ASSERT_EQ(frame.radiance.size(), std::size_t{kW} * kH * 3);
  const auto encode = [](double linear) {
    const double x =
        linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
    return 255.0 * std::clamp(x, 0.0, 1.0);
  };
  double worst = 0.0;
  double brightest = 0.0;
  for (std::size_t p = 0; p < std::size_t{kW} * kH; ++p) {
    for (std::size_t c = 0; c < 3; ++c) {
      const double radiance = static_cast<double>(frame.radiance[p * 3 + c]);
      ASSERT_TRUE(std::isfinite(radiance) && radiance >= 0.0) << p << " " << radiance;
      brightest = std::max(brightest, radiance);
      const double shown = encode(1.0 - std::exp(-radiance * kExposure));
      worst = std::max(worst, std::abs(shown - frame.image.rgba[p * 4 + c]));
    }
  }
  EXPECT_LE(worst, 2.0) << "the tone-mapped radiance is not the frame";
  EXPECT_GT(brightest * kExposure, 10.0) << "no sun's disc brighter than white";
  // Without the radiance asked for, none is read back, and the fragments are tone-mapped as
  // they are drawn: the same frame, to the half floats' rounding.
  const RenderedFrame direct =
      rendered(view, pose, 90.0, 2.0, static_cast<float>(kExposure), kW, kH, false);
  EXPECT_TRUE(direct.radiance.empty());
  ASSERT_EQ(direct.image.rgba.size(), frame.image.rgba.size());
  int largest = 0;
  for (std::size_t i = 0; i < direct.image.rgba.size(); ++i) {
    largest = std::max(largest, std::abs(int{direct.image.rgba[i]} - int{frame.image.rgba[i]}));
  }
  EXPECT_LE(largest, 2) << "the direct frame is not the tone-mapped radiance";
}

}  // namespace
}  // namespace pbdam::gpu

namespace pbdam::gpu {
namespace {

class NormalMaps : public test::GpuTest {};

double meanAbsoluteDifference(const RgbaImage& a, const RgbaImage& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.rgba.size(); ++i) {
    if (i % 4 == 3) continue;
    sum += std::abs(static_cast<double>(a.rgba[i]) - static_cast<double>(b.rgba[i]));
  }
  return sum / (0.75 * static_cast<double>(a.rgba.size()));
}

// Distant relief keeps its shading: Mars's Tharsis from 3,000 km under a sun 10° high, drawn from
// a coarse cut (12 px), looks more like the same view drawn from leaves everywhere (the lattice's
// own triangles) with the normal maps than without them (the coarse patches' own facets): mean
// channel difference 0.26 against 0.34 when written. Under the camera light the normal maps
// change nothing, so its frames are those of before them.
TEST_F(NormalMaps, KeepDistantReliefShadedAsTheLatticeIs) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr std::uint32_t kW = 256;
  constexpr std::uint32_t kH = 192;
  TerrainRendererOptions options;
  options.widthPixels = kW;
  options.heightPixels = kH;
  auto renderer = TerrainRenderer::create(context(), view, options);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const CameraPose pose{5.0, -115.0, 3000e3, 0.0, -80.0, 0.0};
  const Camera camera = test::cameraAt(view, pose, kW, kH);
  const auto draw = [&](double tolerancePixels, bool normalMaps, bool sun) {
    FrameSettings settings;
    if (sun) {
      settings.sunDirectionEcef =
          sunDirectionFromHorizon(view.planet(), pose.latDegrees, pose.lonDegrees, 100.0, 10.0);
      settings.sunAngularRadiusRadians = static_cast<float>(sunAngularRadiusRadians(1.52));
      settings.ambient = 0.05f;
    }
    settings.normalMaps = normalMaps;
    RefinementOptions refinement;
    refinement.tolerancePixels = tolerancePixels;
    auto drawn = renderer->render(refine(view, camera, refinement), camera, settings);
    EXPECT_TRUE(drawn.ok()) << drawn.error().message;
    return drawn.ok() ? std::move(drawn->image) : RgbaImage{};
  };
  const Cut leaves = refine(view, camera, RefinementOptions{0.01});
  const Cut coarse = refine(view, camera, RefinementOptions{12.0});
  ASSERT_GT(leaves.patches.size(), 4 * coarse.patches.size()) << "the cuts do not differ";
  const RgbaImage reference = draw(0.01, true, true);
  const RgbaImage mapped = draw(12.0, true, true);
  const RgbaImage facets = draw(12.0, false, true);
  ASSERT_EQ(reference.rgba.size(), std::size_t{kW} * kH * 4);
  const double withMaps = meanAbsoluteDifference(mapped, reference);
  const double without = meanAbsoluteDifference(facets, reference);
  EXPECT_LT(withMaps, 0.85 * without) << withMaps << " vs " << without;
  // The camera light: the same bytes either way.
  EXPECT_EQ(draw(12.0, true, false).rgba, draw(12.0, false, false).rgba);
}

}  // namespace
}  // namespace pbdam::gpu
