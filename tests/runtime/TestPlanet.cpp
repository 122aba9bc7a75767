// Tests for Planet: spec parsing, WGS84/Mars known values, geodetic <-> ECEF round trips, ENU
// frames, geocentric-direction conversions and GeographicLib's documented geodesic example.
#include <gtest/gtest.h>

#include <GeographicLib/LocalCartesian.hpp>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "pbdam/runtime/Planet.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::runtime {
namespace {

constexpr double kWgs84A = 6378137.0;
constexpr double kWgs84F = 1.0 / 298.257223563;
constexpr double kDegToRad = std::numbers::pi / 180.0;

Planet mustParse(std::string_view spec) {
  Result<Planet> planet = Planet::fromSpec(spec);
  EXPECT_TRUE(planet.ok()) << spec << ": " << (planet.ok() ? "" : planet.error().message);
  return planet.ok() ? std::move(planet).value() : Planet::mars();
}

// Textbook closed form of geodetic -> ECEF (prime vertical radius of curvature), independent of
// GeographicLib.
glm::dvec3 closedFormEcef(double a, double f, double latDegrees, double lonDegrees, double h) {
  const double e2 = f * (2.0 - f);
  const double lat = latDegrees * kDegToRad;
  const double lon = lonDegrees * kDegToRad;
  const double n = a / std::sqrt(1.0 - e2 * std::sin(lat) * std::sin(lat));
  return {(n + h) * std::cos(lat) * std::cos(lon), (n + h) * std::cos(lat) * std::sin(lon),
          (n * (1.0 - e2) + h) * std::sin(lat)};
}

TEST(Planet, NamedModelsHaveTheirParameters) {
  const Planet mars = mustParse("mars");
  EXPECT_EQ(mars.equatorialRadiusMeters(), 3396190.0);
  EXPECT_TRUE(mars.isSphere());
  EXPECT_EQ(mars.name(), "mars");

  const Planet iau = mustParse("mars-iau2000");
  EXPECT_EQ(iau.equatorialRadiusMeters(), 3396190.0);
  EXPECT_NEAR(iau.polarRadiusMeters(), 3376200.0, 1e-6);
  EXPECT_FALSE(iau.isSphere());

  const Planet earth = mustParse("earth");
  EXPECT_EQ(earth.equatorialRadiusMeters(), kWgs84A);
  EXPECT_EQ(earth.flattening(), kWgs84F);
  EXPECT_EQ(mustParse("WGS84"), earth);

  const Planet moon = mustParse("moon");
  EXPECT_EQ(moon.equatorialRadiusMeters(), 1737400.0);
  EXPECT_TRUE(moon.isSphere());
  EXPECT_NE(moon, mars);
}

TEST(Planet, ParsesParametricSpecs) {
  const Planet sphere = mustParse("sphere:1000.5");
  EXPECT_EQ(sphere.equatorialRadiusMeters(), 1000.5);
  EXPECT_TRUE(sphere.isSphere());

  EXPECT_EQ(mustParse("ellipsoid:6378137,1/298.257223563"), Planet::earthWgs84());
  const Planet decimal = mustParse("  Ellipsoid: 100 , 0.25 ");
  EXPECT_EQ(decimal.equatorialRadiusMeters(), 100.0);
  EXPECT_EQ(decimal.flattening(), 0.25);
  EXPECT_EQ(decimal.polarRadiusMeters(), 75.0);
  EXPECT_TRUE(mustParse("ellipsoid:3396190,0").isSphere());
  EXPECT_EQ(mustParse("sphere:3396190"), Planet::mars());
}

TEST(Planet, NameIsASpecThatParsesBackExactly) {
  for (const char* spec : {"mars", "mars-iau2000", "earth", "moon", "sphere:1234.5678901234567",
                           "ellipsoid:6378137,1/298.257223563", "ellipsoid:1e7,0.1"}) {
    const Planet planet = mustParse(spec);
    const Planet again = mustParse(planet.name());
    EXPECT_EQ(again, planet) << spec << " -> " << planet.name();
    EXPECT_EQ(again.name(), planet.name());
    EXPECT_FALSE(planet.description().empty());
  }
  EXPECT_EQ(Planet::marsIau2000().description(),
            "Mars IAU 2000 ellipsoid, a = 3396190 m, b = 3376200 m");
}

TEST(Planet, RejectsBadSpecsNamingThem) {
  for (const char* spec : {"",
                           "venus",
                           "mars:",
                           "sphere:",
                           "sphere:abc",
                           "sphere:-5",
                           "sphere:0",
                           "sphere:inf",
                           "sphere:nan",
                           "sphere:1e400",
                           "sphere:12m",
                           "ellipsoid:1",
                           "ellipsoid:1,1",
                           "ellipsoid:1,-0.1",
                           "ellipsoid:1,1/0",
                           "ellipsoid:-1,0.1",
                           "ellipsoid:1,0.1x",
                           "ellipsoid:1,nan",
                           "ellipsoid:,0.1",
                           "ellipsoid:1,1/x"}) {
    const Result<Planet> planet = Planet::fromSpec(spec);
    ASSERT_FALSE(planet.ok()) << "accepted '" << spec << "'";
    EXPECT_EQ(planet.error().code, ErrorCode::InvalidArgument);
    // Built with append: GCC 12 at -O3 warns falsely (-Wrestrict) on "'" + std::string + "'".
    std::string quoted = "'";
    quoted.append(spec).append("'");
    EXPECT_NE(planet.error().message.find(quoted), std::string::npos) << planet.error().message;
  }
  EXPECT_FALSE(Planet::sphere(-1.0).ok());
  EXPECT_FALSE(Planet::ellipsoid(1.0, 1.0).ok());
  EXPECT_FALSE(Planet::ellipsoid(std::nan(""), 0.0).ok());
}

TEST(Planet, Wgs84EcefKnownValues) {
  const Planet earth = Planet::earthWgs84();
  const glm::dvec3 origin = earth.geodeticToEcef(0.0, 0.0, 0.0);
  EXPECT_NEAR(origin.x, 6378137.0, 1e-9);
  EXPECT_NEAR(origin.y, 0.0, 1e-9);
  EXPECT_NEAR(origin.z, 0.0, 1e-9);

  const glm::dvec3 pole = earth.geodeticToEcef(90.0, 0.0, 0.0);
  EXPECT_NEAR(pole.x, 0.0, 1e-9);
  EXPECT_NEAR(pole.y, 0.0, 1e-9);
  EXPECT_NEAR(pole.z, 6356752.314245, 1e-6);

  const glm::dvec3 east = earth.geodeticToEcef(0.0, 90.0, 1000.0);
  EXPECT_NEAR(east.x, 0.0, 1e-9);
  EXPECT_NEAR(east.y, 6379137.0, 1e-9);

  for (double lat = -90.0; lat <= 90.0; lat += 7.5) {
    for (double lon = -180.0; lon < 180.0; lon += 15.0) {
      for (double h : {-400.0, 0.0, 8848.0, 4.0e5}) {
        const glm::dvec3 expected = closedFormEcef(kWgs84A, kWgs84F, lat, lon, h);
        const glm::dvec3 actual = earth.geodeticToEcef(lat, lon, h);
        EXPECT_LT(glm::length(actual - expected), 1e-6) << lat << " " << lon << " " << h;
      }
    }
  }
}

TEST(Planet, SphereHeightsAreRadial) {
  const Planet mars = Planet::mars();
  for (double lat = -90.0; lat <= 90.0; lat += 10.0) {
    for (double h : {-8200.0, 0.0, 21229.0}) {
      const glm::dvec3 p = mars.geodeticToEcef(lat, 33.0, h);
      EXPECT_NEAR(glm::length(p), 3396190.0 + h, 1e-8);
      EXPECT_NEAR(std::asin(p.z / glm::length(p)) / kDegToRad, lat, 1e-12);
    }
  }
}

TEST(Planet, EcefToGeodeticRoundTrips) {
  for (const Planet& planet : {Planet::earthWgs84(), Planet::marsIau2000(), Planet::mars()}) {
    for (double lat = -90.0; lat <= 90.0; lat += 2.5) {
      for (double lon = -179.0; lon < 180.0; lon += 11.0) {
        for (double h : {-1.0e4, 0.0, 1.0e3, 1.0e6}) {
          const GeodeticPosition back = planet.ecefToGeodetic(planet.geodeticToEcef(lat, lon, h));
          EXPECT_NEAR(back.latDegrees, lat, 1e-11);
          if (std::fabs(lat) < 90.0) {
            EXPECT_NEAR(back.lonDegrees, lon, 1e-11);
          }
          EXPECT_NEAR(back.heightMeters, h, 1e-6);
        }
      }
    }
  }
}

TEST(Planet, SurfaceNormalIsPerpendicularToTheEllipsoid) {
  const Planet planet = Planet::marsIau2000();
  const double a = planet.equatorialRadiusMeters();
  const double b = planet.polarRadiusMeters();
  for (double lat = -89.0; lat <= 89.0; lat += 8.0) {
    for (double lon = -170.0; lon < 180.0; lon += 40.0) {
      const glm::dvec3 p = planet.geodeticToEcef(lat, lon, 0.0);
      const glm::dvec3 gradient =
          glm::normalize(glm::dvec3(p.x / (a * a), p.y / (a * a), p.z / (b * b)));
      EXPECT_LT(glm::length(planet.surfaceNormal(lat, lon) - gradient), 1e-12);
      // A point 1 km up the normal has height 1 km.
      const GeodeticPosition up =
          planet.ecefToGeodetic(p + 1000.0 * planet.surfaceNormal(lat, lon));
      EXPECT_NEAR(up.heightMeters, 1000.0, 1e-6);
    }
  }
}

TEST(Planet, EnuFrameMatchesGeographicLibLocalCartesian) {
  const Planet earth = Planet::earthWgs84();
  for (const auto& [lat, lon, h] : std::vector<std::array<double, 3>>{
           {40.6, -73.8, 10.0}, {-33.9, 151.2, 0.0}, {0.0, 0.0, 0.0}, {89.5, 12.0, 3000.0}}) {
    const EnuFrame frame = earth.enuFrame(lat, lon, h);
    EXPECT_NEAR(glm::determinant(frame.axes), 1.0, 1e-14);
    EXPECT_LT(glm::length(frame.axes[2] - earth.surfaceNormal(lat, lon)), 1e-15);
    const GeographicLib::LocalCartesian reference(lat, lon, h, GeographicLib::Geocentric::WGS84());
    for (const glm::dvec3& enu : {glm::dvec3(100.0, 0.0, 0.0), glm::dvec3(0.0, 250.0, 0.0),
                                  glm::dvec3(-1.0e4, 3.0e4, 500.0)}) {
      double lat2 = 0.0;
      double lon2 = 0.0;
      double h2 = 0.0;
      reference.Reverse(enu.x, enu.y, enu.z, lat2, lon2, h2);
      const glm::dvec3 expected = earth.geodeticToEcef(lat2, lon2, h2);
      EXPECT_LT(glm::length(frame.enuToEcef(enu) - expected), 1e-6);
      EXPECT_LT(glm::length(frame.ecefToEnu(expected) - enu), 1e-6);
      EXPECT_LT(glm::length(frame.ecefToEnuDirection(frame.enuToEcefDirection(enu)) - enu), 1e-9);
    }
  }
}

TEST(Planet, GeocentricDirectionsConvertToGeodeticAndBack) {
  for (const Planet& planet :
       {Planet::earthWgs84(), Planet::marsIau2000(), mustParse("ellipsoid:1000,0.3")}) {
    for (double lat = -90.0; lat <= 90.0; lat += 1.25) {
      for (double lon = -175.0; lon < 180.0; lon += 25.0) {
        const glm::dvec3 direction = planet.geodeticToDirection(lat, lon);
        EXPECT_NEAR(glm::length(direction), 1.0, 1e-15);
        const GeodeticPosition back = planet.directionToGeodetic(direction);
        EXPECT_NEAR(back.latDegrees, lat, 1e-12);
        if (std::fabs(lat) < 90.0) {
          EXPECT_NEAR(back.lonDegrees, lon, 1e-12);
        }
        // The surface point along the direction is the geodetic surface point.
        const glm::dvec3 surface = planet.directionToSurfaceEcef(direction);
        const glm::dvec3 expected = planet.geodeticToEcef(lat, lon, 0.0);
        EXPECT_LT(glm::length(surface - expected), 1e-9 * planet.equatorialRadiusMeters());
      }
    }
  }
  // On an ellipsoid the geodetic latitude of a geocentric direction is larger (away from the
  // equator); at 45° geocentric on WGS84 it is 45.19°.
  const GeodeticPosition geodetic =
      Planet::earthWgs84().directionToGeodetic(glm::normalize(glm::dvec3(1.0, 0.0, 1.0)));
  EXPECT_NEAR(geodetic.latDegrees, 45.1924, 1e-4);
  // On a sphere the two are the same.
  const Planet mars = Planet::mars();
  const GeodeticPosition onSphere = mars.directionToGeodetic(glm::dvec3(1.0, 1.0, 1.0));
  EXPECT_NEAR(onSphere.latDegrees, std::atan(1.0 / std::sqrt(2.0)) / kDegToRad, 1e-12);
  EXPECT_NEAR(onSphere.lonDegrees, 45.0, 1e-12);
}

// GeographicLib's own example (examples/example-Geodesic.cpp in libgeographiclib-dev; its published
// output): JFK (40.6, -73.8) to LHR (51.6, -0.5) on WGS84 is 5551759.400319 m, azimuths
// 51.198883° and 107.821777°; from JFK at azimuth 51° for 5500 km one arrives at
// (51.884565, -1.141173) heading 107.189397°.
TEST(Planet, Wgs84GeodesicMatchesGeographicLibDocumentation) {
  const Planet earth = Planet::earthWgs84();
  const GeodesicInverse inverse = earth.geodesicInverse(40.6, -73.8, 51.6, -0.5);
  EXPECT_NEAR(inverse.distanceMeters, 5551759.400319, 1e-3);
  EXPECT_NEAR(inverse.azimuth1Degrees, 51.198883, 1e-6);
  EXPECT_NEAR(inverse.azimuth2Degrees, 107.821777, 1e-6);

  const GeodesicDirect direct = earth.geodesicDirect(40.6, -73.8, 51.0, 5.5e6);
  EXPECT_NEAR(direct.latDegrees, 51.884565, 1e-6);
  EXPECT_NEAR(direct.lonDegrees, -1.141173, 1e-6);
  EXPECT_NEAR(direct.azimuth2Degrees, 107.189397, 1e-6);

  // Direct undoes inverse.
  const GeodesicDirect back =
      earth.geodesicDirect(40.6, -73.8, inverse.azimuth1Degrees, inverse.distanceMeters);
  EXPECT_NEAR(back.latDegrees, 51.6, 1e-9);
  EXPECT_NEAR(back.lonDegrees, -0.5, 1e-9);
}

TEST(Planet, SphereGeodesicsAreGreatCircles) {
  const Planet mars = Planet::mars();
  const double r = 3396190.0;
  EXPECT_NEAR(mars.geodesicInverse(0.0, 0.0, 0.0, 90.0).distanceMeters, r * std::numbers::pi / 2,
              1e-6);
  EXPECT_NEAR(mars.geodesicInverse(0.0, 10.0, 90.0, 0.0).distanceMeters, r * std::numbers::pi / 2,
              1e-6);
  for (double lat2 = -80.0; lat2 <= 80.0; lat2 += 20.0) {
    const double lat1 = 12.0;
    const double lon1 = -40.0;
    const double lon2 = 75.0;
    // Haversine formula for the central angle.
    const double dLat = (lat2 - lat1) * kDegToRad;
    const double dLon = (lon2 - lon1) * kDegToRad;
    const double h = std::sin(dLat / 2) * std::sin(dLat / 2) +
                     std::cos(lat1 * kDegToRad) * std::cos(lat2 * kDegToRad) * std::sin(dLon / 2) *
                         std::sin(dLon / 2);
    const double expected = 2.0 * r * std::asin(std::sqrt(h));
    EXPECT_NEAR(mars.geodesicInverse(lat1, lon1, lat2, lon2).distanceMeters, expected, 1e-5);
  }
}

TEST(Planet, StronglyFlattenedEllipsoidGeodesics) {
  // f = 0.5 uses GeodesicExact; along the equator (span < (1 - f) 180°) the geodesic is the
  // equator itself, of length a Δλ.
  const Planet squashed = mustParse("ellipsoid:1000,0.5");
  const GeodesicInverse inverse = squashed.geodesicInverse(0.0, 0.0, 0.0, 60.0);
  EXPECT_NEAR(inverse.distanceMeters, 1000.0 * std::numbers::pi / 3.0, 1e-9);
  EXPECT_NEAR(inverse.azimuth1Degrees, 90.0, 1e-9);
  // Meridian: pole to equator is a quarter of the meridian ellipse (a = 1000, b = 500), whose
  // perimeter/4 is 1000 E(e) with e² = 0.75: 1211.056028 m.
  EXPECT_NEAR(squashed.geodesicInverse(0.0, 0.0, 90.0, 0.0).distanceMeters, 1211.056028, 1e-5);
}

}  // namespace
}  // namespace pbdam::runtime
