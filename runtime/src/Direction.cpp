// Planetocentric latitude/longitude <-> unit direction. Degrees are reduced exactly before the
// trigonometry (GeographicLib::Math::sincosd), so multiples of 90° give exact axes.
#include "pbdam/runtime/Direction.h"

#include <GeographicLib/Math.hpp>
#include <cmath>

namespace pbdam::runtime {

glm::dvec3 planetocentricToDirection(double latDegrees, double lonDegrees) noexcept {
  double sinLat = 0.0;
  double cosLat = 0.0;
  double sinLon = 0.0;
  double cosLon = 0.0;
  GeographicLib::Math::sincosd(latDegrees, sinLat, cosLat);
  GeographicLib::Math::sincosd(lonDegrees, sinLon, cosLon);
  return {cosLat * cosLon, cosLat * sinLon, sinLat};
}

LatLonDegrees directionToPlanetocentric(const glm::dvec3& direction) noexcept {
  const double rho = std::hypot(direction.x, direction.y);
  LatLonDegrees result;
  result.latDegrees = GeographicLib::Math::atan2d(direction.z, rho);
  if (rho == 0.0) {
    result.lonDegrees = 0.0;  // the poles: longitude is undefined, report 0
  } else {
    result.lonDegrees = GeographicLib::Math::atan2d(direction.y, direction.x);
    if (result.lonDegrees == -180.0) result.lonDegrees = 180.0;  // (-180, 180]
  }
  return result;
}

}  // namespace pbdam::runtime
