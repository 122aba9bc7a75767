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

/// The sine and cosine of an angle in degrees, the angle reduced exactly first (multiples of 90°
/// give exact values): what planetocentricToDirection takes of each angle.
struct SinCosDegrees final {
  double sin = 0.0;  ///< the angle's sine
  double cos = 1.0;  ///< the angle's cosine
};

/// Returns the sine and cosine of `degrees` (finite) as planetocentricToDirection computes them.
SinCosDegrees sinCosDegrees(double degrees) noexcept;

/// Returns the unit direction (x towards lat 0 lon 0, y towards lat 0 lon 90°E, z towards the
/// north pole) for a planetocentric latitude and longitude in degrees. Inputs must be finite.
glm::dvec3 planetocentricToDirection(double latDegrees, double lonDegrees) noexcept;

/// planetocentricToDirection from the angles' sines and cosines (sinCosDegrees), bit for bit:
/// for a grid of latitudes and longitudes, whose angles repeat along its rows and columns.
glm::dvec3 planetocentricToDirection(const SinCosDegrees& lat, const SinCosDegrees& lon) noexcept;

/// Returns the planetocentric latitude/longitude of `direction`, which must be non-zero (it need
/// not be unit length). Longitude is in (-180, 180]; at the exact poles (x = y = 0) it is 0.
LatLonDegrees directionToPlanetocentric(const glm::dvec3& direction) noexcept;

}  // namespace pbdam::runtime
