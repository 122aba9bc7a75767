// The composite surface of a base DEM and insets: the inset's heights inside its footprint, a
// continuous blend in the band just inside its edge, the base outside; the finer of overlapping
// insets wins; voids are filled from their rims, large ones from what lies below, and the band
// stays where the data ends; tiles that touch at one spacing are one surface, whatever grouping
// they come in (files, a directory, a glob, a VRT); the samples that define it are each source's
// own where it is the finest; and insets or tiles that cannot be joined are refused by name. On
// synthetic grids and on the real ETOPO5 + Luxembourg GeoTIFF pair.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "TestData.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/NodataFill.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

/// A pixel-is-point grid of `w` × `h` samples from (north, west), spacing `step`, heights f.
template <class F>
HeightGrid grid(std::int64_t w, std::int64_t h, double north, double west, double step, F f,
                GridSource source = {}) {
  GridGeometry g{w, h, north, west, step, step, false};
  std::vector<float> v(static_cast<std::size_t>(w * h));
  for (std::int64_t r = 0; r < h; ++r) {
    for (std::int64_t c = 0; c < w; ++c) {
      v[static_cast<std::size_t>(r * w + c)] = static_cast<float>(
          f(north - static_cast<double>(r) * step, west + static_cast<double>(c) * step));
    }
  }
  return HeightGrid(g, std::move(v), std::move(source));
}

/// The composite of a successful make() (the test fails and stops on an error).
CompositeSurface joined(Result<CompositeSurface> made) {
  if (!made.ok()) {
    ADD_FAILURE() << made.error().message;
    std::abort();
  }
  return std::move(made).value();
}

/// A global 1° base, flat at 0 m, and an inset of 0.1° samples over 10–20°N, 30–40°E at 100 m.
CompositeSurface flatPair(std::vector<HeightGrid> more = {}) {
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return 0.0; });
  std::vector<HeightGrid> insets;
  insets.push_back(grid(101, 101, 20.0, 30.0, 0.1, [](double, double) { return 100.0; }));
  std::vector<InsetSpec> specs{InsetSpec{"a.tif", {}, {}}};
  for (HeightGrid& g : more) {
    insets.push_back(std::move(g));
    specs.push_back(InsetSpec{"b.tif", {}, {}});
  }
  return joined(CompositeSurface::make(std::move(base), std::move(specs), std::move(insets)));
}

TEST(CompositeSurface, InsetInsideBaseOutsideAContinuousBlendBetween) {
  const CompositeSurface s = flatPair();
  // Band: 16 inset samples (the minimum; one base spacing is 10).
  ASSERT_EQ(s.insets()[0].bandSamples, 16);
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 35.0), 100.0);
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 45.0), 0.0);
  EXPECT_DOUBLE_EQ(*s.heightAt(25.0, 35.0), 0.0);
  // The outermost ring of samples has weight 0; 17 samples in, weight 1.
  EXPECT_EQ(s.weightOf(0, 20.0, 35.0), 0.0);
  EXPECT_EQ(s.weightOf(0, 15.0, 30.0), 0.0);
  EXPECT_EQ(s.weightOf(0, 15.0, 32.1), 1.0);
  EXPECT_GT(s.weightOf(0, 15.0, 31.0), 0.0);
  EXPECT_LT(s.weightOf(0, 15.0, 31.0), 1.0);
  // Walking across the edge into the inset, heights rise monotonically with no step larger than
  // the blend's steepest slope allows (smoothstep: 1.5 × 100 m over the 1.6° band).
  double last = *s.heightAt(15.0, 29.0);
  for (double lon = 29.0; lon <= 33.0; lon += 0.001) {
    const double h = *s.heightAt(15.0, lon);
    EXPECT_GE(h, last - 1e-9) << lon;
    EXPECT_LE(h - last, 1.5 * 100.0 / 1.6 * 0.001 * 1.01 + 1e-9) << lon;
    last = h;
  }
  EXPECT_EQ(s.sourceAt(15.0, 35.0).inset, 0);
  EXPECT_EQ(s.sourceAt(15.0, 35.0).weight, 1.0);
  EXPECT_EQ(s.sourceAt(15.0, 45.0).inset, -1);
}

// The band spans a cell of what the inset blends into — a coarser inset holding it, else the
// base — but at most a quarter of the inset's smaller side, so an inset smaller than a cell
// below it keeps its middle at its own samples.
TEST(CompositeSurface, TheBandSpansACellOfWhatLiesBelowAndAtMostAQuarterOfTheInset) {
  const auto flat = [](double, double) { return 0.0; };
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, flat);
  std::vector<HeightGrid> insets;
  insets.push_back(grid(1001, 1001, 20.0, 30.0, 0.01, flat));    // 100 base samples a cell
  insets.push_back(grid(401, 401, 15.2, 35.0, 0.0005, flat));    // inside it: 20 a cell of it
  insets.push_back(grid(201, 201, -10.0, 100.0, 0.0005, flat));  // alone: 2000 a base cell
  std::vector<InsetSpec> specs{InsetSpec{"a.tif", {}, {}}, InsetSpec{"b.tif", {}, {}},
                               InsetSpec{"c.tif", {}, {}}};
  const CompositeSurface s =
      joined(CompositeSurface::make(std::move(base), std::move(specs), std::move(insets)));
  ASSERT_EQ(s.insets().size(), 3u);  // coarsest first
  EXPECT_EQ(s.insets()[0].bandSamples, 100);
  EXPECT_EQ(s.insets()[1].bandSamples, 20);  // one cell of the inset holding it
  EXPECT_EQ(s.insets()[2].bandSamples, 50);  // a quarter of its 201 samples, not 2000
  // The lone fine inset's middle is its own: weight 1 there.
  EXPECT_EQ(s.weightOf(2, -10.05, 100.05), 1.0);
}

TEST(CompositeSurface, TheFinerOfOverlappingInsetsWins) {
  std::vector<HeightGrid> fine;
  // 0.05° samples over 12–18°N, 36–44°E at 200 m: it overlaps the 0.1° inset's east part.
  fine.push_back(grid(161, 121, 18.0, 36.0, 0.05, [](double, double) { return 200.0; }));
  const CompositeSurface s = flatPair(std::move(fine));
  ASSERT_EQ(s.insets().size(), 2u);
  EXPECT_EQ(s.specs()[1].path, "b.tif");  // coarsest first
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 39.0), 200.0);
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 41.5), 200.0);  // outside the coarser inset
  // Within the finer inset's 1° band (20 samples), outside the coarser one: a blend to the base.
  EXPECT_NEAR(*s.heightAt(15.0, 43.5), 100.0, 1e-9);
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 33.0), 100.0);
  EXPECT_EQ(s.sourceAt(15.0, 39.0).inset, 1);
  // In the finer inset's band over the coarser one, it blends to 100 m, not to the base's 0.
  const double h = *s.heightAt(15.0, 36.5);
  EXPECT_GT(h, 100.0);
  EXPECT_LT(h, 200.0);
}

TEST(CompositeSurface, SmallVoidsAreFilledFromTheirRimsAndTheBandStaysWhereTheDataEnds) {
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return -5.0; });
  const auto terrain = [](double lat, double lon) {
    return 100.0 + 40.0 * std::sin(3.0 * lat) * std::cos(2.0 * lon);
  };
  const auto hole = [&](double lat, double lon) {
    return std::hypot(lat - 15.0, lon - 35.0) < 0.5 ? std::numeric_limits<double>::quiet_NaN()
                                                    : terrain(lat, lon);
  };
  HeightGrid holed = grid(101, 101, 20.0, 30.0, 0.1, hole);
  // GDAL's fill-nodata over the whole grid (gdal_fillnodata.py -md 100): what the void becomes.
  std::vector<float> expected(holed.heightsMeters().begin(), holed.heightsMeters().end());
  ASSERT_TRUE(fillNodata(expected, 101, 101, 100.0).ok());
  std::vector<HeightGrid> insets;
  insets.push_back(holed);
  const CompositeSurface s = joined(
      CompositeSurface::make(std::move(base), {InsetSpec{"hole.tif", {}, {}}}, std::move(insets)));
  const VoidReport& v = s.insets()[0].voids;
  EXPECT_EQ(v.voids, 1);
  EXPECT_EQ(v.filledVoids, 1);
  EXPECT_EQ(v.largeVoids, 0);
  EXPECT_EQ(v.voidSamples, v.filledSamples);
  EXPECT_GT(v.filledSamples, 60);
  // Every sample of the void is GDAL's fill, the composite's height there, with weight 1.
  for (std::int64_t r = 0; r < 101; ++r) {
    for (std::int64_t c = 0; c < 101; ++c) {
      if (!std::isnan(holed.at(r, c))) continue;
      const double lat = holed.latOfRowDegrees(r), lon = holed.lonOfColumnDegrees(c);
      EXPECT_EQ(s.insets()[0].grid.at(r, c), expected[static_cast<std::size_t>(r * 101 + c)]);
      EXPECT_EQ(s.weightOf(0, lat, lon), 1.0);
      EXPECT_NEAR(*s.heightAt(lat, lon),
                  static_cast<double>(expected[static_cast<std::size_t>(r * 101 + c)]), 1e-4);
      EXPECT_EQ(s.sourceAt(lat, lon).inset, 0);
    }
  }
  // The valid samples next to the void keep their own heights (no band around a void).
  EXPECT_NEAR(*s.heightAt(15.0, 35.6), terrain(15.0, 35.6), 1e-3);
  EXPECT_EQ(s.weightOf(0, 15.0, 35.6), 1.0);
}

TEST(CompositeSurface, ALargeVoidShowsWhatLiesBelowBlendedAcrossABandSizedByTheVoid) {
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return -5.0; });
  // 0.01° samples over 10–16°N, 30–36°E at 100 m with a lake of 1.2° radius (120 samples: more
  // than the fill's reach) around 13°N 33°E and nodata reaching the west edge (a clip).
  const auto lake = [](double lat, double lon) {
    if (std::hypot(lat - 13.0, lon - 33.0) < 1.2 || lon < 30.195) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    return 100.0;
  };
  std::vector<HeightGrid> insets;
  insets.push_back(grid(601, 601, 16.0, 30.0, 0.01, lake));
  const CompositeSurface s = joined(
      CompositeSurface::make(std::move(base), {InsetSpec{"lake.tif", {}, {}}}, std::move(insets)));
  const VoidReport& v = s.insets()[0].voids;
  EXPECT_EQ(v.voids, 1);
  EXPECT_EQ(v.largeVoids, 1);
  EXPECT_EQ(v.filledVoids, 0);
  EXPECT_GT(v.belowSamples, 40000);
  EXPECT_EQ(v.outsideSamples, 601 * 20);
  EXPECT_NEAR(v.largestBelow.southDegrees, 11.8, 0.02);
  ASSERT_EQ(s.insets()[0].bandSamples, 100);
  // Along the row through the lake's middle, at sample centres: the shore is the inset's
  // 100 m, the middle the base's −5 m, and between them a monotone fade over half the lake's
  // radius (60 samples); the valid samples by the shore keep their own height and weight 1.
  const HeightGrid& g = s.insets()[0].grid;
  const std::int64_t row = 300, shore = 420;  // 13°N; 34.2°E, the first valid sample east
  ASSERT_EQ(g.latOfRowDegrees(row), 13.0);
  EXPECT_EQ(g.at(row, shore), 100.0f);
  EXPECT_EQ(s.weightOf(0, 13.0, g.lonOfColumnDegrees(shore + 2)), 1.0);
  EXPECT_DOUBLE_EQ(*s.heightAt(13.0, g.lonOfColumnDegrees(shore + 2)), 100.0);
  EXPECT_NEAR(g.at(row, shore - 1), 100.0f, 1e-3);
  float last = 101.0f;
  for (std::int64_t c = shore - 1; c >= 300; --c) {
    EXPECT_LE(g.at(row, c), last) << c;
    last = g.at(row, c);
    EXPECT_EQ(s.weightOf(0, 13.0, g.lonOfColumnDegrees(c)), 1.0) << c;
  }
  EXPECT_NEAR(g.at(row, shore - 61), -5.0f, 1e-3);  // past the band of 60 samples
  EXPECT_NEAR(*s.heightAt(13.0, 33.0), -5.0, 1e-3);
  // The clipped west edge still bands: weight 0 on its outer ring.
  EXPECT_EQ(s.weightOf(0, 14.0, 30.2), 0.0);
}

TEST(CompositeSurface, TilesOfDifferentSpacingsSideBySideMeetWithoutABandAlongTheirSeam) {
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return 0.0; });
  const auto terrain = [](double lat, double lon) { return 500.0 + 10.0 * lat + 5.0 * lon; };
  // A 0.05° tile over 30–32°E and a 0.1° one over 32–36°E sharing the 32°E column (SRTM's
  // convention), both over 10–14°N.
  std::vector<HeightGrid> insets;
  insets.push_back(grid(41, 81, 14.0, 30.0, 0.05, terrain));
  insets.push_back(grid(41, 41, 14.0, 32.0, 0.1, terrain));
  const CompositeSurface s = joined(CompositeSurface::make(
      std::move(base), {InsetSpec{"fine.tif", {}, {}}, InsetSpec{"coarse.tif", {}, {}}},
      std::move(insets)));
  ASSERT_EQ(s.insets().size(), 2u);
  // Along the seam and on both sides of it, the tiles' own heights: no fade to the base's 0 m.
  for (double lon : {31.9, 31.97, 32.0, 32.03, 32.1, 32.3}) {
    EXPECT_NEAR(*s.heightAt(12.0, lon), terrain(12.0, lon), 1e-6) << lon;
  }
  // Where the data ends (the fine tile's west edge, the coarse tile's east edge), the band.
  EXPECT_LT(*s.heightAt(12.0, 30.1), 0.9 * terrain(12.0, 30.1));
  EXPECT_LT(*s.heightAt(12.0, 35.9), 0.9 * terrain(12.0, 35.9));

  // The same tiles abutting cell to cell (pixel-is-area, no shared column): the fine tile's last
  // sample centre is at 31.975°E, the coarse one's first at 32.05°E. Each is drawn to its cells'
  // edge at 32°E, so the strip between the centres is theirs, not the base's.
  const auto areaGrid = [&](std::int64_t w, std::int64_t h, double west, double step) {
    std::vector<float> v(static_cast<std::size_t>(w * h));
    for (std::int64_t r = 0; r < h; ++r) {
      for (std::int64_t c = 0; c < w; ++c) {
        v[static_cast<std::size_t>(r * w + c)] =
            static_cast<float>(terrain(14.0 - (static_cast<double>(r) + 0.5) * step,
                                       west + (static_cast<double>(c) + 0.5) * step));
      }
    }
    return HeightGrid(GridGeometry{w, h, 14.0 - 0.5 * step, west + 0.5 * step, step, step, true},
                      std::move(v), GridSource{});
  };
  std::vector<HeightGrid> abutting;
  abutting.push_back(areaGrid(40, 80, 30.0, 0.05));
  abutting.push_back(areaGrid(40, 40, 32.0, 0.1));
  const CompositeSurface a = joined(CompositeSurface::make(
      grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return 0.0; }),
      {InsetSpec{"fine.tif", {}, {}}, InsetSpec{"coarse.tif", {}, {}}}, std::move(abutting)));
  for (double lon = 31.9; lon <= 32.15; lon += 0.005) {
    // Held at the outermost samples across the half cells: within a half cell's slope (5 m/°).
    EXPECT_NEAR(*a.heightAt(12.0, lon), terrain(12.0, lon), 0.26) << lon;
    EXPECT_EQ(a.sourceAt(12.0, lon).inset, lon < 32.0 ? 1 : 0) << lon;
  }
  // Beyond an edge where the data ends, the half cell stays the base's.
  EXPECT_EQ(a.weightOf(0, 12.0, 36.04), 0.0);
  EXPECT_EQ(a.weightOf(1, 12.0, 29.99), 0.0);
}

TEST(CompositeSurface, ItsSamplesAreEachSourcesOwnWhereItIsTheFinest) {
  std::vector<HeightGrid> fine;
  fine.push_back(
      grid(161, 121, 18.0, 36.0, 0.05, [](double lat, double lon) { return 200.0 + lat + lon; }));
  const CompositeSurface s = flatPair(std::move(fine));
  std::array<std::size_t, 3> counts{};
  double worst = 0.0;
  s.forEachSample([&](int source, double lat, double lon, double height) {
    ++counts[source < 0 ? 0 : static_cast<std::size_t>(source) + 1];
    // Every sample's height is the composite's there, and the composite's source is its own.
    worst = std::max(worst, std::abs(height - *s.heightAt(lat, lon)));
    EXPECT_EQ(s.sourceAt(lat, lon).inset, source) << lat << "," << lon;
  });
  EXPECT_LT(worst, 1e-6);
  // Base: every sample but those inside the 0.1° inset's footprint hull (11–19°N, 31–39°E plus
  // the finer inset's 13–17°N, 40–43°E): 65160 − 81 − 20.
  EXPECT_EQ(counts[0], 360u * 181u - 81u - 20u);
  EXPECT_GT(counts[1], 0u);
  EXPECT_GT(counts[2], 0u);
  // The finer inset contributes all samples but its outer ring.
  EXPECT_EQ(counts[2], 159u * 119u);
}

TEST(CompositeSurface, InsetsThatCannotBeJoinedAreRefusedByName) {
  GridSource egm96;
  egm96.verticalDatum = "EGM96 height";
  const HeightGrid base = grid(
      360, 181, 90.0, 0.0, 1.0, [](double, double) { return 0.0; }, egm96);
  const auto check = [&](const HeightGrid& inset, const InsetSpec& spec,
                         const std::string& planet) {
    return checkInset(spec, inset, base, planet);
  };
  GridSource earth;
  earth.body = "earth";
  earth.verticalDatum = "NAVD88 height";
  const HeightGrid fine = grid(
      11, 11, 20.0, 30.0, 0.1, [](double, double) { return 1.0; }, earth);
  const HeightGrid coarse = grid(11, 11, 20.0, 30.0, 2.0, [](double, double) { return 1.0; });
  const auto onMars = check(fine, {"usgs.tif", 3.0, {}}, "mars");
  ASSERT_FALSE(onMars.ok());
  EXPECT_NE(
      onMars.error().message.find("usgs.tif: the inset's CRS is on earth but --planet is mars"),
      std::string::npos)
      << onMars.error().message;
  const auto datum = check(fine, {"usgs.tif", {}, {}}, "earth");
  ASSERT_FALSE(datum.ok());
  EXPECT_NE(datum.error().message.find("--inset-offset"), std::string::npos);
  EXPECT_NE(datum.error().message.find("NAVD88 height"), std::string::npos);
  EXPECT_TRUE(check(fine, {"usgs.tif", 0.7, {}}, "earth").ok());
  const auto notFiner = check(coarse, {"coarse.tif", {}, {}}, "earth");
  ASSERT_FALSE(notFiner.ok());
  EXPECT_NE(notFiner.error().message.find("not finer than the base"), std::string::npos);
  const HeightGrid empty = grid(11, 11, 20.0, 30.0, 0.1, [](double, double) {
    return std::numeric_limits<double>::quiet_NaN();
  });
  EXPECT_FALSE(check(empty, {"empty.tif", {}, {}}, "earth").ok());
}

// The issue's real pair: ETOPO5 (5′) with the Luxembourg GeoTIFF (30″) on it.
TEST(CompositeSurface, LuxembourgOnEtopo5) {
  PBDAM_REQUIRE_DATA(luxembourgPath, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  PBDAM_REQUIRE_DATA(etopoPath, PBDAM_ETOPO5_PATH);
  auto etopo = readDem(etopoPath);
  auto luxembourg = readDem(luxembourgPath);
  ASSERT_TRUE(etopo.ok()) << etopo.error().message;
  ASSERT_TRUE(luxembourg.ok()) << luxembourg.error().message;
  const InsetSpec spec{luxembourgPath, {}, {}};
  ASSERT_TRUE(checkInset(spec, *luxembourg, *etopo, "earth").ok());
  EXPECT_FALSE(checkInset(spec, *luxembourg, *etopo, "mars").ok());
  const HeightGrid lux = *luxembourg;
  const CompositeSurface s =
      joined(CompositeSurface::make(*etopo, {spec}, std::vector<HeightGrid>{*luxembourg}));
  // One ETOPO5 spacing is 10 Luxembourg samples: the band is the minimum, 16.
  EXPECT_EQ(s.insets()[0].bandSamples, 16);
  // The GeoTIFF holds the country's shape (nodata around it): wherever a sample is more than the
  // band inside that shape, the composite is the GeoTIFF's own height.
  std::size_t inner = 0;
  for (std::int64_t r = 0; r < lux.height(); ++r) {
    for (std::int64_t c = 0; c < lux.width(); ++c) {
      const double lat = lux.latOfRowDegrees(r), lon = lux.lonOfColumnDegrees(c);
      if (s.weightOf(0, lat, lon) < 1.0) continue;
      ++inner;
      EXPECT_NEAR(*s.heightAt(lat, lon), static_cast<double>(lux.at(r, c)), 1e-9);
      EXPECT_EQ(s.sourceAt(lat, lon).inset, 0);
    }
  }
  std::printf("%zu Luxembourg samples beyond the band\n", inner);
  EXPECT_GT(inner, 200u);
  // Well outside it: ETOPO5's.
  EXPECT_NEAR(*s.heightAt(49.0, 5.0), *etopo->sampleBicubic(49.0, 5.0), 1e-9);
  EXPECT_EQ(s.sourceAt(49.0, 5.0).inset, -1);
}

/// Writes rows [r0, r1] and columns [c0, c1] of `g` (pixel-is-area) as an ESRI ASCII grid.
void writeTile(const std::filesystem::path& path, const HeightGrid& g, std::int64_t r0,
               std::int64_t r1, std::int64_t c0, std::int64_t c1) {
  std::ofstream out(path);
  const GridGeometry& geo = g.geometry();
  char header[256];
  std::snprintf(header, sizeof header,
                "ncols %lld\nnrows %lld\nxllcorner %.12f\nyllcorner %.12f\ncellsize %.12f\n"
                "NODATA_value -9999\n",
                static_cast<long long>(c1 - c0) + 1, static_cast<long long>(r1 - r0) + 1,
                g.lonOfColumnDegrees(c0) - 0.5 * geo.lonSpacingDegrees,
                g.latOfRowDegrees(r1) - 0.5 * geo.latSpacingDegrees, geo.lonSpacingDegrees);
  out << header;
  for (std::int64_t r = r0; r <= r1; ++r) {
    for (std::int64_t c = c0; c <= c1; ++c) {
      const float v = g.at(r, c);
      out << (std::isnan(v) ? -9999.0f : v) << (c < c1 ? " " : "\n");
    }
  }
}

/// The composite's inset samples in order, and the count of its base samples.
std::pair<std::vector<std::array<double, 3>>, std::size_t> samplesOf(const CompositeSurface& s) {
  std::vector<std::array<double, 3>> out;
  std::size_t base = 0;
  s.forEachSample([&](int source, double lat, double lon, double h) {
    if (source < 0) {
      ++base;
    } else {
      out.push_back({lat, lon, h});
    }
  });
  return {std::move(out), base};
}

// The Luxembourg GeoTIFF cut into 2 × 2 tiles — sharing their edge rows (SRTM's convention) or
// abutting cell to cell — and given as four insets, as a directory, as a glob or as a VRT: one
// surface with the single file's samples and heights, no band along the seams.
TEST(CompositeSurface, TilesThatTouchAreOneSurfaceWhateverGroupingTheyComeIn) {
  PBDAM_REQUIRE_DATA(luxembourgPath, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  PBDAM_REQUIRE_DATA(etopoPath, PBDAM_ETOPO5_PATH);
  auto etopo = readDem(etopoPath);
  auto lux = readDem(luxembourgPath);
  ASSERT_TRUE(etopo.ok() && lux.ok());
  test::TempDir dir;
  const std::int64_t w = lux->width(), h = lux->height(), rm = h / 2, cm = w / 2;
  writeTile(dir / "whole.asc", *lux, 0, h - 1, 0, w - 1);
  std::filesystem::create_directories(dir / "shared");
  std::filesystem::create_directories(dir / "abutting");
  for (const auto& [name, overlap] : {std::pair{"shared", 0}, std::pair{"abutting", 1}}) {
    const std::filesystem::path d = dir / name;
    writeTile(d / "nw.asc", *lux, 0, rm, 0, cm);
    writeTile(d / "ne.asc", *lux, 0, rm, cm + overlap, w - 1);
    writeTile(d / "sw.asc", *lux, rm + overlap, h - 1, 0, cm);
    writeTile(d / "se.asc", *lux, rm + overlap, h - 1, cm + overlap, w - 1);
  }
  ASSERT_EQ(test::runCommand("gdalbuildvrt -q '" + (dir / "tiles.vrt").string() + "' '" +
                             (dir / "abutting").string() + "'/*.asc")
                .exitCode,
            0);
  const auto read = [&](std::vector<std::filesystem::path> paths) {
    std::vector<InsetSpec> specs;
    specs.reserve(paths.size());
    for (auto& p : paths) specs.push_back(InsetSpec{std::move(p), {}, {}});
    return CompositeSurface::read(*etopo, std::move(specs), {}, "earth");
  };
  auto whole = read({dir / "whole.asc"});
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  const auto wholeSamples = samplesOf(*whole);
  std::mt19937_64 random(7);
  const LatLonBounds b = lux->bounds();
  std::uniform_real_distribution<double> lat(b.southDegrees, b.northDegrees);
  std::uniform_real_distribution<double> lon(b.westDegrees, b.eastDegrees);
  std::vector<std::pair<double, double>> points;
  points.reserve(1000);
  for (int k = 0; k < 1000; ++k) points.emplace_back(lat(random), lon(random));
  const std::vector<std::pair<std::string, std::vector<std::filesystem::path>>> groupings = {
      {"four files sharing edge rows",
       {dir / "shared/nw.asc", dir / "shared/se.asc", dir / "shared/ne.asc",
        dir / "shared/sw.asc"}},
      {"four abutting files",
       {dir / "abutting/sw.asc", dir / "abutting/nw.asc", dir / "abutting/ne.asc",
        dir / "abutting/se.asc"}},
      {"a directory", {dir / "shared"}},
      {"a glob", {dir / "abutting/*.asc"}},
      {"a VRT", {dir / "tiles.vrt"}},
      {"a directory and a file of it twice over", {dir / "abutting", dir / "shared/nw.asc"}},
  };
  for (const auto& [what, paths] : groupings) {
    SCOPED_TRACE(what);
    auto tiled = read(paths);
    ASSERT_TRUE(tiled.ok()) << tiled.error().message;
    ASSERT_EQ(tiled->insets().size(), 1u) << "one surface";
    EXPECT_EQ(tiled->insets()[0].bandSamples, whole->insets()[0].bandSamples);
    EXPECT_TRUE(samplesOf(*tiled) == wholeSamples) << "the same samples, heights and order";
    for (const auto& [la, lo] : points) {
      const auto expected = whole->heightAt(la, lo);
      const auto got = tiled->heightAt(la, lo);
      ASSERT_EQ(expected.has_value(), got.has_value());
      if (expected) {
        EXPECT_EQ(*got, *expected) << la << "," << lo;
      }
      EXPECT_EQ(tiled->weightOf(0, la, lo), whole->weightOf(0, la, lo));
    }
  }
}

// The voids are found row by row over runs of nodata: the same regions as a plain 8-connected
// flood fill over random masks from sparse specks to mostly nodata (spirals, diagonal-only
// links and regions that reach the edge through a corner included by chance).
TEST(CompositeSurface, VoidsAreTheEightConnectedRegionsThatDoNotReachTheEdge) {
  std::mt19937_64 random(42);
  for (const double density : {0.02, 0.2, 0.45, 0.6, 0.9}) {
    for (int trial = 0; trial < 6; ++trial) {
      const std::int64_t w = 37 + trial * 7, h = 29 + trial * 5;
      std::bernoulli_distribution nodata(density);
      std::vector<bool> mask(static_cast<std::size_t>(w * h));
      for (std::size_t i = 0; i < mask.size(); ++i) mask[i] = nodata(random);
      const HeightGrid g = grid(w, h, 20.0, 30.0, 0.01, [&](double lat, double lon) {
        const auto r = static_cast<std::int64_t>(std::lround((20.0 - lat) / 0.01));
        const auto c = static_cast<std::int64_t>(std::lround((lon - 30.0) / 0.01));
        return mask[static_cast<std::size_t>(r * w + c)] ? std::numeric_limits<double>::quiet_NaN()
                                                         : 10.0;
      });
      // The reference: flood fill.
      std::int64_t voids = 0, voidSamples = 0, outside = 0;
      std::vector<bool> seen(mask.size());
      for (std::int64_t start = 0; start < w * h; ++start) {
        if (!mask[static_cast<std::size_t>(start)] || seen[static_cast<std::size_t>(start)]) {
          continue;
        }
        std::vector<std::int64_t> stack{start};
        seen[static_cast<std::size_t>(start)] = true;
        std::int64_t count = 0;
        bool edge = false;
        while (!stack.empty()) {
          const std::int64_t i = stack.back();
          stack.pop_back();
          ++count;
          const std::int64_t r = i / w, c = i % w;
          edge = edge || r == 0 || c == 0 || r == h - 1 || c == w - 1;
          for (std::int64_t dr = -1; dr <= 1; ++dr) {
            for (std::int64_t dc = -1; dc <= 1; ++dc) {
              const std::int64_t nr = r + dr, nc = c + dc;
              if (nr < 0 || nc < 0 || nr >= h || nc >= w) continue;
              const auto j = static_cast<std::size_t>(nr * w + nc);
              if (mask[j] && !seen[j]) {
                seen[j] = true;
                stack.push_back(nr * w + nc);
              }
            }
          }
        }
        if (edge) {
          outside += count;
        } else {
          ++voids;
          voidSamples += count;
        }
      }
      const auto report = findVoids(g);
      ASSERT_TRUE(report.ok()) << report.error().message;
      SCOPED_TRACE("density " + std::to_string(density) + ", trial " + std::to_string(trial));
      EXPECT_EQ(report->voids, voids);
      EXPECT_EQ(report->voidSamples, voidSamples);
      EXPECT_EQ(report->outsideSamples, outside);
      EXPECT_EQ(report->filledVoids + report->largeVoids, voids);
    }
  }
}

// A tile set read out of core (its mosaic, the filled copy and the edge distances in mapped
// scratch files, as `pbdam build` reads anything over 256 MB) is the same surface as read in
// memory: the same samples, heights, weights and voids. On the Luxembourg GeoTIFF with voids
// punched on its steepest slopes, cut into two tiles.
TEST(CompositeSurface, ATileSetReadOutOfCoreIsTheSameSurface) {
  PBDAM_REQUIRE_DATA(luxembourgPath, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  PBDAM_REQUIRE_DATA(etopoPath, PBDAM_ETOPO5_PATH);
  auto etopo = readDem(etopoPath);
  auto lux = readDem(luxembourgPath);
  ASSERT_TRUE(etopo.ok() && lux.ok());
  // Voids: a 3 × 3 one, filled from its rim, and a 13 × 13 one, beyond a fill search of 4
  // samples: the surface below.
  std::vector<float> heights(lux->heightsMeters().begin(), lux->heightsMeters().end());
  const std::int64_t w = lux->width(), h = lux->height();
  const auto punch = [&](std::int64_t r0, std::int64_t c0, std::int64_t n) {
    for (std::int64_t r = r0; r < r0 + n; ++r) {
      for (std::int64_t c = c0; c < c0 + n; ++c) {
        heights[static_cast<std::size_t>(r * w + c)] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  };
  punch(h / 3, w / 2, 3);
  punch(h / 2 - 6, w / 2 - 6, 13);
  const HeightGrid punched(lux->geometry(), std::move(heights), lux->source());
  test::TempDir dir;
  std::filesystem::create_directories(dir / "tiles");
  std::filesystem::create_directories(dir / "scratch");
  writeTile(dir / "tiles/west.asc", punched, 0, h - 1, 0, w / 2);
  writeTile(dir / "tiles/east.asc", punched, 0, h - 1, w / 2 + 1, w - 1);
  auto inMemory =
      CompositeSurface::read(*etopo, {InsetSpec{dir / "tiles", {}, {}}}, {}, "earth",
                             VoidFillOptions{.maxDistanceSamples = 4.0, .scratchDirectory = {}});
  DemReadOptions mapped;
  mapped.scratchDirectory = dir / "scratch";
  mapped.mapAtBytes = 0;
  auto outOfCore = CompositeSurface::read(
      *etopo, {InsetSpec{dir / "tiles", {}, {}}}, mapped, "earth",
      VoidFillOptions{.maxDistanceSamples = 4.0, .scratchDirectory = dir / "scratch"});
  ASSERT_TRUE(inMemory.ok()) << inMemory.error().message;
  ASSERT_TRUE(outOfCore.ok()) << outOfCore.error().message;
  const CompositeSurface::Inset& a = inMemory->insets().at(0);
  const CompositeSurface::Inset& b = outOfCore->insets().at(0);
  EXPECT_FALSE(a.grid.fileBacked());
  EXPECT_EQ(a.edgeDistanceFile, nullptr);
  EXPECT_TRUE(b.grid.fileBacked());
  ASSERT_NE(b.edgeDistanceFile, nullptr);
  EXPECT_EQ(b.voids.voids, 2);
  EXPECT_EQ(b.voids.filledVoids, 1);
  EXPECT_EQ(b.voids.largeVoids, 1);
  EXPECT_EQ(a.voids.voidSamples, b.voids.voidSamples);
  EXPECT_EQ(a.voids.outsideSamples, b.voids.outsideSamples);
  EXPECT_TRUE(std::equal(a.edgeDistance.begin(), a.edgeDistance.end(), b.edgeDistance.begin(),
                         b.edgeDistance.end()));
  EXPECT_TRUE(samplesOf(*inMemory) == samplesOf(*outOfCore));
  outOfCore->releaseResident();
  EXPECT_TRUE(samplesOf(*inMemory) == samplesOf(*outOfCore)) << "after letting the pages go";
}

TEST(CompositeSurface, TileSetsThatCannotBeReadAreRefusedNamingTheFile) {
  PBDAM_REQUIRE_DATA(luxembourgPath, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  PBDAM_REQUIRE_DATA(etopoPath, PBDAM_ETOPO5_PATH);
  auto etopo = readDem(etopoPath);
  auto lux = readDem(luxembourgPath);
  ASSERT_TRUE(etopo.ok() && lux.ok());
  test::TempDir dir;
  const auto refused = [&](const std::filesystem::path& path, const std::string& expected) {
    auto read = CompositeSurface::read(*etopo, {InsetSpec{path, {}, {}}}, {}, "earth");
    ASSERT_FALSE(read.ok()) << path;
    EXPECT_NE(read.error().message.find(expected), std::string::npos) << read.error().message;
  };
  std::filesystem::create_directories(dir / "empty");
  std::ofstream(dir / "empty/README.txt") << "not a tile\n";
  refused(dir / "empty", "holds no tiles");
  refused(dir / "nothing/*.hgt", "matches no tiles");
  // A corrupt tile among good ones.
  std::filesystem::create_directories(dir / "corrupt");
  writeTile(dir / "corrupt/a.asc", *lux, 0, 40, 0, 40);
  writeTile(dir / "corrupt/b.asc", *lux, 0, 40, 40, 80);
  std::ofstream(dir / "corrupt/c.asc") << "ncols 12\nnrows x\ngarbage\n";
  refused(dir / "corrupt", "corrupt/c.asc");
  // A tile of another planet (its CRS says Mars) beside Earth's.
  std::filesystem::create_directories(dir / "planets");
  writeTile(dir / "planets/earth.asc", *lux, 0, 40, 0, 40);
  writeTile(dir / "planets/mars.asc", *lux, 0, 40, 40, 80);
  std::ofstream(dir / "planets/earth.prj")
      << R"(GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],)"
      << R"(PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]])";
  std::ofstream(dir / "planets/mars.prj")
      << R"(GEOGCS["Mars 2000",DATUM["D_Mars_2000",SPHEROID["Mars_2000_IAU_IAG",3396190,)"
      << R"(169.894447223612]],PRIMEM["Reference_Meridian",0],UNIT["degree",0.0174532925199433]])";
  refused(dir / "planets", "planets/mars.asc: its CRS is on mars");
  // Tiles no finer than the base, named by the tile.
  std::filesystem::create_directories(dir / "coarse");
  writeTile(dir / "coarse/a.asc", grid(8, 8, 50.0, 5.0, 0.5, [](double, double) { return 300.0; }),
            0, 7, 0, 7);
  refused(dir / "coarse", "coarse/a.asc: its samples");
}

}  // namespace
}  // namespace pbdam::builder
