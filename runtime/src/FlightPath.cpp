// Waypoint flights along geodesics (FlightPath.h).
#include "pbdam/runtime/FlightPath.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <string>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

double smoothstep(double s) { return s * s * (3.0 - 2.0 * s); }

double defaultPitch(double altitude, double radius) {
  const double s =
      std::clamp(std::log10(std::max(altitude, 1.0) / 1e3) / std::log10(radius / 1e3), 0.0, 1.0);
  return -(15.0 + 75.0 * s);
}

}  // namespace

Result<std::vector<CameraPathPoint>> waypointFlight(const Planet& planet,
                                                    const std::vector<Waypoint>& waypoints,
                                                    const FlightOptions& o) {
  const auto bad = [](const std::string& what) {
    return makeError(ErrorCode::InvalidArgument, what);
  };
  if (waypoints.size() < 2) return bad("a flight needs at least two waypoints");
  for (const Waypoint& w : waypoints) {
    if (!std::isfinite(w.latDegrees) || std::abs(w.latDegrees) > 90.0 ||
        !std::isfinite(w.lonDegrees) || std::abs(w.lonDegrees) > 360.0 ||
        !std::isfinite(w.altitudeMeters) || w.altitudeMeters < 1.0 ||
        w.altitudeMeters > 100.0 * planet.equatorialRadiusMeters()) {
      return bad("waypoint " + std::to_string(w.latDegrees) + "," + std::to_string(w.lonDegrees) +
                 "," + std::to_string(w.altitudeMeters) +
                 ": latitude/longitude out of range or altitude not in [1 m, 100 R]");
    }
  }
  if (!std::isfinite(o.durationSeconds) || o.durationSeconds <= 0.0 ||
      !std::isfinite(o.framesPerSecond) || o.framesPerSecond <= 0.0 ||
      o.durationSeconds * o.framesPerSecond > 1e6) {
    return bad("duration and fps must be positive, with at most 1,000,000 frames");
  }
  if (o.pitchDegrees && (!std::isfinite(*o.pitchDegrees) || std::abs(*o.pitchDegrees) > 90.0)) {
    return bad("pitch must be in [-90, 90] degrees");
  }
  // Leg lengths: 3D distance between the waypoints' positions.
  std::vector<double> legEnd;  // cumulative
  double total = 0.0;
  for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
    const Waypoint& a = waypoints[k];
    const Waypoint& b = waypoints[k + 1];
    const glm::dvec3 pa = planet.geodeticToEcef({a.latDegrees, a.lonDegrees, a.altitudeMeters});
    const glm::dvec3 pb = planet.geodeticToEcef({b.latDegrees, b.lonDegrees, b.altitudeMeters});
    total += std::max(glm::length(pb - pa), 1e-3);
    legEnd.push_back(total);
  }
  const auto frames = static_cast<std::size_t>(std::floor(o.durationSeconds * o.framesPerSecond));
  std::vector<CameraPathPoint> path;
  path.reserve(frames + 1);
  for (std::size_t f = 0; f <= frames; ++f) {
    const double t = std::min(static_cast<double>(f) / o.framesPerSecond, o.durationSeconds);
    const double along = total * t / o.durationSeconds;
    const std::size_t leg = static_cast<std::size_t>(
        std::lower_bound(legEnd.begin(), legEnd.end() - 1, along) - legEnd.begin());
    const double start = leg == 0 ? 0.0 : legEnd[leg - 1];
    const double s = std::clamp((along - start) / (legEnd[leg] - start), 0.0, 1.0);
    const Waypoint& a = waypoints[leg];
    const Waypoint& b = waypoints[leg + 1];
    const GeodesicInverse inv =
        planet.geodesicInverse(a.latDegrees, a.lonDegrees, b.latDegrees, b.lonDegrees);
    CameraPathPoint p;
    p.tSeconds = t;
    double heading = inv.azimuth1Degrees;
    if (inv.distanceMeters > 0.0) {
      const GeodesicDirect d = planet.geodesicDirect(a.latDegrees, a.lonDegrees,
                                                     inv.azimuth1Degrees, s * inv.distanceMeters);
      p.latDegrees = d.latDegrees;
      p.lonDegrees = d.lonDegrees;
      heading = d.azimuth2Degrees;
    } else {
      p.latDegrees = a.latDegrees;
      p.lonDegrees = a.lonDegrees;
    }
    p.altitudeMeters =
        std::exp(std::log(a.altitudeMeters) +
                 smoothstep(s) * (std::log(b.altitudeMeters) - std::log(a.altitudeMeters)));
    p.headingDegrees = std::fmod(heading + 360.0, 360.0);
    p.pitchDegrees =
        o.pitchDegrees.value_or(defaultPitch(p.altitudeMeters, planet.equatorialRadiusMeters()));
    p.rollDegrees = 0.0;
    path.push_back(p);
  }
  return path;
}

double meanSpeedMetersPerSecond(const Planet& planet, const std::vector<CameraPathPoint>& path) {
  if (path.size() < 2) return 0.0;
  double distance = 0.0;
  for (std::size_t k = 1; k < path.size(); ++k) {
    const auto& a = path[k - 1];
    const auto& b = path[k];
    distance += glm::length(planet.geodeticToEcef({b.latDegrees, b.lonDegrees, b.altitudeMeters}) -
                            planet.geodeticToEcef({a.latDegrees, a.lonDegrees, a.altitudeMeters}));
  }
  return distance / (path.back().tSeconds - path.front().tSeconds);
}

}  // namespace pbdam::runtime
