// Planetocentric latitude/longitude <-> unit direction from the planet's centre. The cube map
// (CubeMap.h) and Planet (Planet.h) meet here: cube-map directions are geocentric directions.
#pragma once

#include <glm/vec3.hpp>

namespace pbdam::runtime {

/// A planetocentric (geocentric) latitude and a longitude, in degrees. Latitude is the angle
/// between the equatorial plane and the direction from the planet's centre; on a sphere it equals
/// the geodetic latitude, on an ellipsoid it does not (see Planet::directionToGeodetic).
struct LatLonDegrees final {
  double latDegrees = 0.0;  ///< in [-90, 90]
  double lonDegrees = 0.0;  ///< in (-180, 180] for results; any finite value as input
};

/// Returns the unit direction (x towards lat 0 lon 0, y towards lat 0 lon 90°E, z towards the
/// north pole) for a planetocentric latitude and longitude in degrees. Inputs must be finite.
glm::dvec3 planetocentricToDirection(double latDegrees, double lonDegrees) noexcept;

/// Returns the planetocentric latitude/longitude of `direction`, which must be non-zero (it need
/// not be unit length). Longitude is in (-180, 180]; at the exact poles (x = y = 0) it is 0.
LatLonDegrees directionToPlanetocentric(const glm::dvec3& direction) noexcept;

}  // namespace pbdam::runtime
