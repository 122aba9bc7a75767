// Planet: reference sphere/ellipsoid through GeographicLib (Geocentric for ECEF, Geodesic or
// GeodesicExact for geodesics), built once per planet and shared by copies (docs/architecture.md
// "Planet models").
#include "pbdam/runtime/Planet.h"

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicExact.hpp>
#include <GeographicLib/Math.hpp>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <exception>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <optional>
#include <system_error>
#include <utility>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

constexpr double kMarsRadiusMeters = 3396190.0;
constexpr double kMarsIauPolarRadiusMeters = 3376200.0;
constexpr double kWgs84EquatorialRadiusMeters = 6378137.0;
constexpr double kWgs84InverseFlattening = 298.257223563;
constexpr double kMoonRadiusMeters = 1737400.0;
// Geodesic's series are accurate to round-off for |f| <= 0.01 and still good to 0.02;
// GeodesicExact (elliptic integrals, slower) covers the rest of [0, 1).
constexpr double kMaxSeriesFlattening = 0.02;

// Shortest decimal that reads back to exactly `value`.
std::string formatExact(double value) {
  std::array<char, 64> buffer{};
  const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  if (ec != std::errc{}) return "?";
  return std::string(buffer.data(), end);
}

std::string formatShort(double value) {
  std::array<char, 64> buffer{};
  const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                       std::chars_format::general, 12);
  if (ec != std::errc{}) return "?";
  return std::string(buffer.data(), end);
}

std::string_view trim(std::string_view text) noexcept {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front())) != 0) {
    text.remove_prefix(1);
  }
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())) != 0) {
    text.remove_suffix(1);
  }
  return text;
}

std::string toLower(std::string_view text) {
  std::string lower(text);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

// Parses a whole token as a double; nullopt if anything is left over or nothing parses.
std::optional<double> parseNumber(std::string_view token) noexcept {
  token = trim(token);
  if (token.empty()) return std::nullopt;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc{} || end != token.data() + token.size()) return std::nullopt;
  return value;
}

// Parses a flattening written as a decimal or as "1/x".
std::optional<double> parseFlattening(std::string_view token) noexcept {
  token = trim(token);
  const auto slash = token.find('/');
  if (slash == std::string_view::npos) return parseNumber(token);
  const auto numerator = parseNumber(token.substr(0, slash));
  const auto denominator = parseNumber(token.substr(slash + 1));
  if (!numerator || !denominator) return std::nullopt;
  return *numerator / *denominator;  // 1/0 gives inf, rejected as non-finite by the caller
}

Error specError(std::string_view spec, const std::string& what) {
  return makeError(ErrorCode::InvalidArgument, "planet spec '" + std::string(spec) + "': " + what);
}

std::optional<std::string> checkRadius(double radiusMeters) {
  if (!std::isfinite(radiusMeters) || radiusMeters <= 0.0) {
    return "radius must be finite and > 0 metres (got " + formatExact(radiusMeters) + ")";
  }
  return std::nullopt;
}

std::optional<std::string> checkFlattening(double flattening) {
  if (!std::isfinite(flattening) || flattening < 0.0 || flattening >= 1.0) {
    return "flattening must be finite and in [0, 1) (got " + formatExact(flattening) + ")";
  }
  return std::nullopt;
}

}  // namespace

struct Planet::Impl final {
  Impl(double a, double f) : geocentric(a, f) {
    if (f <= kMaxSeriesFlattening) {
      geodesic.emplace(a, f);
    } else {
      geodesicExact.emplace(a, f);
    }
  }

  GeographicLib::Geocentric geocentric;
  std::optional<GeographicLib::Geodesic> geodesic;
  std::optional<GeographicLib::GeodesicExact> geodesicExact;
};

Planet::Planet(std::string name, double equatorialRadiusMeters, double flattening)
    : name_(std::move(name)),
      equatorialRadiusMeters_(equatorialRadiusMeters),
      flattening_(flattening),
      polarRadiusMeters_(equatorialRadiusMeters * (1.0 - flattening)),
      impl_(std::make_shared<const Impl>(equatorialRadiusMeters, flattening)) {}

Result<Planet> Planet::sphere(double radiusMeters) {
  if (auto problem = checkRadius(radiusMeters)) {
    return makeError(ErrorCode::InvalidArgument, "sphere: " + *problem);
  }
  try {
    return Planet("sphere:" + formatExact(radiusMeters), radiusMeters, 0.0);
  } catch (const std::exception& e) {
    return makeError(ErrorCode::Internal, std::string("sphere: GeographicLib: ") + e.what());
  }
}

Result<Planet> Planet::ellipsoid(double equatorialRadiusMeters, double flattening) {
  if (auto problem = checkRadius(equatorialRadiusMeters)) {
    return makeError(ErrorCode::InvalidArgument, "ellipsoid: equatorial " + *problem);
  }
  if (auto problem = checkFlattening(flattening)) {
    return makeError(ErrorCode::InvalidArgument, "ellipsoid: " + *problem);
  }
  if (flattening == 0.0) return sphere(equatorialRadiusMeters);
  try {
    return Planet(
        "ellipsoid:" + formatExact(equatorialRadiusMeters) + "," + formatExact(flattening),
        equatorialRadiusMeters, flattening);
  } catch (const std::exception& e) {
    return makeError(ErrorCode::Internal, std::string("ellipsoid: GeographicLib: ") + e.what());
  }
}

Planet Planet::mars() { return Planet("mars", kMarsRadiusMeters, 0.0); }

Planet Planet::marsIau2000() {
  return Planet("mars-iau2000", kMarsRadiusMeters,
                (kMarsRadiusMeters - kMarsIauPolarRadiusMeters) / kMarsRadiusMeters);
}

Planet Planet::earthWgs84() {
  return Planet("earth", kWgs84EquatorialRadiusMeters, 1.0 / kWgs84InverseFlattening);
}

Planet Planet::moon() { return Planet("moon", kMoonRadiusMeters, 0.0); }

Result<Planet> Planet::fromSpec(std::string_view spec) {
  const std::string_view trimmed = trim(spec);
  const std::string lower = toLower(trimmed);
  if (lower == "mars") return mars();
  if (lower == "mars-iau2000") return marsIau2000();
  if (lower == "earth" || lower == "wgs84") return earthWgs84();
  if (lower == "moon") return moon();

  const auto colon = lower.find(':');
  const std::string kind = lower.substr(0, colon);
  const std::string_view args =
      colon == std::string::npos ? std::string_view{} : trimmed.substr(colon + 1);
  if (colon != std::string::npos && kind == "sphere") {
    const auto radius = parseNumber(args);
    if (!radius) return specError(spec, "radius '" + std::string(trim(args)) + "' is not a number");
    if (auto problem = checkRadius(*radius)) return specError(spec, *problem);
    return sphere(*radius);
  }
  if (colon != std::string::npos && kind == "ellipsoid") {
    const auto comma = args.find(',');
    if (comma == std::string_view::npos) {
      return specError(spec, "expected 'ellipsoid:A,F' (equatorial radius, flattening)");
    }
    const auto radius = parseNumber(args.substr(0, comma));
    if (!radius) {
      return specError(spec, "equatorial radius '" + std::string(trim(args.substr(0, comma))) +
                                 "' is not a number");
    }
    const auto flattening = parseFlattening(args.substr(comma + 1));
    if (!flattening) {
      return specError(spec, "flattening '" + std::string(trim(args.substr(comma + 1))) +
                                 "' is not a number or 1/x");
    }
    if (auto problem = checkRadius(*radius)) return specError(spec, "equatorial " + *problem);
    if (auto problem = checkFlattening(*flattening)) return specError(spec, *problem);
    return ellipsoid(*radius, *flattening);
  }
  return specError(spec,
                   "unknown planet; expected mars, mars-iau2000, earth, moon, sphere:R or "
                   "ellipsoid:A,F");
}

std::string Planet::description() const {
  if (name_ == "mars") return "Mars sphere (MOLA reference), R = 3396190 m";
  if (name_ == "mars-iau2000") return "Mars IAU 2000 ellipsoid, a = 3396190 m, b = 3376200 m";
  if (name_ == "earth") return "Earth WGS84 ellipsoid, a = 6378137 m, f = 1/298.257223563";
  if (name_ == "moon") return "Moon sphere, R = 1737400 m";
  if (isSphere()) return "sphere, R = " + formatShort(equatorialRadiusMeters_) + " m";
  return "ellipsoid, a = " + formatShort(equatorialRadiusMeters_) + " m, f = 1/" +
         formatShort(1.0 / flattening_);
}

glm::dvec3 Planet::geodeticToEcef(double latDegrees, double lonDegrees,
                                  double heightMeters) const noexcept {
  glm::dvec3 ecef{0.0};
  impl_->geocentric.Forward(latDegrees, lonDegrees, heightMeters, ecef.x, ecef.y, ecef.z);
  return ecef;
}

glm::dvec3 Planet::geodeticToEcef(const GeodeticPosition& position) const noexcept {
  return geodeticToEcef(position.latDegrees, position.lonDegrees, position.heightMeters);
}

GeodeticPosition Planet::ecefToGeodetic(const glm::dvec3& ecefMeters) const noexcept {
  GeodeticPosition position;
  impl_->geocentric.Reverse(ecefMeters.x, ecefMeters.y, ecefMeters.z, position.latDegrees,
                            position.lonDegrees, position.heightMeters);
  return position;
}

glm::dvec3 Planet::surfaceNormal(double latDegrees, double lonDegrees) const noexcept {
  // The geodetic up direction is the planetocentric direction of the same angles.
  return planetocentricToDirection(latDegrees, lonDegrees);
}

EnuFrame Planet::enuFrame(double latDegrees, double lonDegrees,
                          double heightMeters) const noexcept {
  double sinLat = 0.0;
  double cosLat = 0.0;
  double sinLon = 0.0;
  double cosLon = 0.0;
  GeographicLib::Math::sincosd(latDegrees, sinLat, cosLat);
  GeographicLib::Math::sincosd(lonDegrees, sinLon, cosLon);
  EnuFrame frame;
  frame.originEcef = geodeticToEcef(latDegrees, lonDegrees, heightMeters);
  frame.axes[0] = glm::dvec3(-sinLon, cosLon, 0.0);                        // east
  frame.axes[1] = glm::dvec3(-sinLat * cosLon, -sinLat * sinLon, cosLat);  // north
  frame.axes[2] = glm::dvec3(cosLat * cosLon, cosLat * sinLon, sinLat);    // up
  return frame;
}

glm::dvec3 EnuFrame::enuToEcef(const glm::dvec3& enuMeters) const noexcept {
  return originEcef + axes * enuMeters;
}

glm::dvec3 EnuFrame::ecefToEnu(const glm::dvec3& ecefMeters) const noexcept {
  return glm::transpose(axes) * (ecefMeters - originEcef);
}

glm::dvec3 EnuFrame::enuToEcefDirection(const glm::dvec3& enuDirection) const noexcept {
  return axes * enuDirection;
}

glm::dvec3 EnuFrame::ecefToEnuDirection(const glm::dvec3& ecefDirection) const noexcept {
  return glm::transpose(axes) * ecefDirection;
}

glm::dvec3 Planet::directionToSurfaceEcef(const glm::dvec3& direction) const noexcept {
  // Solve |t d|_ellipsoid = 1: t = 1 / sqrt((dx² + dy²) / a² + dz² / b²).
  const double a = equatorialRadiusMeters_;
  const double b = polarRadiusMeters_;
  const double rhoOverA = std::hypot(direction.x, direction.y) / a;
  const double zOverB = direction.z / b;
  return direction * (1.0 / std::hypot(rhoOverA, zOverB));
}

GeodeticPosition Planet::directionToGeodetic(const glm::dvec3& direction) const noexcept {
  // On the ellipsoid the normal is ∝ (x/a², y/a², z/b²), so tan(geodetic lat) = z a² / (ρ b²)
  // for the surface point, and the surface point is a multiple of the direction.
  const double oneMinusF = 1.0 - flattening_;
  const glm::dvec3 scaled(direction.x * oneMinusF * oneMinusF, direction.y * oneMinusF * oneMinusF,
                          direction.z);
  const LatLonDegrees latLon = directionToPlanetocentric(scaled);
  return GeodeticPosition{latLon.latDegrees, latLon.lonDegrees, 0.0};
}

glm::dvec3 Planet::geodeticToDirection(double latDegrees, double lonDegrees) const noexcept {
  return geodeticToDirection(sinCosDegrees(latDegrees), sinCosDegrees(lonDegrees));
}

glm::dvec3 Planet::geodeticToDirection(const SinCosDegrees& lat,
                                       const SinCosDegrees& lon) const noexcept {
  // Inverse of directionToGeodetic: tan(geocentric lat) = (1 - f)² tan(geodetic lat).
  const double oneMinusF = 1.0 - flattening_;
  const glm::dvec3 normal = planetocentricToDirection(lat, lon);
  const glm::dvec3 scaled(normal.x, normal.y, normal.z * oneMinusF * oneMinusF);
  return scaled / glm::length(scaled);
}

GeodesicInverse Planet::geodesicInverse(double lat1Degrees, double lon1Degrees, double lat2Degrees,
                                        double lon2Degrees) const noexcept {
  GeodesicInverse result;
  if (impl_->geodesic) {
    impl_->geodesic->Inverse(lat1Degrees, lon1Degrees, lat2Degrees, lon2Degrees,
                             result.distanceMeters, result.azimuth1Degrees, result.azimuth2Degrees);
  } else {
    impl_->geodesicExact->Inverse(lat1Degrees, lon1Degrees, lat2Degrees, lon2Degrees,
                                  result.distanceMeters, result.azimuth1Degrees,
                                  result.azimuth2Degrees);
  }
  return result;
}

GeodesicDirect Planet::geodesicDirect(double latDegrees, double lonDegrees, double azimuthDegrees,
                                      double distanceMeters) const noexcept {
  GeodesicDirect result;
  if (impl_->geodesic) {
    impl_->geodesic->Direct(latDegrees, lonDegrees, azimuthDegrees, distanceMeters,
                            result.latDegrees, result.lonDegrees, result.azimuth2Degrees);
  } else {
    impl_->geodesicExact->Direct(latDegrees, lonDegrees, azimuthDegrees, distanceMeters,
                                 result.latDegrees, result.lonDegrees, result.azimuth2Degrees);
  }
  return result;
}

}  // namespace pbdam::runtime
