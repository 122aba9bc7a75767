// The composite surface of a base DEM and insets: the inset's heights inside its footprint, a
// continuous blend in the band just inside its edge, the base outside; the finer of overlapping
// insets wins; nodata holes fall back to what lies below; the samples that define it are each
// source's own where it is the finest; and insets that cannot be joined are refused by name. On
// synthetic grids and on the real ETOPO5 + Luxembourg GeoTIFF pair.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "TestData.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"

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
  return CompositeSurface::make(std::move(base), std::move(specs), std::move(insets));
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
      CompositeSurface::make(std::move(base), std::move(specs), std::move(insets));
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

TEST(CompositeSurface, NodataHolesFallBackToWhatLiesBelow) {
  HeightGrid base = grid(360, 181, 90.0, 0.0, 1.0, [](double, double) { return -5.0; });
  std::vector<HeightGrid> insets;
  insets.push_back(grid(101, 101, 20.0, 30.0, 0.1, [](double lat, double lon) {
    return std::hypot(lat - 15.0, lon - 35.0) < 0.5 ? std::numeric_limits<double>::quiet_NaN()
                                                    : 100.0;
  }));
  const CompositeSurface s =
      CompositeSurface::make(std::move(base), {InsetSpec{"hole.tif", {}, {}}}, std::move(insets));
  EXPECT_DOUBLE_EQ(*s.heightAt(15.0, 35.0), -5.0);
  EXPECT_EQ(s.sourceAt(15.0, 35.0).inset, -1);
  // Around the hole the band rises again: 0.7° (7 samples) from its nearest nodata sample the
  // weight is between 0 and 1; beyond the 16-sample band it is 1.
  EXPECT_LT(s.weightOf(0, 15.0, 36.1), 1.0);
  EXPECT_GT(s.weightOf(0, 15.0, 36.1), 0.0);
  EXPECT_DOUBLE_EQ(*s.heightAt(17.5, 37.5), 100.0);
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

// The real pair: ETOPO5 (5′) with the Luxembourg GeoTIFF (30″) on it.
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
  const CompositeSurface s = CompositeSurface::make(*etopo, {spec}, {std::move(*luxembourg)});
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

}  // namespace
}  // namespace pbdam::builder
