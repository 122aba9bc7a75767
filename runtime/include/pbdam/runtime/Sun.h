// The sun where it is (docs/architecture.md "Light"): UTC instants from ISO 8601, and the subsolar
// point of Earth and Mars at an instant from established ephemerides — for Earth the low-accuracy
// solar coordinates and sidereal time of Meeus, Astronomical Algorithms (2nd ed., ch. 12 and 25;
// the algorithm behind NOAA's solar calculator), for Mars the Mars24 algorithm of Allison &
// McEwen (2000) as NASA GISS documents it (giss.nasa.gov/tools/mars24/help/algorithm.html).
// Both are good to about 0.01° over 1800–2200, far below a pixel of a whole-planet view.
// Thread-safety: pure functions.
#pragma once

#include <glm/vec3.hpp>
#include <string>
#include <string_view>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// Parses an ISO 8601 UTC instant: "YYYY-MM-DD", "YYYY-MM-DDThh:mm", "YYYY-MM-DDThh:mm:ss" with
/// optional fraction of a second, then optionally "Z" or an offset "±hh:mm" (a space may stand
/// for the "T"). Years 1800–2200. Returns POSIX seconds since 1970-01-01T00:00:00Z (leap seconds
/// not counted, as UTC clocks read); InvalidArgument naming the text and what is wrong.
formats::Result<double> parseUtcTime(std::string_view text);

/// The ISO 8601 text of POSIX seconds: "YYYY-MM-DDThh:mm:ssZ", with ".sss" when the instant is
/// not a whole second.
std::string formatUtcTime(double unixSeconds);

/// TT − UTC in seconds at a UTC instant: 32.184 s plus TAI − UTC from the leap-second table
/// (1972–2017; 37 s since 2017-01-01, no leap second announced since). Before 1972, 42.184 s
/// (the first TAI − UTC of 10 s): the sun's direction moves by 0.004° in a second.
double terrestrialMinusUtcSeconds(double unixSeconds) noexcept;

/// The point of a body's surface where the sun stands at the zenith, and the sun's distance.
struct SubsolarPoint final {
  double latDegrees = 0.0;  ///< the sun's declination: planetographic latitude of the point
  double lonDegrees = 0.0;  ///< east longitude, in (-180, 180]
  double distanceAu = 1.0;  ///< the body's distance from the sun in astronomical units
};

/// Earth's subsolar point at a UTC instant (Meeus ch. 25, low accuracy: apparent right ascension
/// and declination; ch. 12: apparent sidereal time at Greenwich; longitude = α − GAST).
SubsolarPoint earthSubsolarPoint(double unixSeconds) noexcept;

/// Mars time at an instant, as Mars24 computes it (AM2000, steps A–C).
struct MarsSolarTime final {
  double solarLongitudeDegrees = 0.0;  ///< Ls, the season: 0 northern spring equinox, in [0, 360)
  double equationOfTimeDegrees = 0.0;  ///< EOT (true minus mean solar time, as an angle)
  double meanSolarTimeHours = 0.0;     ///< MST (coordinated Mars time) at the prime meridian
};

/// Mars24's Ls, equation of time and coordinated Mars time at a UTC instant.
MarsSolarTime marsSolarTime(double unixSeconds) noexcept;

/// Mars's subsolar point at a UTC instant (Mars24: longitude MST·15° + EOT + 180° west, turned
/// east; declination asin(0.42565 sin Ls) + 0.25° sin Ls, planetographic; heliocentric distance).
SubsolarPoint marsSubsolarPoint(double unixSeconds) noexcept;

/// The bodies with an ephemeris here.
enum class SolarBody { None, Earth, Mars };

/// The body whose reference surface `planet` is: Earth for "earth" (WGS84), Mars for "mars" and
/// "mars-iau2000", None for anything else (the Moon, custom spheres and ellipsoids).
SolarBody solarBodyOf(const Planet& planet) noexcept;

/// The subsolar point of `planet`'s body at a UTC instant; InvalidArgument naming the planet
/// when it has no ephemeris (then a light must be chosen with an azimuth and elevation).
formats::Result<SubsolarPoint> subsolarPoint(const Planet& planet, double unixSeconds);

/// The unit direction towards the sun in the planet's body-fixed (ECEF) axes: the surface normal
/// at the subsolar point.
glm::dvec3 sunDirectionEcef(const Planet& planet, const SubsolarPoint& subsolar) noexcept;

/// The unit direction towards a sun at azimuth `azimuthDegrees` (clockwise from north) and
/// elevation `elevationDegrees` above the horizon of the point (latDegrees, lonDegrees).
glm::dvec3 sunDirectionFromHorizon(const Planet& planet, double latDegrees, double lonDegrees,
                                   double azimuthDegrees, double elevationDegrees) noexcept;

/// The sun's angular radius in radians seen from `distanceAu` (its radius is 695,700 km, the IAU
/// 2015 nominal value).
double sunAngularRadiusRadians(double distanceAu) noexcept;

}  // namespace pbdam::runtime
