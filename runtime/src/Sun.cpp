// Solar ephemerides for Earth and Mars (Sun.h).
#include "pbdam/runtime/Sun.h"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>

namespace pbdam::runtime {
namespace {

using formats::ErrorCode;
using formats::makeError;
using formats::Result;

constexpr double kDegrees = std::numbers::pi / 180.0;
constexpr double kSecondsPerDay = 86400.0;
constexpr double kUnixEpochJulianDay = 2440587.5;
constexpr double kJ2000 = 2451545.0;

double sinDeg(double degrees) { return std::sin(degrees * kDegrees); }
double cosDeg(double degrees) { return std::cos(degrees * kDegrees); }

/// `degrees` reduced to [0, 360).
double wrap360(double degrees) {
  const double r = std::fmod(degrees, 360.0);
  return r < 0.0 ? r + 360.0 : r;
}

/// `degrees` reduced to (-180, 180].
double wrap180(double degrees) {
  const double r = wrap360(degrees);
  return r > 180.0 ? r - 360.0 : r;
}

double julianDayUt(double unixSeconds) {
  return kUnixEpochJulianDay + unixSeconds / kSecondsPerDay;
}

double julianDayTt(double unixSeconds) {
  return julianDayUt(unixSeconds) + terrestrialMinusUtcSeconds(unixSeconds) / kSecondsPerDay;
}

/// POSIX seconds of a civil date (proleptic Gregorian) and time of day.
double unixSecondsOf(int year, unsigned month, unsigned day, double secondsOfDay) {
  const std::chrono::sys_days days{std::chrono::year{year} / std::chrono::month{month} /
                                   std::chrono::day{day}};
  return static_cast<double>(days.time_since_epoch().count()) * kSecondsPerDay + secondsOfDay;
}

/// The days since the epoch at which TAI − UTC stepped to 11, 12, ... 37 s (IERS Bulletin C).
struct LeapStep final {
  int year;
  unsigned month;
};
constexpr std::array<LeapStep, 27> kLeapSteps = {{
    {1972, 7}, {1973, 1}, {1974, 1}, {1975, 1}, {1976, 1}, {1977, 1}, {1978, 1},
    {1979, 1}, {1980, 1}, {1981, 7}, {1982, 7}, {1983, 7}, {1985, 7}, {1988, 1},
    {1990, 1}, {1991, 1}, {1992, 7}, {1993, 7}, {1994, 7}, {1996, 1}, {1997, 7},
    {1999, 1}, {2006, 1}, {2009, 1}, {2012, 7}, {2015, 7}, {2017, 1},
}};

/// Reads `count` decimal digits at `pos` (advancing it); nullopt if they are not all digits.
std::optional<int> digits(std::string_view text, std::size_t& pos, std::size_t count) {
  if (pos + count > text.size()) return std::nullopt;
  int value = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const char c = text[pos + i];
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + (c - '0');
  }
  pos += count;
  return value;
}

formats::Error timeError(std::string_view text, const std::string& what) {
  return makeError(ErrorCode::InvalidArgument,
                   "time '" + std::string(text) + "': " + what +
                       " (expected ISO 8601 UTC, e.g. 2024-03-20T06:00:00Z)");
}

}  // namespace

Result<double> parseUtcTime(std::string_view text) {
  std::size_t pos = 0;
  const auto year = digits(text, pos, 4);
  if (!year || pos >= text.size() || text[pos++] != '-') return timeError(text, "no YYYY-MM-DD");
  const auto month = digits(text, pos, 2);
  if (!month || pos >= text.size() || text[pos++] != '-') return timeError(text, "no YYYY-MM-DD");
  const auto day = digits(text, pos, 2);
  if (!day) return timeError(text, "no YYYY-MM-DD");
  if (*year < 1800 || *year > 2200) return timeError(text, "the year must be in 1800..2200");
  const std::chrono::year_month_day date{std::chrono::year{*year},
                                         std::chrono::month{static_cast<unsigned>(*month)},
                                         std::chrono::day{static_cast<unsigned>(*day)}};
  if (!date.ok()) return timeError(text, "no such date");
  double secondsOfDay = 0.0;
  double offsetSeconds = 0.0;
  if (pos < text.size()) {
    if (text[pos] != 'T' && text[pos] != 't' && text[pos] != ' ') {
      return timeError(text, "expected 'T' after the date");
    }
    ++pos;
    const auto hour = digits(text, pos, 2);
    if (!hour || pos >= text.size() || text[pos++] != ':') return timeError(text, "no hh:mm");
    const auto minute = digits(text, pos, 2);
    if (!minute) return timeError(text, "no hh:mm");
    double second = 0.0;
    if (pos < text.size() && text[pos] == ':') {
      ++pos;
      const auto whole = digits(text, pos, 2);
      if (!whole) return timeError(text, "no seconds after hh:mm:");
      second = *whole;
      if (pos < text.size() && (text[pos] == '.' || text[pos] == ',')) {
        ++pos;
        double scale = 0.1;
        const std::size_t start = pos;
        while (pos < text.size() && text[pos] >= '0' && text[pos] <= '9') {
          second += scale * (text[pos] - '0');
          scale *= 0.1;
          ++pos;
        }
        if (pos == start) return timeError(text, "no digits after the decimal point");
      }
    }
    if (*hour > 23 || *minute > 59 || second >= 60.0) {
      return timeError(text, "the time of day is out of range (leap second 60 not taken)");
    }
    secondsOfDay = *hour * 3600.0 + *minute * 60.0 + second;
    if (pos < text.size()) {
      const char zone = text[pos++];
      if (zone == 'Z' || zone == 'z') {
        // UTC
      } else if (zone == '+' || zone == '-') {
        const auto oh = digits(text, pos, 2);
        if (!oh || pos >= text.size() || text[pos++] != ':') {
          return timeError(text, "expected an offset ±hh:mm");
        }
        const auto om = digits(text, pos, 2);
        if (!om || *oh > 23 || *om > 59) return timeError(text, "expected an offset ±hh:mm");
        offsetSeconds = (zone == '+' ? 1.0 : -1.0) * (*oh * 3600.0 + *om * 60.0);
      } else {
        return timeError(text, "expected 'Z' or an offset ±hh:mm after the time");
      }
    }
  }
  if (pos != text.size()) return timeError(text, "unexpected text at the end");
  return unixSecondsOf(*year, static_cast<unsigned>(*month), static_cast<unsigned>(*day),
                       secondsOfDay) -
         offsetSeconds;
}

std::string formatUtcTime(double unixSeconds) {
  const double whole = std::floor(unixSeconds);
  const auto days = static_cast<long long>(std::floor(whole / kSecondsPerDay));
  const auto secondsOfDay =
      static_cast<long long>(whole - static_cast<double>(days) * kSecondsPerDay);
  const std::chrono::year_month_day date{std::chrono::sys_days{std::chrono::days{days}}};
  char text[48];
  std::snprintf(text, sizeof text, "%04d-%02u-%02uT%02lld:%02lld:%02lld",
                static_cast<int>(date.year()), static_cast<unsigned>(date.month()),
                static_cast<unsigned>(date.day()), secondsOfDay / 3600, secondsOfDay / 60 % 60,
                secondsOfDay % 60);
  std::string out = text;
  const double fraction = unixSeconds - whole;
  if (fraction >= 0.0005) {
    std::snprintf(text, sizeof text, "%.3f", fraction);
    out += std::string(text).substr(1);  // ".sss"
  }
  return out + "Z";
}

double terrestrialMinusUtcSeconds(double unixSeconds) noexcept {
  double taiMinusUtc = 10.0;
  for (const LeapStep& step : kLeapSteps) {
    if (unixSeconds < unixSecondsOf(step.year, step.month, 1, 0.0)) break;
    taiMinusUtc += 1.0;
  }
  return 32.184 + taiMinusUtc;
}

SubsolarPoint earthSubsolarPoint(double unixSeconds) noexcept {
  // Meeus ch. 25 (low accuracy): T in Julian centuries of TT from J2000.
  const double t = (julianDayTt(unixSeconds) - kJ2000) / 36525.0;
  const double meanLongitude = wrap360(280.46646 + t * (36000.76983 + t * 0.0003032));
  const double meanAnomaly = 357.52911 + t * (35999.05029 - t * 0.0001537);
  const double eccentricity = 0.016708634 - t * (0.000042037 + t * 0.0000001267);
  const double centre = (1.914602 - t * (0.004817 + t * 0.000014)) * sinDeg(meanAnomaly) +
                        (0.019993 - t * 0.000101) * sinDeg(2.0 * meanAnomaly) +
                        0.000289 * sinDeg(3.0 * meanAnomaly);
  const double trueLongitude = meanLongitude + centre;
  const double trueAnomaly = meanAnomaly + centre;
  const double node = 125.04 - 1934.136 * t;  // Ω, the Moon's ascending node
  const double apparentLongitude = trueLongitude - 0.00569 - 0.00478 * sinDeg(node);
  const double meanObliquity =
      23.0 + (26.0 + (21.448 - t * (46.8150 + t * (0.00059 - t * 0.001813))) / 60.0) / 60.0;
  const double obliquity = meanObliquity + 0.00256 * cosDeg(node);
  const double rightAscension =
      std::atan2(cosDeg(obliquity) * sinDeg(apparentLongitude), cosDeg(apparentLongitude)) /
      kDegrees;
  const double declination = std::asin(sinDeg(obliquity) * sinDeg(apparentLongitude)) / kDegrees;
  // Meeus ch. 12: mean sidereal time at Greenwich from UT, made apparent by the nutation in
  // longitude (ch. 22, to 0.5″) times cos ε.
  const double daysUt = julianDayUt(unixSeconds) - kJ2000;
  const double tUt = daysUt / 36525.0;
  const double meanSidereal =
      280.46061837 + 360.98564736629 * daysUt + tUt * tUt * (0.000387933 - tUt / 38710000.0);
  const double sunLongitude = 280.4665 + 36000.7698 * t;
  const double moonLongitude = 218.3165 + 481267.8813 * t;
  const double nutationArcsec = -17.20 * sinDeg(node) - 1.32 * sinDeg(2.0 * sunLongitude) -
                                0.23 * sinDeg(2.0 * moonLongitude) + 0.21 * sinDeg(2.0 * node);
  const double apparentSidereal = meanSidereal + nutationArcsec / 3600.0 * cosDeg(obliquity);
  SubsolarPoint point;
  point.latDegrees = declination;
  point.lonDegrees = wrap180(rightAscension - apparentSidereal);
  point.distanceAu = 1.000001018 * (1.0 - eccentricity * eccentricity) /
                     (1.0 + eccentricity * cosDeg(trueAnomaly));
  return point;
}

namespace {

/// Mars24 step B: the mean anomaly M and the equation of centre ν − M at ΔtJ2000 (TT days).
struct MarsOrbit final {
  double meanAnomaly = 0.0;
  double equationOfCentre = 0.0;
  double solarLongitude = 0.0;
};

MarsOrbit marsOrbit(double daysTt) {
  constexpr std::array<double, 7> kAmplitude = {0.0071, 0.0057, 0.0039, 0.0037,
                                                0.0021, 0.0020, 0.0018};
  constexpr std::array<double, 7> kPeriodYears = {2.2353, 2.7543, 1.1177, 15.7866,
                                                  2.1354, 2.4694, 32.8493};
  constexpr std::array<double, 7> kPhase = {49.409, 168.173, 191.837, 21.736,
                                            15.704, 95.528,  49.095};
  MarsOrbit orbit;
  orbit.meanAnomaly = 19.3871 + 0.52402073 * daysTt;
  const double fictitiousMeanSun = 270.3871 + 0.524038496 * daysTt;
  double perturbers = 0.0;
  for (std::size_t i = 0; i < kAmplitude.size(); ++i) {
    perturbers += kAmplitude[i] * cosDeg(0.985626 * daysTt / kPeriodYears[i] + kPhase[i]);
  }
  const double m = orbit.meanAnomaly;
  orbit.equationOfCentre = (10.691 + 3.0e-7 * daysTt) * sinDeg(m) + 0.623 * sinDeg(2.0 * m) +
                           0.050 * sinDeg(3.0 * m) + 0.005 * sinDeg(4.0 * m) +
                           0.0005 * sinDeg(5.0 * m) + perturbers;
  orbit.solarLongitude = wrap360(fictitiousMeanSun + orbit.equationOfCentre);
  return orbit;
}

}  // namespace

MarsSolarTime marsSolarTime(double unixSeconds) noexcept {
  const double jdTt = julianDayTt(unixSeconds);
  const MarsOrbit orbit = marsOrbit(jdTt - kJ2000);
  const double ls = orbit.solarLongitude;
  MarsSolarTime time;
  time.solarLongitudeDegrees = ls;
  time.equationOfTimeDegrees = 2.861 * sinDeg(2.0 * ls) - 0.071 * sinDeg(4.0 * ls) +
                               0.002 * sinDeg(6.0 * ls) - orbit.equationOfCentre;
  const double sols = (jdTt - 2451549.5) / 1.0274912517 + 44796.0 - 0.0009626;
  time.meanSolarTimeHours = 24.0 * (sols - std::floor(sols));
  return time;
}

SubsolarPoint marsSubsolarPoint(double unixSeconds) noexcept {
  const MarsSolarTime time = marsSolarTime(unixSeconds);
  const MarsOrbit orbit = marsOrbit(julianDayTt(unixSeconds) - kJ2000);
  const double ls = time.solarLongitudeDegrees;
  const double westLongitude = time.meanSolarTimeHours * 15.0 + time.equationOfTimeDegrees + 180.0;
  SubsolarPoint point;
  point.latDegrees = std::asin(0.42565 * sinDeg(ls)) / kDegrees + 0.25 * sinDeg(ls);
  point.lonDegrees = wrap180(-westLongitude);
  const double m = orbit.meanAnomaly;
  point.distanceAu = 1.52367934 * (1.00436 - 0.09309 * cosDeg(m) - 0.004336 * cosDeg(2.0 * m) -
                                   0.00031 * cosDeg(3.0 * m) - 0.00003 * cosDeg(4.0 * m));
  return point;
}

SolarBody solarBodyOf(const Planet& planet) noexcept {
  if (planet.name() == "earth") return SolarBody::Earth;
  if (planet.name() == "mars" || planet.name() == "mars-iau2000") return SolarBody::Mars;
  return SolarBody::None;
}

Result<SubsolarPoint> subsolarPoint(const Planet& planet, double unixSeconds) {
  switch (solarBodyOf(planet)) {
    case SolarBody::Earth:
      return earthSubsolarPoint(unixSeconds);
    case SolarBody::Mars:
      return marsSubsolarPoint(unixSeconds);
    case SolarBody::None:
      break;
  }
  return makeError(ErrorCode::InvalidArgument,
                   "no ephemeris for planet '" + planet.name() +
                       "' (Earth and Mars have one): give the sun as an azimuth and elevation");
}

glm::dvec3 sunDirectionEcef(const Planet& planet, const SubsolarPoint& subsolar) noexcept {
  return planet.surfaceNormal(subsolar.latDegrees, subsolar.lonDegrees);
}

glm::dvec3 sunDirectionFromHorizon(const Planet& planet, double latDegrees, double lonDegrees,
                                   double azimuthDegrees, double elevationDegrees) noexcept {
  const EnuFrame frame = planet.enuFrame(latDegrees, lonDegrees, 0.0);
  const glm::dvec3 enu{cosDeg(elevationDegrees) * sinDeg(azimuthDegrees),
                       cosDeg(elevationDegrees) * cosDeg(azimuthDegrees), sinDeg(elevationDegrees)};
  return frame.enuToEcefDirection(enu);
}

double sunAngularRadiusRadians(double distanceAu) noexcept {
  constexpr double kSunRadiusMeters = 695700e3;
  constexpr double kAuMeters = 149597870700.0;
  return std::asin(kSunRadiusMeters / (distanceAu * kAuMeters));
}

}  // namespace pbdam::runtime
