// Line of sight on the device (gpu/GpuSightline.h), on lavapipe with validation on: a wall
// blocks a segment at the right fraction and nothing else does; on Mars, the answer over the
// rendered terrain agrees with a brute-force ray march over the source DEM; bad points are
// refused naming them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/runtime/SurfaceQuery.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

class GpuSightlineTest : public test::GpuTest {};

TEST_F(GpuSightlineTest, AWallBlocksAtItsFractionAndNothingElseDoes) {
  // A triangle in the plane x = 1000 around the x axis, the observer far from the origin.
  const glm::dvec3 o(3.4e6, 0.0, 0.0);
  const std::vector<glm::dvec3> vertices = {o + glm::dvec3(1000.0, -50.0, -50.0),
                                            o + glm::dvec3(1000.0, 100.0, -50.0),
                                            o + glm::dvec3(1000.0, -50.0, 100.0)};
  const std::vector<std::uint32_t> triangle = {0, 1, 2};
  auto through = testSightline(context(), vertices, triangle, o, o + glm::dvec3(4000.0, 0, 0));
  ASSERT_TRUE(through.ok()) << through.error().message;
  EXPECT_FALSE(through->visible);
  EXPECT_EQ(through->crossings, 1u);
  EXPECT_NEAR(through->nearestFraction, 0.25, 1e-6);
  auto shortOf = testSightline(context(), vertices, triangle, o, o + glm::dvec3(900.0, 0, 0));
  ASSERT_TRUE(shortOf.ok());
  EXPECT_TRUE(shortOf->visible);
  auto beside = testSightline(context(), vertices, triangle, o + glm::dvec3(0, 200.0, 0),
                              o + glm::dvec3(4000.0, 200.0, 0));
  ASSERT_TRUE(beside.ok());
  EXPECT_TRUE(beside->visible);
  // A crossing within a metre of an end does not count (an observer on the ground).
  auto atEnd = testSightline(context(), vertices, triangle, o, o + glm::dvec3(1000.5, 0, 0));
  ASSERT_TRUE(atEnd.ok());
  EXPECT_TRUE(atEnd->visible);
  EXPECT_FALSE(testSightline(context(), vertices, {0, 1, 7}, o, o + glm::dvec3(1, 0, 0)).ok());
  EXPECT_FALSE(testSightline(context(), vertices, triangle, o, o).ok());
}

// Random pairs of points 2 m to 20 km above the terrain, up to ~120 km apart, over the whole of
// Mars: the device's answer on the rendered terrain against a ray march over the MOLA grid
// itself (bilinear heights at 4,000 points of the segment, heights of the chord's points above
// the reference sphere). The rendered terrain is within the leaves' stored error of the grid, so
// the two must agree wherever the line passes the grid's terrain by more than that error; lines
// closer than that (grazing) may go either way and are counted apart.
TEST_F(GpuSightlineTest, MarsAgreesWithARayMarchOverTheDemOutsideTheLeavesError) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, pbdam::test::dataDir() / "mars/megt90n000cb.lbl");
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Planet& planet = view.planet();
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int clear = 0, grazing = 0, blocked = 0, visible = 0, sureBlocked = 0;
  // The march's 499 points along a line fall on a few dozen leaves: each is decoded once.
  SurfaceLeafCache leaves;
  for (int k = 0; k < 100; ++k) {
    const double lat = -60.0 + 120.0 * unit(rng);
    const double lon = 360.0 * unit(rng) - 180.0;
    const GroundPoint from{lat, lon, 2.0 * std::pow(10000.0, unit(rng))};
    const GroundPoint to{lat + 2.0 * unit(rng) - 1.0, lon + 2.0 * unit(rng) - 1.0,
                         2.0 * std::pow(10000.0, unit(rng))};
    auto line = sightlineOverTerrain(context(), view, from, to);
    ASSERT_TRUE(line.ok()) << line.error().message;
    // Sure answers from the grid: the segment clears it everywhere by more than the local leaf's
    // stored error, or passes below it somewhere by more than that; else it grazes. The ends
    // stand on the rendered terrain, not on the grid: the first and last leaf error of the
    // segment's length are skipped.
    bool visibleSure = true, blockedSure = false;
    const double length = glm::length(line->to - line->from);
    for (int s = 1; s < 500; ++s) {
      const double along = s / 500.0;
      const glm::dvec3 p = line->from + along * (line->to - line->from);
      const GeodeticPosition g = planet.ecefToGeodetic(p);
      const auto ground = dem->sampleBilinear(g.latDegrees, g.lonDegrees);
      const auto rendered = surfaceHeightAt(view, g.latDegrees, g.lonDegrees, leaves);
      if (!ground || !rendered) continue;
      const double error = rendered->leafErrorMeters;
      if (std::min(along, 1.0 - along) * length < 2.0 * error) continue;
      const double above = g.heightMeters - *ground;
      visibleSure = visibleSure && above > error;
      blockedSure = blockedSure || above < -error;
    }
    (line->result.visible ? visible : blocked) += 1;
    if (!visibleSure && !blockedSure) {
      ++grazing;
      continue;
    }
    ++clear;
    sureBlocked += static_cast<int>(blockedSure);
    EXPECT_EQ(line->result.visible, visibleSure)
        << "line " << k << ": the grid says " << (visibleSure ? "visible" : "blocked");
  }
  std::printf(
      "%d lines checked against the ray march, %d grazing within the leaves' error; %d visible, "
      "%d blocked\n",
      clear, grazing, visible, blocked);
  EXPECT_GE(clear, 25);
  EXPECT_GT(sureBlocked, 0) << "some checked lines are blocked for sure";
  EXPECT_GT(clear - sureBlocked, 0) << "some checked lines are visible for sure";
  EXPECT_GT(visible, 0);
  EXPECT_GT(blocked, 0);
}

TEST_F(GpuSightlineTest, BadPointsAreRefusedNamingThem) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const auto refused = [&](const GroundPoint& a, const GroundPoint& b, const char* mention) {
    auto r = sightlineOverTerrain(context(), view, a, b);
    ASSERT_FALSE(r.ok()) << mention;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(r.error().message.find(mention), std::string::npos) << r.error().message;
  };
  refused({95.0, 0.0, 10.0}, {0.0, 0.0, 10.0}, "--from: latitude");
  refused({0.0, 0.0, 10.0}, {0.0, 0.0, -1.0}, "--to: the point is underground");
  refused({0.0, 0.0, 10.0}, {0.0, 0.0, 10.0}, "the same point");
}

}  // namespace
}  // namespace pbdam::gpu
