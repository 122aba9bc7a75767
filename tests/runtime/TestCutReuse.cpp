// Frame-to-frame cut reuse (runtime/CutReuse.h): along the recorded Mars and Earth flights, every
// cut of the incremental refinement is the stateless refinement's cut for the same camera
// (patches in the same order, tiles, counts, screen errors), with far fewer split and cull
// decisions; so is a camera that turns on the spot, stands still, or jumps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "TestData.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::runtime {
namespace {

void expectSameCut(const Cut& a, const Cut& b, std::size_t frame) {
  ASSERT_EQ(a.patches.size(), b.patches.size()) << "frame " << frame;
  for (std::size_t k = 0; k < a.patches.size(); ++k) {
    const CutPatch& p = a.patches[k];
    const CutPatch& q = b.patches[k];
    ASSERT_TRUE(p.node == q.node && p.level == q.level && p.tile.face == q.tile.face &&
                p.tile.heap == q.tile.heap && p.screenErrorPixels == q.screenErrorPixels)
        << "frame " << frame << ", patch " << k;
  }
  ASSERT_EQ(a.tiles.size(), b.tiles.size()) << "frame " << frame;
  for (std::size_t k = 0; k < a.tiles.size(); ++k) {
    ASSERT_TRUE(a.tiles[k].face == b.tiles[k].face && a.tiles[k].heap == b.tiles[k].heap)
        << "frame " << frame;
  }
  ASSERT_EQ(a.triangles, b.triangles) << "frame " << frame;
  ASSERT_EQ(a.vertices, b.vertices) << "frame " << frame;
}

struct Totals final {
  std::uint64_t stateless = 0;
  std::uint64_t incremental = 0;
};

Totals flyAndCompare(const std::filesystem::path& datasetDir, const std::filesystem::path& path,
                     const RefinementOptions& options) {
  Totals totals;
  auto dataset = MappedDataset::open(datasetDir);
  EXPECT_TRUE(dataset) << dataset.error().message;
  auto poses = readCameraPath(path);
  EXPECT_TRUE(poses) << poses.error().message;
  if (!dataset || !poses) return totals;
  const DatasetView& view = (*dataset)->view();
  IncrementalRefiner incremental(view);
  const Viewport viewport{640, 480, 60.0};
  for (std::size_t f = 0; f < poses->size(); ++f) {
    const CameraPathPoint& p = (*poses)[f];
    const Camera camera = Camera::fromPose(view.planet(),
                                           {p.latDegrees, p.lonDegrees, p.altitudeMeters,
                                            p.headingDegrees, p.pitchDegrees, p.rollDegrees},
                                           viewport);
    const Cut expected = refine(view, camera, options);
    const Cut cut = incremental.update(camera, options);
    expectSameCut(cut, expected, f);
    if (::testing::Test::HasFatalFailure()) return totals;
    totals.stateless += expected.nodesVisited;
    totals.incremental += incremental.lastStats().decisions;
  }
  return totals;
}

/// Replays a recorded flight, prints its decision counts and expects far fewer with reuse.
void flyReplayed(const char* name, const std::filesystem::path& datasetDir, const char* pathFile,
                 const RefinementOptions& options) {
  const Totals t =
      flyAndCompare(datasetDir, std::filesystem::path(PBDAM_PATHS_DIR) / pathFile, options);
  std::printf("%s: %llu stateless decisions, %llu incremental (%.1fx fewer)\n", name,
              static_cast<unsigned long long>(t.stateless),
              static_cast<unsigned long long>(t.incremental),
              static_cast<double>(t.stateless) / static_cast<double>(t.incremental));
  EXPECT_LT(2 * t.incremental, t.stateless);
}

TEST(CutReuse, MarsFlightCutsAreTheStatelessOnesWithFewerDecisions) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  flyReplayed("Mars flight", dir, "mars_flight.csv", {});
}

TEST(CutReuse, EarthFlightCutsAreTheStatelessOnesWithFewerDecisions) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  RefinementOptions options;
  options.tolerancePixels = 2.0;
  flyReplayed("Earth flight", dir, "earth_himalayas.csv", options);
}

TEST(CutReuse, TurningStandingStillJumpingAndNewOptionsStayExact) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  IncrementalRefiner incremental(view, 5.0);
  const Viewport viewport{640, 480, 60.0};
  RefinementOptions options;
  std::size_t frame = 0;
  const auto check = [&](const CameraPose& pose) {
    const Camera camera = Camera::fromPose(view.planet(), pose, viewport);
    expectSameCut(incremental.update(camera, options), refine(view, camera, options), frame++);
  };
  // A full turn on the spot, low over Olympus Mons, looking at the horizon: 3° a frame.
  for (int k = 0; k <= 120; ++k) check({18.6, 226.2, 30000.0, 3.0 * k, -10.0, 0.0});
  // Standing still: no decision at all.
  check({18.6, 226.2, 30000.0, 0.0, -10.0, 0.0});
  check({18.6, 226.2, 30000.0, 0.0, -10.0, 0.0});
  EXPECT_EQ(incremental.lastStats().decisions, 0u);
  EXPECT_FALSE(incremental.lastStats().rebuilt);
  EXPECT_GT(incremental.lastStats().validityRadiusMeters, 0.0);
  // A jump across the planet, a roll, then another tolerance and a level cap (a rebuild).
  check({-40.0, 60.0, 200000.0, 90.0, -30.0, 0.0});
  check({-40.0, 60.0, 200000.0, 90.0, -30.0, 45.0});
  options.tolerancePixels = 1.0;
  check({-40.0, 60.0, 200000.0, 90.0, -30.0, 45.0});
  EXPECT_TRUE(incremental.lastStats().rebuilt);
  options.maxLevel = 5;
  check({-40.0, 60.0, 150000.0, 90.0, -30.0, 45.0});
  check({-40.1, 60.0, 150000.0, 91.0, -30.0, 45.0});
  options.frustumCulling = false;
  check({-40.1, 60.0, 150000.0, 91.0, -30.0, 45.0});
  options.frustumCulling = true;
  check({-40.1, 60.0, 150000.0, 91.0, -30.0, 45.0});
}

}  // namespace
}  // namespace pbdam::runtime
