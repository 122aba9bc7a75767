// The sun's place against published values: Meeus's worked examples (Astronomical Algorithms,
// 2nd ed., Examples 25.a and 28.b), USNO's equinox and solstice instants of 2024, and the two
// worked examples of the Mars24 algorithm (NASA GISS, giss.nasa.gov/tools/mars24/help/
// algorithm.html: A, 2000-01-06 00:00:00 UTC; B, Spirit's landing, 2004-01-03 13:46:31 UTC).
// ISO 8601 parsing, its errors, and the light from an azimuth and elevation.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>

#include "pbdam/runtime/Sun.h"

namespace pbdam::runtime {
namespace {

double utc(const char* text) {
  auto t = parseUtcTime(text);
  EXPECT_TRUE(t.ok()) << text << ": " << (t.ok() ? "" : t.error().message);
  return t.ok() ? *t : 0.0;
}

double angleBetweenDegrees(double a, double b) {
  double d = std::fmod(a - b, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d < -180.0) d += 360.0;
  return std::abs(d);
}

TEST(Sun, Iso8601TimesParseToPosixSeconds) {
  EXPECT_EQ(utc("1970-01-01T00:00:00Z"), 0.0);
  EXPECT_EQ(utc("1970-01-02"), 86400.0);
  EXPECT_EQ(utc("2000-01-06T00:00:00Z"), 947116800.0);   // Mars24 example A's millis / 1000
  EXPECT_EQ(utc("2004-01-03T13:46:31Z"), 1073137591.0);  // example B
  EXPECT_EQ(utc("2004-01-03 13:46:31"), 1073137591.0);
  EXPECT_EQ(utc("2004-01-03T14:46:31+01:00"), 1073137591.0);
  EXPECT_EQ(utc("2004-01-03T13:46"), 1073137560.0);
  EXPECT_DOUBLE_EQ(utc("2004-01-03T13:46:31.25Z"), 1073137591.25);
  EXPECT_EQ(formatUtcTime(1073137591.0), "2004-01-03T13:46:31Z");
  EXPECT_EQ(formatUtcTime(1073137591.25), "2004-01-03T13:46:31.250Z");
  EXPECT_EQ(formatUtcTime(-86400.0), "1969-12-31T00:00:00Z");
  for (const char* bad :
       {"", "2024", "2024-13-01", "2024-02-30", "2024-03-20T25:00", "2024-03-20T06:00:61",
        "2024-03-20T06", "2024-03-20X06:00", "2024-03-20T06:00Q", "2024-03-20T06:00+5",
        "1700-01-01", "2024-03-20T06:00:00Z junk", "2024-03-20T06:00:00."}) {
    auto t = parseUtcTime(bad);
    ASSERT_FALSE(t.ok()) << bad;
    EXPECT_EQ(t.error().code, formats::ErrorCode::InvalidArgument);
    EXPECT_NE(t.error().message.find(std::string("time '") + bad + "'"), std::string::npos)
        << t.error().message;
  }
}

TEST(Sun, TerrestrialTimeFollowsTheLeapSeconds) {
  EXPECT_DOUBLE_EQ(terrestrialMinusUtcSeconds(utc("2000-01-06T00:00:00Z")), 64.184);
  EXPECT_DOUBLE_EQ(terrestrialMinusUtcSeconds(utc("2016-12-31T23:59:59Z")), 68.184);
  EXPECT_DOUBLE_EQ(terrestrialMinusUtcSeconds(utc("2017-01-01T00:00:00Z")), 69.184);
  EXPECT_DOUBLE_EQ(terrestrialMinusUtcSeconds(utc("2026-11-29T00:00:00Z")), 69.184);
  EXPECT_DOUBLE_EQ(terrestrialMinusUtcSeconds(utc("1960-01-01T00:00:00Z")), 42.184);
}

TEST(Sun, EarthMatchesMeeusWorkedExamples) {
  // 1992 October 13.0 TD (TT − UTC = 59.184 s then). Example 25.a: δ = −7.78507°, R = 0.99766
  // AU. Example 28.b: the equation of time E = +3.427351° (13m42.6s), so the sun stands over
  // longitude 180° − 15°·UT − E.
  const double ttMinusUtc = 59.184;
  const double t = utc("1992-10-13T00:00:00Z") - ttMinusUtc;
  const SubsolarPoint sun = earthSubsolarPoint(t);
  EXPECT_NEAR(sun.latDegrees, -7.78507, 0.001);
  EXPECT_NEAR(sun.distanceAu, 0.99766, 0.0001);
  const double expectedLon = 180.0 + 15.0 * ttMinusUtc / 3600.0 - 3.427351;
  EXPECT_LT(angleBetweenDegrees(sun.lonDegrees, expectedLon), 0.01) << sun.lonDegrees;
}

TEST(Sun, EarthDeclinationAtTheEquinoxAndSolsticeOf2024) {
  // USNO: March equinox 2024-03-20 03:06 UTC, June solstice 2024-06-20 20:51 UTC (to the
  // minute: the declination moves by at most 0.0003° in a minute there).
  EXPECT_NEAR(earthSubsolarPoint(utc("2024-03-20T03:06Z")).latDegrees, 0.0, 0.005);
  EXPECT_NEAR(earthSubsolarPoint(utc("2024-06-20T20:51Z")).latDegrees, 23.437, 0.005);
  // Noon at Greenwich moves the sun to about longitude 0 (within the equation of time's 4.1°).
  EXPECT_LT(std::abs(earthSubsolarPoint(utc("2024-06-20T12:00Z")).lonDegrees), 4.1);
}

struct Mars24Example {
  const char* utc;
  double ls;
  double eotDegrees;
  double mstHours;
  double subsolarWestDegrees;
  double declination;
};

TEST(Sun, MarsMatchesTheMars24WorkedExamples) {
  for (const Mars24Example& e : {
           Mars24Example{"2000-01-06T00:00:00Z", 277.187, -5.1877, 23.9943, 174.727, -25.228},
           Mars24Example{"2004-01-03T13:46:31Z", 327.323, -12.7756, 13.1654, 4.706, -13.421},
       }) {
    SCOPED_TRACE(e.utc);
    const double t = utc(e.utc);
    const MarsSolarTime time = marsSolarTime(t);
    EXPECT_NEAR(time.solarLongitudeDegrees, e.ls, 0.01);
    EXPECT_NEAR(time.equationOfTimeDegrees, e.eotDegrees, 0.01);
    EXPECT_NEAR(time.meanSolarTimeHours, e.mstHours, 0.001);
    const SubsolarPoint sun = marsSubsolarPoint(t);
    EXPECT_LT(angleBetweenDegrees(sun.lonDegrees, -e.subsolarWestDegrees), 0.01) << sun.lonDegrees;
    EXPECT_NEAR(sun.latDegrees, e.declination, 0.01);
    EXPECT_GT(sun.distanceAu, 1.38);  // perihelion 1.381 AU, aphelion 1.666 AU
    EXPECT_LT(sun.distanceAu, 1.67);
  }
}

TEST(Sun, TheBodyFollowsThePlanetAndOthersHaveNoEphemeris) {
  EXPECT_EQ(solarBodyOf(Planet::earthWgs84()), SolarBody::Earth);
  EXPECT_EQ(solarBodyOf(Planet::mars()), SolarBody::Mars);
  EXPECT_EQ(solarBodyOf(Planet::marsIau2000()), SolarBody::Mars);
  EXPECT_EQ(solarBodyOf(Planet::moon()), SolarBody::None);
  auto none = subsolarPoint(Planet::moon(), 0.0);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("no ephemeris for planet 'moon'"), std::string::npos)
      << none.error().message;
  auto mars = subsolarPoint(Planet::mars(), utc("2004-01-03T13:46:31Z"));
  ASSERT_TRUE(mars.ok());
  const glm::dvec3 d = sunDirectionEcef(Planet::mars(), *mars);
  EXPECT_NEAR(glm::length(d), 1.0, 1e-12);
  EXPECT_NEAR(std::asin(d.z) * 180.0 / M_PI, mars->latDegrees, 1e-9);
}

TEST(Sun, AnAzimuthAndElevationPointAtTheSky) {
  const Planet earth = Planet::earthWgs84();
  const glm::dvec3 up = earth.surfaceNormal(45.0, 10.0);
  const glm::dvec3 zenith = sunDirectionFromHorizon(earth, 45.0, 10.0, 123.0, 90.0);
  EXPECT_NEAR(glm::dot(zenith, up), 1.0, 1e-12);
  const glm::dvec3 east = sunDirectionFromHorizon(earth, 45.0, 10.0, 90.0, 0.0);
  EXPECT_NEAR(glm::dot(east, up), 0.0, 1e-12);
  EXPECT_NEAR(glm::dot(east, glm::dvec3(-std::sin(10.0 * M_PI / 180.0),
                                        std::cos(10.0 * M_PI / 180.0), 0.0)),
              1.0, 1e-12);
  const glm::dvec3 low = sunDirectionFromHorizon(earth, 45.0, 10.0, 270.0, 5.0);
  EXPECT_NEAR(std::asin(glm::dot(low, up)) * 180.0 / M_PI, 5.0, 1e-9);
  // The sun's disc: 0.2666° from Earth at 1 AU, 0.175° from Mars at 1.524 AU.
  EXPECT_NEAR(sunAngularRadiusRadians(1.0) * 180.0 / M_PI, 0.2666, 0.0005);
  EXPECT_NEAR(sunAngularRadiusRadians(1.524) * 180.0 / M_PI, 0.1749, 0.0005);
}

}  // namespace
}  // namespace pbdam::runtime
