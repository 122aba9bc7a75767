// Planet: the reference surface (sphere or oblate ellipsoid) every position in pbdam is measured
// against — geodetic <-> ECEF, east-north-up frames and geodesics, through GeographicLib
// (docs/architecture.md "Planet models"). Heights are metres above the reference surface (radial on
// a sphere).
#pragma once

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <memory>
#include <string>
#include <string_view>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Direction.h"

namespace pbdam::runtime {

/// A geodetic position: latitude of the surface normal, longitude, height along that normal.
struct GeodeticPosition final {
  double latDegrees = 0.0;    ///< geodetic latitude in [-90, 90]
  double lonDegrees = 0.0;    ///< longitude in [-180, 180]
  double heightMeters = 0.0;  ///< above the reference surface, along the surface normal
};

/// A local east-north-up frame (what GeographicLib::LocalCartesian computes), in ECEF metres.
/// `axes` has the unit vectors east, north, up as its columns 0, 1, 2: ecef = origin + axes * enu.
struct EnuFrame final {
  glm::dvec3 originEcef{0.0};  ///< the frame's origin
  glm::dmat3 axes{1.0};        ///< columns: unit east, north, up

  /// Returns the ECEF position of a point given in this frame's east/north/up metres.
  glm::dvec3 enuToEcef(const glm::dvec3& enuMeters) const noexcept;
  /// Returns the east/north/up metres of an ECEF position relative to this frame.
  glm::dvec3 ecefToEnu(const glm::dvec3& ecefMeters) const noexcept;
  /// Returns an ECEF direction (no translation) for a direction given in east/north/up.
  glm::dvec3 enuToEcefDirection(const glm::dvec3& enuDirection) const noexcept;
  /// Returns the east/north/up components of an ECEF direction (no translation).
  glm::dvec3 ecefToEnuDirection(const glm::dvec3& ecefDirection) const noexcept;
};

/// Result of the inverse geodesic problem: the shortest path between two points.
struct GeodesicInverse final {
  double distanceMeters = 0.0;   ///< length of the geodesic on the reference surface
  double azimuth1Degrees = 0.0;  ///< forward azimuth at point 1, clockwise from north
  double azimuth2Degrees = 0.0;  ///< forward azimuth at point 2 (direction of travel there)
};

/// Result of the direct geodesic problem: where a geodesic of given start, azimuth and length ends.
struct GeodesicDirect final {
  double latDegrees = 0.0;       ///< the end point's latitude
  double lonDegrees = 0.0;       ///< in [-180, 180]
  double azimuth2Degrees = 0.0;  ///< forward azimuth at the end point
};

/// A planet's reference surface: a sphere or an oblate ellipsoid of revolution.
///
/// Frames: ECEF metres with the origin at the planet's centre, +x through lat 0 lon 0, +z through
/// the north pole. Latitudes are geodetic (the angle of the surface normal); on a sphere they equal
/// planetocentric latitudes. The cube map (CubeMap.h) works with geocentric directions; use
/// directionToGeodetic / geodeticToDirection to cross between the two on an ellipsoid.
///
/// Planet is an immutable value: copies share one set of GeographicLib objects (built once in the
/// factory, never per call). All member functions are const and safe to call from any number of
/// threads at once.
class Planet final {
 public:
  /// Parses a planet specification:
  ///  - "mars": sphere of radius 3,396,190 m (the MOLA reference);
  ///  - "mars-iau2000": ellipsoid a = 3,396,190 m, b = 3,376,200 m;
  ///  - "earth" (or "wgs84"): the WGS84 ellipsoid;
  ///  - "moon": sphere of radius 1,737,400 m;
  ///  - "sphere:R": a sphere of radius R metres;
  ///  - "ellipsoid:A,F": equatorial radius A metres and flattening F, written as a decimal or as
  ///    "1/x" (e.g. "ellipsoid:6378137,1/298.257223563").
  /// Names are case-insensitive; surrounding spaces are ignored. Returns InvalidArgument naming the
  /// spec for unknown names, malformed numbers, non-finite or non-positive radii and flattenings
  /// outside [0, 1).
  static formats::Result<Planet> fromSpec(std::string_view spec);

  /// Returns a sphere of `radiusMeters`, which must be finite and > 0 (else InvalidArgument).
  static formats::Result<Planet> sphere(double radiusMeters);
  /// Returns an ellipsoid; `equatorialRadiusMeters` finite > 0, `flattening` finite in [0, 1).
  /// A flattening of 0 gives a sphere.
  static formats::Result<Planet> ellipsoid(double equatorialRadiusMeters, double flattening);

  static Planet mars();         ///< sphere, R = 3,396,190 m
  static Planet marsIau2000();  ///< ellipsoid, a = 3,396,190 m, b = 3,376,200 m
  static Planet earthWgs84();   ///< WGS84: a = 6,378,137 m, f = 1/298.257223563
  static Planet moon();         ///< sphere, R = 1,737,400 m

  /// The canonical spec: "mars", "mars-iau2000", "earth", "moon", "sphere:R" or "ellipsoid:A,F"
  /// with numbers written so that fromSpec(name()) gives back the same planet exactly.
  const std::string& name() const noexcept { return name_; }
  /// A one-line human-readable description, e.g. "Mars sphere, R = 3396190 m".
  std::string description() const;

  /// The reference surface's semi-major axis.
  double equatorialRadiusMeters() const noexcept { return equatorialRadiusMeters_; }
  /// The reference surface's semi-minor axis (the equatorial radius for a sphere).
  double polarRadiusMeters() const noexcept { return polarRadiusMeters_; }
  /// (a − b) / a; 0 for a sphere.
  double flattening() const noexcept { return flattening_; }
  /// Whether the reference surface is a sphere (flattening 0).
  bool isSphere() const noexcept { return flattening_ == 0.0; }

  /// Returns the ECEF position of a geodetic position. Inputs must be finite.
  /// @{
  glm::dvec3 geodeticToEcef(double latDegrees, double lonDegrees,
                            double heightMeters) const noexcept;
  glm::dvec3 geodeticToEcef(const GeodeticPosition& position) const noexcept;
  /// @}
  /// Returns the geodetic position of an ECEF position (exact to round-off at any height).
  GeodeticPosition ecefToGeodetic(const glm::dvec3& ecefMeters) const noexcept;

  /// Returns the unit outward surface normal (geodetic up) at a geodetic latitude/longitude.
  glm::dvec3 surfaceNormal(double latDegrees, double lonDegrees) const noexcept;
  /// Returns the east-north-up frame at a geodetic position (origin at that position). At the
  /// poles, east is taken as the direction of increasing longitude for the given lonDegrees.
  EnuFrame enuFrame(double latDegrees, double lonDegrees, double heightMeters) const noexcept;

  /// Returns the point of the reference surface on the ray from the centre along `direction`
  /// (a geocentric direction, e.g. from the cube map; non-zero, need not be unit length).
  glm::dvec3 directionToSurfaceEcef(const glm::dvec3& direction) const noexcept;
  /// Returns the geodetic latitude/longitude (height 0) of directionToSurfaceEcef(direction). On a
  /// sphere this equals directionToPlanetocentric(direction).
  GeodeticPosition directionToGeodetic(const glm::dvec3& direction) const noexcept;
  /// Returns the unit geocentric direction of the surface point at a geodetic latitude/longitude;
  /// the inverse of directionToGeodetic.
  glm::dvec3 geodeticToDirection(double latDegrees, double lonDegrees) const noexcept;
  /// geodeticToDirection from the angles' sines and cosines (sinCosDegrees), bit for bit.
  glm::dvec3 geodeticToDirection(const SinCosDegrees& lat, const SinCosDegrees& lon) const noexcept;

  /// Solves the inverse geodesic problem on this surface (GeographicLib::Geodesic; accurate to
  /// round-off). Latitudes must be in [-90, 90].
  GeodesicInverse geodesicInverse(double lat1Degrees, double lon1Degrees, double lat2Degrees,
                                  double lon2Degrees) const noexcept;
  /// Solves the direct geodesic problem: start point, initial azimuth (clockwise from north) and
  /// distance along the surface (negative goes backwards).
  GeodesicDirect geodesicDirect(double latDegrees, double lonDegrees, double azimuthDegrees,
                                double distanceMeters) const noexcept;

  /// Two planets are equal when their reference surfaces are (radius and flattening); names
  /// are not compared ("mars" equals "sphere:3396190").
  friend bool operator==(const Planet& a, const Planet& b) noexcept {
    return a.equatorialRadiusMeters_ == b.equatorialRadiusMeters_ && a.flattening_ == b.flattening_;
  }

 private:
  struct Impl;  // GeographicLib objects; defined in Planet.cpp

  Planet(std::string name, double equatorialRadiusMeters, double flattening);

  std::string name_;
  double equatorialRadiusMeters_ = 0.0;
  double flattening_ = 0.0;
  double polarRadiusMeters_ = 0.0;
  std::shared_ptr<const Impl> impl_;
};

}  // namespace pbdam::runtime
