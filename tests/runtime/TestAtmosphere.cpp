// The atmosphere's tables against what is known of the sky: the transmittance of a vertical
// column equals its analytic optical depth; Earth's noon sky is blue and its sunset red; Mars's
// day sky is butterscotch and blue near the setting sun; the aerial perspective brings a terrain
// colour closer to the sky's the more air it is seen through; multiple scattering adds light;
// the tables are the same floats whatever the thread count. Small tables keep the sanitizer
// presets quick: the claims hold at any resolution.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#if defined(__SANITIZE_THREAD__)
#include <tbb/global_control.h>
#endif

#include <cmath>
#include <glm/geometric.hpp>

#include "pbdam/runtime/Atmosphere.h"

namespace pbdam::runtime {
namespace {

#if defined(__SANITIZE_THREAD__)
// As gpu/src/SanitizerSupport.cpp does for the renderer: Debian's libtbb is not instrumented, so
// TSan reports TBB's own task handoffs as races; under TSan the tables are made on the calling
// thread. The parallel path (and its thread-count independence) is checked by the release and
// ASan runs.
const tbb::global_control atmosphereSerialUnderTsan(tbb::global_control::max_allowed_parallelism,
                                                    1);
#endif

AtmosphereTableSizes small(std::uint32_t orders = 3) {
  AtmosphereTableSizes s;
  s.transmittanceWidth = 64;
  s.transmittanceHeight = 16;
  s.scatteringR = 8;
  s.scatteringMu = 32;
  s.scatteringMuS = 8;
  s.scatteringNu = 4;
  s.irradianceWidth = 16;
  s.irradianceHeight = 4;
  s.scatteringOrders = orders;
  return s;
}

const AtmosphereTables& earthTables() {
  static const AtmosphereTables tables =
      AtmosphereTables::compute(AtmosphereParameters::earth(), small());
  return tables;
}

const AtmosphereTables& marsTables() {
  static const AtmosphereTables tables =
      AtmosphereTables::compute(AtmosphereParameters::mars(), small());
  return tables;
}

/// The unit direction at elevation `degrees` towards +x (the sun's side) in the x-z plane.
glm::dvec3 elevated(double degrees, double towards = 1.0) {
  const double e = degrees * M_PI / 180.0;
  return glm::normalize(glm::dvec3(towards * std::cos(e), 0.0, std::sin(e)));
}

TEST(Atmosphere, AVerticalColumnHasItsAnalyticOpticalDepth) {
  for (const AtmosphereParameters& p :
       {AtmosphereParameters::earth(), AtmosphereParameters::mars()}) {
    const AtmosphereTables tables = AtmosphereTables::compute(p, small(1));
    const double top = p.topRadius - p.bottomRadius;
    const auto column = [top](double scaleHeight) {
      return scaleHeight * (1.0 - std::exp(-top / scaleHeight));
    };
    const double rayleighH = -1.0 / p.rayleighDensity.layers[1].expScale;
    const double mieH = -1.0 / p.mieDensity.layers[1].expScale;
    // Earth's ozone is a tent of height 1 from 10 to 40 km: a 15 km column.
    const glm::dvec3 depth = p.rayleighScattering * column(rayleighH) +
                             p.mieExtinction * column(mieH) + p.absorptionExtinction * 15e3;
    const glm::dvec3 t = tables.transmittanceToTop(p.bottomRadius, 1.0);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(t[c], std::exp(-depth[c]), 0.002 * std::exp(-depth[c])) << c;
    }
    // Through the whole atmosphere towards the horizon there is far more air.
    EXPECT_LT(tables.transmittanceToTop(p.bottomRadius, 0.01).z, 0.5 * t.z);
  }
}

TEST(Atmosphere, EarthsNoonSkyIsBlueAndItsSunsetRed) {
  const AtmosphereTables& earth = earthTables();
  const glm::dvec3 ground(0.0, 0.0, AtmosphereParameters::earth().bottomRadius + 10.0);
  const glm::dvec3 noonSun = elevated(60.0);
  const glm::dvec3 zenith = earth.skyRadiance(ground, {0.0, 0.0, 1.0}, noonSun).radiance;
  EXPECT_GT(zenith.z, zenith.y);
  EXPECT_GT(zenith.y, zenith.x);
  EXPECT_GT(zenith.z, 2.0 * zenith.x);
  const glm::dvec3 sunsetSun = elevated(1.0);
  const glm::dvec3 horizon = earth.skyRadiance(ground, elevated(3.0), sunsetSun).radiance;
  EXPECT_GT(horizon.x, horizon.y);
  EXPECT_GT(horizon.y, horizon.z);
  const glm::dvec3 sunlight = earth.transmittanceToSun(ground.z, std::sin(1.0 * M_PI / 180.0));
  EXPECT_GT(sunlight.x, 10.0 * sunlight.z);
  // Below the horizon the sun gives no direct light; the sky dims with it.
  EXPECT_EQ(earth.transmittanceToSun(ground.z, std::sin(-3.0 * M_PI / 180.0)).x, 0.0);
  EXPECT_LT(earth.skyRadiance(ground, {0.0, 0.0, 1.0}, elevated(-8.0)).radiance.z, 0.1 * zenith.z);
}

TEST(Atmosphere, MarsDaySkyIsButterscotchAndBlueNearTheSettingSun) {
  const AtmosphereTables& mars = marsTables();
  const glm::dvec3 ground(0.0, 0.0, AtmosphereParameters::mars().bottomRadius + 10.0);
  const glm::dvec3 daySun = elevated(50.0);
  const glm::dvec3 away = mars.skyRadiance(ground, elevated(30.0, -1.0), daySun).radiance;
  EXPECT_GT(away.x, away.y);
  EXPECT_GT(away.y, away.z);
  EXPECT_GT(away.x, 1.4 * away.z);
  const glm::dvec3 sunsetSun = elevated(3.0);
  const glm::dvec3 aureole = mars.skyRadiance(ground, elevated(6.0), sunsetSun).radiance;
  EXPECT_GT(aureole.z, aureole.x);  // the blue sunset
}

TEST(Atmosphere, AerialPerspectiveGrowsWithDistance) {
  const AtmosphereTables& earth = earthTables();
  const double bottom = AtmosphereParameters::earth().bottomRadius;
  const glm::dvec3 camera(0.0, 0.0, bottom + 2000.0);
  const glm::dvec3 sun = elevated(40.0);
  const glm::dvec3 albedo(0.1, 0.15, 0.05);
  double previousDistanceToSky = 1e30;
  glm::dvec3 previousTransmittance(1.0);
  for (const double km : {5.0, 20.0, 60.0, 150.0}) {
    SCOPED_TRACE(km);
    // A ground point `km` away along the surface, towards −y (sideways to the sun).
    const double angle = km * 1e3 / bottom;
    const glm::dvec3 point(0.0, -bottom * std::sin(angle), bottom * std::cos(angle));
    const AtmosphereTables::Radiance air = earth.skyRadianceToPoint(camera, point, sun);
    const AtmosphereTables::Irradiance light =
        earth.sunAndSkyIrradiance(point, glm::normalize(point), sun);
    const glm::dvec3 ground = albedo / M_PI * (light.sun + light.sky);
    const glm::dvec3 seen = ground * air.transmittance + air.radiance;
    const glm::dvec3 sky = earth.skyRadiance(camera, glm::normalize(point - camera), sun).radiance;
    const double distanceToSky = glm::length(seen - sky);
    EXPECT_LT(distanceToSky, previousDistanceToSky);
    EXPECT_LT(air.transmittance.z, previousTransmittance.z);
    previousDistanceToSky = distanceToSky;
    previousTransmittance = air.transmittance;
  }
}

TEST(Atmosphere, MultipleScatteringAddsLightAndTheTablesDoNotDependOnThreads) {
  const AtmosphereParameters p = AtmosphereParameters::earth();
  const AtmosphereTables single = AtmosphereTables::compute(p, small(1));
  const glm::dvec3 ground(0.0, 0.0, p.bottomRadius + 10.0);
  const glm::dvec3 sun = elevated(30.0);
  const glm::dvec3 once = single.skyRadiance(ground, {0.0, 0.0, 1.0}, sun).radiance;
  const glm::dvec3 many = earthTables().skyRadiance(ground, {0.0, 0.0, 1.0}, sun).radiance;
  for (int c = 0; c < 3; ++c) EXPECT_GT(many[c], once[c] * 1.02) << c;
  EXPECT_GT(earthTables().irradiance().texel(15, 0).y, 0.0);  // the sky lights the ground

  tbb::task_arena oneThread(1);
  AtmosphereTables serial =
      oneThread.execute([&] { return AtmosphereTables::compute(p, small()); });
  EXPECT_TRUE(serial.transmittance().rgb == earthTables().transmittance().rgb);
  EXPECT_TRUE(serial.scattering().rgb == earthTables().scattering().rgb);
  EXPECT_TRUE(serial.singleMieScattering().rgb == earthTables().singleMieScattering().rgb);
  EXPECT_TRUE(serial.irradiance().rgb == earthTables().irradiance().rgb);
}

/// Every texel finite and not negative.
void expectFiniteAndNonNegative(const AtmosphereTable& table, const char* name) {
  std::size_t bad = 0;
  for (const float v : table.rgb) bad += (std::isfinite(v) && v >= 0.0f) ? 0u : 1u;
  EXPECT_EQ(bad, 0u) << name << ": " << bad << " of " << table.rgb.size() << " values";
}

TEST(Atmosphere, TheTablesHoldFiniteNonNegativeLight) {
  for (const AtmosphereTables* tables : {&earthTables(), &marsTables()}) {
    expectFiniteAndNonNegative(tables->transmittance(), "transmittance");
    expectFiniteAndNonNegative(tables->scattering(), "scattering");
    expectFiniteAndNonNegative(tables->singleMieScattering(), "single Mie");
    expectFiniteAndNonNegative(tables->irradiance(), "irradiance");
  }
}

TEST(Atmosphere, TheNightSideSeenFromAboveTheAirIsDarkAndFinite) {
  // A camera 500 km over Mars looking obliquely down at ground on the night side (the sun
  // opposite): every ray to the ground, grazing ones included, gives finite, non-negative light
  // and transmittance, and no more in-scattered light than a faint glow.
  const AtmosphereTables& mars = marsTables();
  const double bottom = AtmosphereParameters::mars().bottomRadius;
  const glm::dvec3 camera(0.0, 0.0, bottom + 500e3);
  const glm::dvec3 sun(0.0, 0.0, -1.0);
  for (const double degrees : {0.0, 5.0, 10.0, 15.0, 19.0, 20.0, 21.0}) {
    SCOPED_TRACE(degrees);
    const double angle = degrees * M_PI / 180.0;
    const glm::dvec3 point(bottom * std::sin(angle), 0.0, bottom * std::cos(angle));
    const AtmosphereTables::Radiance air = mars.skyRadianceToPoint(camera, point, sun);
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(std::isfinite(air.radiance[c]) && air.radiance[c] >= 0.0) << air.radiance[c];
      EXPECT_TRUE(std::isfinite(air.transmittance[c]) && air.transmittance[c] >= 0.0 &&
                  air.transmittance[c] <= 1.0)
          << air.transmittance[c];
      EXPECT_LT(air.radiance[c], 1e-3);
    }
  }
}

TEST(Atmosphere, TheBodyChoosesItsAtmosphere) {
  EXPECT_TRUE(AtmosphereParameters::of(Planet::earthWgs84()).has_value());
  EXPECT_TRUE(AtmosphereParameters::of(Planet::mars()).has_value());
  EXPECT_FALSE(AtmosphereParameters::of(Planet::moon()).has_value());
}

}  // namespace
}  // namespace pbdam::runtime
