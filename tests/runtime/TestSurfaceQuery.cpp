// pbdam height's query on real datasets: the rendered surface height agrees with the source
// DEM's bilinear sample within the stored error of the leaf it comes from.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>

#include "TestData.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::runtime {
namespace {

void expectHeightsWithinStoredError(const std::filesystem::path& dir,
                                    const std::filesystem::path& demPath, std::uint64_t seed) {
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double worst = 0.0;
  for (int k = 0; k < 300; ++k) {
    // Uniform on the sphere, plus the poles and a face corner.
    double lat = std::asin(2.0 * unit(rng) - 1.0) * 180.0 / 3.14159265358979323846;
    double lon = 360.0 * unit(rng) - 180.0;
    if (k == 0) lat = 90.0;
    if (k == 1) lat = -90.0;
    if (k == 2) lat = 35.264389682754654, lon = 45.0;  // (1, 1, 1)/√3 on a sphere
    const auto h = surfaceHeightAt((*dataset)->view(), lat, lon);
    ASSERT_TRUE(h.ok()) << h.error().message;
    const auto sample = dem->sampleBilinear(lat, lon);
    if (!sample) continue;
    const double diff = std::abs(h->heightMeters - *sample);
    EXPECT_LE(diff, h->leafErrorMeters) << lat << ", " << lon;
    worst = std::max(worst, diff / h->leafErrorMeters);
  }
  std::printf("worst |height - DEM| at %.0f%% of the stored error\n", 100.0 * worst);
}

TEST(SurfaceQuery, MarsHeightsMatchTheDemWithinTheStoredError) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  expectHeightsWithinStoredError(dir, dem, 11);
}

TEST(SurfaceQuery, EarthHeightsMatchTheDemWithinTheStoredError) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  PBDAM_REQUIRE_DATA(dem, PBDAM_ETOPO5_PATH);
  expectHeightsWithinStoredError(dir, dem, 12);
}

// A SurfaceLeafCache changes nothing but the decoding: along random 100 km segments (a ray
// march's points, many on leaves already decoded), across faces and at the poles, the cached
// answers are the uncached ones bit for bit, also once the cache has started over; a
// malformed position is refused the same way.
TEST(SurfaceQuery, ACacheOfLeavesGivesTheSameAnswers) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  SurfaceLeafCache cache(40);  // small, so that it starts over along the way
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int points = 0;
  for (int line = 0; line < 20; ++line) {
    const double lat = line == 0 ? 89.5 : line == 1 ? -89.5 : 170.0 * unit(rng) - 85.0;
    const double lon = 360.0 * unit(rng) - 180.0;
    const double dLat = 2.0 * unit(rng) - 1.0, dLon = 2.0 * unit(rng) - 1.0;
    for (int s = 0; s <= 50; ++s, ++points) {
      const double la = std::clamp(lat + dLat * s / 50.0, -90.0, 90.0);
      const double lo = lon + dLon * s / 50.0;
      const auto plain = surfaceHeightAt(view, la, lo);
      const auto cached = surfaceHeightAt(view, la, lo, cache);
      ASSERT_TRUE(plain.ok()) << plain.error().message;
      ASSERT_TRUE(cached.ok()) << cached.error().message;
      EXPECT_EQ(std::bit_cast<std::uint64_t>(cached->heightMeters),
                std::bit_cast<std::uint64_t>(plain->heightMeters))
          << la << ", " << lo;
      EXPECT_EQ(cached->leaf, plain->leaf);
      EXPECT_EQ(cached->leafErrorMeters, plain->leafErrorMeters);
      EXPECT_EQ(cached->leafMeasuredErrorMeters, plain->leafMeasuredErrorMeters);
      EXPECT_EQ(cached->leafSources, plain->leafSources);
    }
  }
  // Each point looks at up to nine leaves; neighbours share most of them.
  EXPECT_GT(cache.decodedLeaves(), 40u);
  EXPECT_LT(cache.decodedLeaves(), static_cast<std::size_t>(points) * 2);
  const auto bad = surfaceHeightAt(view, 91.0, 0.0, cache);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::InvalidArgument);
}

TEST(SurfaceQuery, RejectsOutOfRangePositions) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok());
  for (const auto& [lat, lon] : {std::pair{91.0, 0.0}, {0.0, 400.0}, {NAN, 0.0}}) {
    const auto h = surfaceHeightAt((*dataset)->view(), lat, lon);
    ASSERT_FALSE(h.ok());
    EXPECT_EQ(h.error().code, ErrorCode::InvalidArgument);
  }
}

}  // namespace
}  // namespace pbdam::runtime
