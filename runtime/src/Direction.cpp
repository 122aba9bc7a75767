// Planetocentric latitude/longitude <-> unit direction. Degrees are reduced exactly before the
// trigonometry (GeographicLib::Math::sincosd), so multiples of 90° give exact axes.
#include "pbdam/runtime/Direction.h"

#include <GeographicLib/Math.hpp>
#include <cmath>

namespace pbdam::runtime {

SinCosDegrees sinCosDegrees(double degrees) noexcept {
  SinCosDegrees result;
  GeographicLib::Math::sincosd(degrees, result.sin, result.cos);
  return result;
}

glm::dvec3 planetocentricToDirection(double latDegrees, double lonDegrees) noexcept {
  return planetocentricToDirection(sinCosDegrees(latDegrees), sinCosDegrees(lonDegrees));
}

glm::dvec3 planetocentricToDirection(const SinCosDegrees& lat, const SinCosDegrees& lon) noexcept {
  return {lat.cos * lon.cos, lat.cos * lon.sin, lat.sin};
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
