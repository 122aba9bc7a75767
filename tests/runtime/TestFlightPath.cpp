// Waypoint flights: endpoints hit exactly, headings follow the geodesic, altitude eases
// monotonically between waypoints, bad parameters are rejected.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "pbdam/runtime/FlightPath.h"

using namespace pbdam::runtime;

namespace pbdam::runtime {
namespace {

TEST(FlightPath, GreatCircleHitsBothEndsAndFollowsTheGeodesic) {
  const Planet earth = Planet::earthWgs84();
  // Near JFK to near LHR: headings start and end as the geodesic's azimuths.
  const GeodesicInverse geodesic = earth.geodesicInverse(40.6, -73.8, 51.6, -0.5);
  const auto path = waypointFlight(earth, {{40.6, -73.8, 10e3}, {51.6, -0.5, 1e3}},
                                   FlightOptions{10.0, 10.0, std::nullopt});
  ASSERT_TRUE(path.ok()) << path.error().message;
  ASSERT_EQ(path->size(), 101u);
  EXPECT_NEAR(path->front().latDegrees, 40.6, 1e-9);
  EXPECT_NEAR(path->back().lonDegrees, -0.5, 1e-9);
  EXPECT_NEAR(path->back().altitudeMeters, 1e3, 1e-6);
  EXPECT_DOUBLE_EQ(path->back().tSeconds, 10.0);
  EXPECT_NEAR(path->front().headingDegrees, geodesic.azimuth1Degrees, 1e-6);
  EXPECT_NEAR(path->back().headingDegrees, geodesic.azimuth2Degrees, 1e-6);
  for (std::size_t k = 1; k < path->size(); ++k) {
    EXPECT_LE((*path)[k].altitudeMeters, (*path)[k - 1].altitudeMeters + 1e-6);
    EXPECT_GT((*path)[k].tSeconds, (*path)[k - 1].tSeconds);
  }
  // ~5,550 km of geodesic in 10 s.
  EXPECT_NEAR(meanSpeedMetersPerSecond(earth, *path), 555e3, 10e3);
}

TEST(FlightPath, WaypointsAreVisitedAndPitchCanBeFixed) {
  const Planet mars = Planet::mars();
  const auto path = waypointFlight(mars, {{0, 0, 1e6}, {0, 10, 1e4}, {10, 10, 1e4}},
                                   FlightOptions{4.0, 50.0, -30.0});
  ASSERT_TRUE(path.ok());
  double closest = 1e9;  // degrees from the middle waypoint
  for (const auto& p : *path) {
    EXPECT_EQ(p.pitchDegrees, -30.0);
    closest = std::min(closest, std::abs(p.lonDegrees - 10.0) + std::abs(p.latDegrees));
  }
  EXPECT_LT(closest, 0.2);  // one frame's travel: ~1,200 km of legs in 200 frames
  EXPECT_NEAR(path->back().latDegrees, 10.0, 1e-9);
}

TEST(FlightPath, RejectsBadParameters) {
  const Planet mars = Planet::mars();
  const FlightOptions ok{1.0, 10.0, std::nullopt};
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}}, ok).ok());
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}, {95, 0, 1e3}}, ok).ok());
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}, {0, 0, 0.0}}, ok).ok());
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}, {1, 0, 1e3}}, {0.0, 10.0, std::nullopt}).ok());
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}, {1, 0, 1e3}}, {1e6, 30.0, std::nullopt}).ok());
  EXPECT_FALSE(waypointFlight(mars, {{0, 0, 1e3}, {1, 0, 1e3}}, {1.0, 10.0, -91.0}).ok());
}

}  // namespace
}  // namespace pbdam::runtime
