// The viewshed on the device (gpu/GpuViewshed.h), on lavapipe with validation on: on a bare
// sphere the visible disc ends at the geometric horizon; a ridge hides the wedge behind it and
// nothing else; the same request gives the same mask; on the DEM's own surface (MOLA, ETOPO5) the
// passes agree with a brute-force ray march over the DEM on at least 99% of the cells, and so do
// they over the MOLA test dataset's rendered leaves.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/gpu/GpuViewshed.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

class GpuViewshedTest : public test::GpuTest {};

constexpr double kDegrees = 180.0 / std::numbers::pi;

/// A grid around (lat, lon), the eye `eye` metres above the reference surface.
ViewshedGrid gridAt(double lat, double lon, double eye, double radius, double cell,
                    const Planet& planet = Planet::mars()) {
  ViewshedGrid grid;
  grid.planet = planet;
  grid.latDegrees = lat;
  grid.lonDegrees = lon;
  grid.eyeHeightMeters = eye;
  grid.eyeEcef = grid.planet.geodeticToEcef(lat, lon, eye);
  grid.radiusMeters = radius;
  grid.cellMeters = cell;
  grid.cells = 2 * static_cast<int>(std::ceil(radius / cell)) + 1;
  return grid;
}

/// A regular mesh of the projection's square ±`extent` metres at `spacing`, heights from
/// `height(east, north)`, two triangles a square.
template <typename Height>
CutMesh squareMesh(const ViewshedGrid& grid, double extent, double spacing, Height height) {
  CutMesh mesh;
  const int n = static_cast<int>(std::lround(2.0 * extent / spacing)) + 1;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const glm::dvec2 en(-extent + i * spacing, extent - j * spacing);
      const GeodeticPosition g = grid.unproject(en);
      mesh.vertices.push_back(
          grid.planet.geodeticToEcef(g.latDegrees, g.lonDegrees, height(en.x, en.y)));
    }
  }
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const auto v = [&](int di, int dj) {
        return static_cast<std::uint32_t>((j + dj) * n + i + di);
      };
      mesh.indices.insert(mesh.indices.end(),
                          {v(0, 0), v(0, 1), v(1, 0), v(1, 0), v(0, 1), v(1, 1)});
    }
  }
  return mesh;
}

// On Mars' sphere and on the WGS84 ellipsoid: the horizon in each direction is where the sight
// line grazes the normal section of that azimuth (its radius of curvature R: arc R·acos(R/(R+h))).
TEST_F(GpuViewshedTest, OnABareSurfaceTheVisibleDiscEndsAtTheHorizon) {
  for (const Planet& planet : {Planet::mars(), Planet::earthWgs84()}) {
    const ViewshedGrid grid = gridAt(40.0, 20.0, 200.0, 62000.0, 500.0, planet);
    const CutMesh mesh = squareMesh(grid, 64000.0, 250.0, [](double, double) { return 0.0; });
    ViewshedPassStats stats;
    auto mask = computeViewshed(context(), grid, mesh, &stats);
    ASSERT_TRUE(mask.ok()) << mask.error().message;
    // Meridian and prime-vertical radii of curvature at the latitude.
    const double a = planet.equatorialRadiusMeters();
    const double e2 = planet.flattening() * (2.0 - planet.flattening());
    const double sinLat = std::sin(grid.latDegrees / kDegrees);
    const double w = std::sqrt(1.0 - e2 * sinLat * sinLat);
    const double meridian = a * (1.0 - e2) / (w * w * w);
    const double primeVertical = a / w;
    int visible = 0, hidden = 0, outside = 0;
    for (int row = 0; row < grid.cells; ++row) {
      for (int col = 0; col < grid.cells; ++col) {
        const std::uint8_t m =
            (*mask)[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.cells) +
                    static_cast<std::size_t>(col)];
        const glm::dvec2 en = grid.cellCentreMeters(col, row);
        const double d = glm::length(en);
        const double azimuth = std::atan2(en.x, en.y);
        const double r = 1.0 / (std::cos(azimuth) * std::cos(azimuth) / meridian +
                                std::sin(azimuth) * std::sin(azimuth) / primeVertical);
        const double horizon = r * std::acos(r / (r + grid.eyeHeightMeters));
        if (d > grid.radiusMeters) {
          EXPECT_EQ(m, kViewshedOutside);
          ++outside;
        } else if (d < horizon - 1.5 * grid.cellMeters) {
          EXPECT_EQ(m, kViewshedVisible) << planet.name() << ": " << en.x << ", " << en.y;
          ++visible;
        } else if (d > horizon + 1.5 * grid.cellMeters) {
          EXPECT_EQ(m, kViewshedHidden) << planet.name() << ": " << en.x << ", " << en.y;
          ++hidden;
        }
      }
    }
    EXPECT_GT(visible, 10000) << planet.name();
    EXPECT_GT(hidden, 1000) << planet.name();
    EXPECT_GT(outside, 0);
    EXPECT_GT(stats.triangles, 0u);
    EXPECT_GE(stats.rays, static_cast<std::uint32_t>(2.0 * std::numbers::pi * 124.0));
  }
}

TEST_F(GpuViewshedTest, ARidgeHidesTheWedgeBehindItAndTheMaskIsDeterministic) {
  // A ridge 400 m high, 10 km east of an eye 200 m up, 10 km long north-south.
  const ViewshedGrid grid = gridAt(-30.0, 100.0, 200.0, 30000.0, 500.0);
  const CutMesh mesh = squareMesh(grid, 32000.0, 250.0, [](double east, double north) {
    return std::fabs(east - 10000.0) <= 250.0 && std::fabs(north) <= 5000.0 ? 400.0 : 0.0;
  });
  auto mask = computeViewshed(context(), grid, mesh);
  ASSERT_TRUE(mask.ok()) << mask.error().message;
  int behind = 0, west = 0;
  for (int row = 0; row < grid.cells; ++row) {
    for (int col = 0; col < grid.cells; ++col) {
      const glm::dvec2 en = grid.cellCentreMeters(col, row);
      const double d = glm::length(en);
      const double azimuth = std::atan2(en.x, en.y) * kDegrees;  // clockwise from north
      const std::uint8_t m =
          (*mask)[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.cells) +
                  static_cast<std::size_t>(col)];
      if (d > 11500.0 && d < grid.radiusMeters && std::fabs(azimuth - 90.0) < 20.0) {
        EXPECT_EQ(m, kViewshedHidden) << "behind the ridge: " << en.x << ", " << en.y;
        ++behind;
      }
      if (d < 25000.0 && std::fabs(azimuth + 90.0) < 60.0) {
        EXPECT_EQ(m, kViewshedVisible) << "west: " << en.x << ", " << en.y;
        ++west;
      }
    }
  }
  EXPECT_GT(behind, 300);
  EXPECT_GT(west, 2000);
  auto again = computeViewshed(context(), grid, mesh);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *mask);
}

// The passes against the ray march on one terrain: the device gets a mesh of the DEM's own
// heights (a regular mesh of half the cell's spacing), the ray march the DEM; the same eye.
// What differs is the method alone: the rasterised cells, the rays' spacing and the horizon's
// interpolation.
// MOLA on Mars' sphere, ETOPO5 on WGS84 (the Alps).
TEST_F(GpuViewshedTest, OnTheDemsOwnSurfaceThePassesAgreeWithTheRayMarch) {
  PBDAM_REQUIRE_DATA(molaPath, pbdam::test::dataDir() / "mars/megt90n000cb.lbl");
  auto mola = readDem(molaPath);
  ASSERT_TRUE(mola.ok()) << mola.error().message;
  const std::filesystem::path etopoPath = "/usr/share/ferret-vis/data/etopo5.cdf";
  if (!std::filesystem::exists(etopoPath)) GTEST_SKIP() << etopoPath << " is not installed";
  auto etopo = readDem(etopoPath);
  ASSERT_TRUE(etopo.ok()) << etopo.error().message;
  struct Case {
    const HeightGrid* dem;
    Planet planet;
    double lat, lon, aboveGround, radius, cell;
  };
  for (const Case& c : {Case{&*mola, Planet::mars(), 18.65, 226.2, 10.0, 150000.0, 1000.0},
                        Case{&*mola, Planet::mars(), 10.0, 200.0, 8000.0, 300000.0, 2000.0},
                        Case{&*mola, Planet::mars(), -8.0, -75.0, 100.0, 150000.0, 1000.0},
                        Case{&*mola, Planet::mars(), -8.0, -75.0, 2000.0, 200000.0, 1000.0},
                        Case{&*etopo, Planet::earthWgs84(), 45.83, 6.86, 10.0, 150000.0, 1000.0},
                        Case{&*etopo, Planet::earthWgs84(), 46.5, 8.0, 2000.0, 200000.0, 1000.0}}) {
    const HeightGrid* dem = c.dem;
    const double ground = demHeight(*dem, c.lat, c.lon).value_or(0.0);
    const ViewshedGrid grid =
        gridAt(c.lat, c.lon, ground + c.aboveGround, c.radius, c.cell, c.planet);
    const CutMesh mesh =
        squareMesh(grid, c.radius + 2.0 * c.cell, c.cell / 2.0, [&](double east, double north) {
          const GeodeticPosition g = grid.unproject({east, north});
          return demHeight(*dem, g.latDegrees, g.lonDegrees).value_or(0.0);
        });
    auto mask = computeViewshed(context(), grid, mesh);
    ASSERT_TRUE(mask.ok()) << mask.error().message;
    const auto reference = viewshedByRayMarch(grid, *dem, grid.eyeEcef);
    const ViewshedAgreement a = compareViewsheds(*mask, reference);
    std::printf(
        "%.2f, %.2f, %.0f m up: %llu compared, %.3f%% agree, %.2f%% of the cells either "
        "sees (%llu, %llu)\n",
        c.lat, c.lon, c.aboveGround, static_cast<unsigned long long>(a.compared),
        100.0 * a.fraction(), 100.0 * a.visibleFraction(),
        static_cast<unsigned long long>(a.visibleOnlyInFirst),
        static_cast<unsigned long long>(a.visibleOnlyInSecond));
    EXPECT_GE(a.fraction(), 0.99);
    EXPECT_GE(a.visibleFraction(), 0.95);
  }
}

/// The device's viewshed over a test dataset against the ray march over its source DEM, the eye
/// the same height above each one's ground. They see different terrain: the leaves are simplified
// TINs within their stored error of the DEM, on a lattice of its own spacing.
void expectAgreement(VulkanContext& context, const DatasetView& view, const HeightGrid& dem,
                     const ViewshedRequest& request, double atLeast) {
  auto viewshed = viewshedOverTerrain(context, view, request);
  ASSERT_TRUE(viewshed.ok()) << viewshed.error().message;
  const ViewshedGrid& grid = viewshed->grid;
  const auto ground = demHeight(dem, grid.latDegrees, grid.lonDegrees);
  ASSERT_TRUE(ground.has_value());
  const glm::dvec3 eye = grid.planet.geodeticToEcef(grid.latDegrees, grid.lonDegrees,
                                                    *ground + request.heightAboveGroundMeters);
  const auto reference = viewshedByRayMarch(grid, dem, eye);
  const ViewshedAgreement a = compareViewsheds(viewshed->mask, reference);
  std::printf(
      "%.3f, %.3f, %.0f m up, radius %.0f m, %d² cells: %llu compared, %.2f%% agree "
      "(%.1f%% of the cells either sees), %llu visible only on the leaves, %llu only on "
      "the DEM; %.0f ms\n",
      request.latDegrees, request.lonDegrees, request.heightAboveGroundMeters, grid.radiusMeters,
      grid.cells, static_cast<unsigned long long>(a.compared), 100.0 * a.fraction(),
      100.0 * a.visibleFraction(), static_cast<unsigned long long>(a.visibleOnlyInFirst),
      static_cast<unsigned long long>(a.visibleOnlyInSecond), viewshed->totalMilliseconds);
  EXPECT_GT(a.compared, 1000u);
  EXPECT_GE(a.fraction(), atLeast);
  EXPECT_GT(viewshed->stats.visibleCells, 0u);
  EXPECT_LT(viewshed->stats.visibleCells, viewshed->stats.cellsInRadius);
}

// The small test dataset (10.4 km lattice, leaves within tens to hundreds of metres of MOLA) at
// its default cell; the large-data dataset is measured in docs/performance.md "Focus cuts and
// viewsheds on the large-data dataset and ETOPO5".
TEST_F(GpuViewshedTest, MarsAgreesWithARayMarchOverMola) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, pbdam::test::dataDir() / "mars/megt90n000cb.lbl");
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  // Olympus Mons' summit caldera, its flank from 8 km up, Valles Marineris' rim.
  for (const ViewshedRequest& at : {ViewshedRequest{18.65, 226.2, 10.0, 500000.0, {}},
                                    ViewshedRequest{10.0, 200.0, 8000.0, 500000.0, {}},
                                    ViewshedRequest{-8.0, -75.0, 2000.0, 500000.0, {}},
                                    ViewshedRequest{40.0, 20.0, 500.0, 500000.0, {}}}) {
    expectAgreement(context(), dataset->view(), *dem, at, 0.99);
  }
}

TEST_F(GpuViewshedTest, BadRequestsAreRefusedNamingWhatIsWrong) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const auto refused = [&](const ViewshedRequest& request, const char* mention) {
    auto r = viewshedOverTerrain(context(), dataset->view(), request);
    ASSERT_FALSE(r.ok()) << mention;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(r.error().message.find(mention), std::string::npos) << r.error().message;
  };
  refused({95.0, 0.0, 10.0, {}, {}}, "--at: latitude");
  refused({0.0, 0.0, -1.0, {}, {}}, "underground");
  refused({0.0, 0.0, 10.0, 0.0, {}}, "--radius-m must be a positive");
  refused({0.0, 0.0, 10.0, -5.0, {}}, "--radius-m must be a positive");
  refused({0.0, 0.0, 10.0, 1000.0, 0.0}, "--cell-m must be a positive");
  refused({0.0, 0.0, 10.0, 3.0e6, {}}, "beyond the horizon of the whole planet");
  refused({0.0, 0.0, 10.0, 500000.0, 100.0}, "cells a side");
}

}  // namespace
}  // namespace pbdam::gpu
