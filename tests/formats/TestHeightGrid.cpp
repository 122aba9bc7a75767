// HeightGrid sampling on synthetic grids: exact at samples, seam and pole continuity, nodata.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "pbdam/formats/HeightGrid.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

/// A global pixel-is-area grid of w×h cells whose values are f(row, col).
template <typename F>
HeightGrid globalGrid(std::int64_t w, std::int64_t h, F f) {
  GridGeometry g;
  g.width = w;
  g.height = h;
  g.lonSpacingDegrees = 360.0 / static_cast<double>(w);
  g.latSpacingDegrees = 180.0 / static_cast<double>(h);
  g.firstLonDegrees = 0.5 * g.lonSpacingDegrees;
  g.firstLatDegrees = 90.0 - 0.5 * g.latSpacingDegrees;
  std::vector<float> v(static_cast<std::size_t>(w * h));
  for (std::int64_t r = 0; r < h; ++r) {
    for (std::int64_t c = 0; c < w; ++c) v[static_cast<std::size_t>(r * w + c)] = f(r, c);
  }
  return HeightGrid(g, std::move(v), GridSource{});
}

TEST(HeightGrid, BilinearIsExactAtSampleCentres) {
  const auto grid =
      globalGrid(16, 8, [](auto r, auto c) { return static_cast<float>(r * 100 + c); });
  for (std::int64_t r = 0; r < 8; ++r) {
    for (std::int64_t c = 0; c < 16; ++c) {
      const auto v = grid.sampleBilinear(grid.latOfRowDegrees(r), grid.lonOfColumnDegrees(c));
      ASSERT_TRUE(v);
      EXPECT_DOUBLE_EQ(*v, static_cast<double>(r * 100 + c));
      const auto b = grid.sampleBicubic(grid.latOfRowDegrees(r), grid.lonOfColumnDegrees(c));
      ASSERT_TRUE(b);
      EXPECT_NEAR(*b, static_cast<double>(r * 100 + c), 1e-9);
    }
  }
}

TEST(HeightGrid, BilinearWrapsTheLongitudeSeam) {
  const auto grid =
      globalGrid(8, 4, [](auto r, auto c) { return static_cast<float>(10 * r + c * c); });
  // Column 7 is centred at 337.5°, column 0 at 22.5° (= 382.5°); 0° lies halfway between.
  const double lat = grid.latOfRowDegrees(1);
  const double expected =
      0.5 * (static_cast<double>(grid.at(1, 7)) + static_cast<double>(grid.at(1, 0)));
  EXPECT_DOUBLE_EQ(*grid.sampleBilinear(lat, 0.0), expected);
  EXPECT_DOUBLE_EQ(*grid.sampleBilinear(lat, 360.0), expected);
  EXPECT_DOUBLE_EQ(*grid.sampleBilinear(lat, -360.0), expected);
  EXPECT_NEAR(*grid.sampleBilinear(lat, -10.0), *grid.sampleBilinear(lat, 350.0), 1e-9);
  EXPECT_NEAR(*grid.sampleBicubic(lat, -10.0), *grid.sampleBicubic(lat, 350.0), 1e-9);
}

TEST(HeightGrid, PoleIsOnePointFromEveryLongitude) {
  const auto grid =
      globalGrid(12, 6, [](auto r, auto c) { return static_cast<float>(r * 7 + c * 3); });
  ASSERT_TRUE(grid.coversPoles());
  const double north = *grid.sampleBilinear(90.0, 0.0);
  const double south = *grid.sampleBilinear(-90.0, 0.0);
  for (double lon = 0.0; lon < 360.0; lon += 7.5) {
    EXPECT_NEAR(*grid.sampleBilinear(90.0, lon), north, 1e-6) << lon;
    EXPECT_NEAR(*grid.sampleBilinear(-90.0, lon), south, 1e-6) << lon;
    EXPECT_NEAR(*grid.sampleBicubic(90.0, lon), *grid.sampleBicubic(90.0, lon + 180.0), 1e-6);
  }
  // The pole's height is the mean of the outermost row; samples approach it continuously.
  double rowSum = 0.0;
  for (std::int64_t c = 0; c < 12; ++c) rowSum += static_cast<double>(grid.at(0, c));
  EXPECT_NEAR(north, rowSum / 12.0, 1e-4);
  EXPECT_NEAR(*grid.sampleBilinear(89.999, 123.0), north, 0.01);
  // Half a cell below the pole, samples are the outermost row itself.
  EXPECT_NEAR(*grid.sampleBilinear(grid.latOfRowDegrees(0), grid.lonOfColumnDegrees(3)),
              static_cast<double>(grid.at(0, 3)), 1e-9);
}

TEST(HeightGrid, BicubicReproducesLinearFunctions) {
  const auto grid =
      globalGrid(36, 18, [](auto r, auto c) { return static_cast<float>(2 * r + 3 * c); });
  for (double lat = -60.0; lat <= 60.0; lat += 7.3) {
    for (double lon = 30.0; lon <= 300.0; lon += 11.1) {
      EXPECT_NEAR(*grid.sampleBicubic(lat, lon), *grid.sampleBilinear(lat, lon), 1e-4);
    }
  }
}

TEST(HeightGrid, NoDataIsLeftOutAndReportedWhenAlone) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto grid = globalGrid(8, 4, [&](auto r, auto c) {
    if (r == 1 && c == 1) return nan;
    if (r >= 2 && c >= 4) return nan;
    return 5.0f;
  });
  EXPECT_DOUBLE_EQ(
      *grid.sampleBilinear(grid.latOfRowDegrees(1) - 11.25, grid.lonOfColumnDegrees(1) + 11.25),
      5.0);
  EXPECT_DOUBLE_EQ(*grid.sampleBicubic(grid.latOfRowDegrees(1), grid.lonOfColumnDegrees(2)), 5.0);
  EXPECT_FALSE(grid.sampleBilinear(grid.latOfRowDegrees(3), grid.lonOfColumnDegrees(5) + 10.0));
  const GridStats stats = grid.computeStats();
  EXPECT_EQ(stats.noDataCount, 1 + 2 * 4);
  EXPECT_EQ(stats.validCount, 32 - 9);
}

TEST(HeightGrid, RegionalGridRejectsPointsOutside) {
  GridGeometry g;
  g.width = 10;
  g.height = 10;
  g.firstLatDegrees = 50.0;
  g.firstLonDegrees = -10.0;
  g.latSpacingDegrees = 1.0;
  g.lonSpacingDegrees = 1.0;
  g.pixelIsArea = false;
  std::vector<float> v(100, 1.0f);
  const HeightGrid grid(g, v, GridSource{});
  EXPECT_FALSE(grid.wrapsLongitude());
  EXPECT_TRUE(grid.sampleBilinear(45.0, -5.0));
  EXPECT_TRUE(grid.sampleBilinear(45.0, 355.0));  // the same place, another turn
  EXPECT_FALSE(grid.sampleBilinear(45.0, 5.0));
  EXPECT_FALSE(grid.sampleBilinear(51.0, -5.0));
  EXPECT_FALSE(grid.sampleBilinear(std::nan(""), -5.0));
  EXPECT_FALSE(grid.sampleBilinear(95.0, -5.0));
  const LatLonBounds b = grid.bounds();
  EXPECT_DOUBLE_EQ(b.northDegrees, 50.0);
  EXPECT_DOUBLE_EQ(b.southDegrees, 41.0);
  EXPECT_DOUBLE_EQ(b.westDegrees, -10.0);
  EXPECT_DOUBLE_EQ(b.eastDegrees, -1.0);
}

}  // namespace
}  // namespace pbdam::formats
