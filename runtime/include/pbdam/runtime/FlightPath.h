// Camera paths for flythroughs and benchmarks (docs/architecture.md "Formats"): flights along
// geodesics (GeographicLib) through waypoints, with a smooth altitude profile (log-altitude eased
// between waypoints, so an approach from orbit slows down as it nears the ground), heading along
// the track and a pitch that looks down from orbit and ahead near the ground. Thread-safety: pure.
#pragma once

#include <optional>
#include <vector>

#include "pbdam/formats/CameraPath.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// A waypoint: degrees and metres above the reference surface.
struct Waypoint final {
  double latDegrees = 0.0;      ///< latitude
  double lonDegrees = 0.0;      ///< longitude
  double altitudeMeters = 0.0;  ///< above the reference surface
};

/// How long a flight takes, how densely it is sampled, and its pitch.
struct FlightOptions final {
  double durationSeconds = 10.0;  ///< from the first waypoint to the last
  double framesPerSecond = 30.0;  ///< poses per second of flight
  /// Fixed pitch in degrees; unset: −15° at 1 km altitude easing to −90° at one planet radius.
  std::optional<double> pitchDegrees;
};

/// A flight through `waypoints` (≥ 2) along geodesics, the time of each leg proportional to its
/// length (3D chord between waypoints, so climbs and dives count), sampled at the frame rate
/// from t = 0 to the duration inclusive. Turns at waypoints are abrupt (the paper's flight has
/// abrupt turns). InvalidArgument for fewer than two waypoints, out-of-range values, or more
/// than 1,000,000 frames.
formats::Result<std::vector<formats::CameraPathPoint>> waypointFlight(
    const Planet& planet, const std::vector<Waypoint>& waypoints, const FlightOptions& options);

/// Mean speed of a path in m/s (3D distance between consecutive camera positions over time).
double meanSpeedMetersPerSecond(const Planet& planet,
                                const std::vector<formats::CameraPathPoint>& path);

}  // namespace pbdam::runtime
