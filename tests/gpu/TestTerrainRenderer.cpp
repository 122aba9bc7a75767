// TerrainRenderer on lavapipe with the validation layer: crack-free frames of real datasets
// (no background pixel inside the planet's silhouette, from orbit to low oblique views, across
// face edges, cube corners and poles), exact-mode determinism, the over-budget multi-pass
// fallback (same image, budget never exceeded), the LRU across frames, redrawing the last frame
// from what is resident, and errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numbers>
#include <random>
#include <span>
#include <vector>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/streaming/DecodeScheduler.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kWidth = 640;
constexpr std::uint32_t kHeight = 360;
constexpr double kCubeCornerLatDegrees = 35.26438968275465;  // atan(1/√2)

FrameSettings magentaBackground() {
  FrameSettings settings;
  settings.clearRgb = test::kMagentaRgb;
  return settings;
}

/// ≥ 20 cameras: far orbit to low altitude, straight down and oblique, over face edges, cube
/// corners (±1,±1,±1)/√3 and both poles. `low` is the lowest camera altitude, chosen above the
/// planet's highest terrain (a camera inside the terrain sees back faces, which are culled).
std::vector<CameraPose> crackTestCameras(double radius, double low) {
  const double c = kCubeCornerLatDegrees;
  return {
      {0.0, 0.0, 2.0 * radius, 0.0, -90.0, 0.0},         // whole planet
      {0.0, 180.0, 2.0 * radius, 0.0, -90.0, 0.0},       //
      {90.0, 0.0, 1.5 * radius, 0.0, -90.0, 0.0},        // north pole from orbit
      {-90.0, 0.0, 1.5 * radius, 0.0, -90.0, 0.0},       // south pole from orbit
      {c, 45.0, radius, 0.0, -90.0, 0.0},                // cube corners
      {-c, 135.0, radius, 0.0, -90.0, 0.0},              //
      {c, -135.0, 0.8 * radius, 0.0, -90.0, 0.0},        //
      {-c, -45.0, 0.5 * radius, 0.0, -90.0, 0.0},        //
      {0.0, 45.0, 0.3 * radius, 0.0, -90.0, 0.0},        // face edges
      {45.0, 0.0, 0.3 * radius, 0.0, -90.0, 0.0},        //
      {-45.0, 90.0, 0.1 * radius, 30.0, -45.0, 0.0},     //
      {0.0, 135.0, radius, 0.0, -60.0, 0.0},             // oblique from far
      {c, 45.0, 6.0 * low, 10.0, -20.0, 0.0},            // low and oblique at a corner
      {-c, -135.0, low, 225.0, -6.0, 0.0},               // low, looking at the horizon
      {0.0, 45.0, 3.0 * low, 90.0, -10.0, 0.0},          // across a face edge
      {0.0, -45.0, 2.0 * low, 0.0, -15.0, 0.0},          // along a face edge
      {89.5, 0.0, 10.0 * low, 0.0, -15.0, 0.0},          // towards the north pole
      {-89.5, 30.0, 10.0 * low, 180.0, -15.0, 0.0},      // towards the south pole
      {90.0, 0.0, 0.05 * radius, 0.0, -90.0, 0.0},       // straight over the pole
      {-90.0, 0.0, 4.0 * low, 70.0, -35.0, 0.0},         // at the south pole, oblique
      {45.0, 45.0, 0.06 * radius, 45.0, -30.0, 0.0},     //
      {10.0, -100.0, 0.025 * radius, 0.0, -25.0, 20.0},  // rolled
      {-60.0, 170.0, 2.0 * low, 300.0, -12.0, 0.0},      //
      {c, 135.0, 1.5 * low, 0.0, -70.0, -10.0},          // corner, steep, rolled
  };
}

/// `crackTestCameras` and random ones up to `count` in all: anywhere, from `low` to two radii
/// up (log-uniform), any heading, pitch from straight down to 5° below the horizon.
std::vector<CameraPose> crackAndRandomCameras(double radius, double low, std::size_t count) {
  std::vector<CameraPose> poses = crackTestCameras(radius, low);
  std::mt19937_64 rng(2027);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  while (poses.size() < count) {
    const double lat = std::asin(2.0 * unit(rng) - 1.0) * 180.0 / std::numbers::pi;
    const double alt = low * std::pow(2.0 * radius / low, unit(rng));
    poses.push_back(
        {lat, 360.0 * unit(rng) - 180.0, alt, 360.0 * unit(rng), -90.0 + 85.0 * unit(rng), 0.0});
  }
  return poses;
}

// ≥ 100 cameras a planet, each with five morph ranges; sanitizer builds check fewer.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr std::size_t kHoleCameras = 24;
#else
constexpr std::size_t kHoleCameras = 100;
#endif
constexpr std::array<double, 5> kMorphRanges = {0.0, 0.05, 0.1, 0.175, 0.25};

class TerrainRendererTest : public test::GpuTest {
 protected:
  Result<TerrainRenderer> makeRenderer(const DatasetView& view, std::uint64_t budgetBytes,
                                       bool forceRgba8 = false, double exaggeration = 1.0) {
    TerrainRendererOptions options;
    options.exaggeration = exaggeration;
    options.widthPixels = kWidth;
    options.heightPixels = kHeight;
    options.gpuCacheBytes = budgetBytes;
    options.forceRgba8Textures = forceRgba8;
    options.warnWhenBudgetExceeded = false;
    return TerrainRenderer::create(context(), view, options);
  }

  void expectNoHoles(const std::filesystem::path& dir, double lowAltitude,
                     std::vector<CameraPose> poses = {}, double exaggeration = 1.0) {
    const auto dataset = test::openDataset(dir);
    ASSERT_NE(dataset, nullptr);
    const DatasetView& view = dataset->view();
    auto renderer = makeRenderer(view, std::uint64_t{256} << 20, false, exaggeration);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    if (poses.empty()) {
      poses =
          crackAndRandomCameras(view.planet().equatorialRadiusMeters(), lowAltitude, kHoleCameras);
    }
    ASSERT_GE(poses.size(), 20u);
    std::uint64_t inside = 0;
    for (std::size_t k = 0; k < poses.size() * kMorphRanges.size(); ++k) {
      const CameraPose& pose = poses[k / kMorphRanges.size()];
      const double morphRange = kMorphRanges[k % kMorphRanges.size()];
      SCOPED_TRACE(test::describe(pose) + " morph range " + std::to_string(morphRange));
      const Camera camera = test::cameraAt(view, pose, kWidth, kHeight);
      RefinementOptions options;
      options.morphRange = morphRange;
      options.exaggeration = exaggeration;
      const Cut cut = refine(view, camera, options);
      ASSERT_FALSE(cut.patches.empty());
      double maxError = 0.0;
      for (const CutPatch& p : cut.patches) {
        maxError = std::max(maxError, static_cast<double>(view.node(p.node).errorMeters));
      }
      // Exaggerated, the lowest terrain and the errors scale by F too.
      const double radius = view.planet().polarRadiusMeters() +
                            exaggeration * (view.manifest().minHeightMeters - maxError) - 1.0;
      auto frame = renderer->render(cut, camera, magentaBackground());
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      EXPECT_FALSE(frame->stats.budgetExceeded);
      const test::SilhouetteCheck check =
          test::holesInsideSphere(frame->image, camera, radius, test::kMagentaRgb);
      EXPECT_EQ(check.holes, 0u) << check.holes << " background pixels of " << check.inside
                                 << " inside the silhouette, the first at (" << check.firstHoleX
                                 << ", " << check.firstHoleY << "); " << cut.patches.size()
                                 << " patches, sphere radius " << radius;
      inside += check.inside;
    }
    // The check looked at a good share of all pixels.
    EXPECT_GT(inside, std::uint64_t{kWidth} * kHeight * poses.size() * kMorphRanges.size() / 4);
  }
};

TEST_F(TerrainRendererTest, NoBackgroundInsideTheSilhouetteOfMars) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectNoHoles(dir, 25000.0);  // above Olympus Mons (21.3 km)
}

// Five-fold heights: Olympus Mons stands 106 km high. The crack-test cameras above it, and
// cameras low over its flank looking at it: no background inside the silhouette.
TEST_F(TerrainRendererTest, NoBackgroundInsideTheSilhouetteOfFiveFoldMars) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  std::vector<CameraPose> poses = crackTestCameras(3396190.0, 5.0 * 25000.0);
  for (const double pitch : {-5.0, -20.0, -45.0}) {
    poses.push_back({15.4, -133.8, 160000.0, 0.0, pitch, 0.0});
  }
  poses.push_back({18.65, -128.0, 150000.0, 270.0, -10.0, 0.0});  // from the east
  expectNoHoles(dir, 0.0, poses, 5.0);
}

// The shared cache holds patches decoded under one exaggeration: a renderer of another is refused.
TEST_F(TerrainRendererTest, ASharedCacheOfAnotherExaggerationIsRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  GpuCacheOptions cacheOptions;
  cacheOptions.exaggeration = 2.0;
  auto cache = GpuCache::create(context(), dataset->view(), cacheOptions);
  ASSERT_TRUE(cache.ok()) << cache.error().message;
  TerrainRendererOptions options;
  options.widthPixels = 64;
  options.heightPixels = 64;
  options.sharedCache = *cache;
  options.exaggeration = 3.0;
  auto refused = TerrainRenderer::create(context(), dataset->view(), options);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("exaggeration"), std::string::npos);
  options.exaggeration = 2.0;
  EXPECT_TRUE(TerrainRenderer::create(context(), dataset->view(), options).ok());
}

TEST_F(TerrainRendererTest, NoBackgroundInsideTheSilhouetteOfEarth) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  expectNoHoles(dir, 10000.0);  // above Everest
}

// Oblique frames across the Luxembourg inset's border, where leaves of level 20 meet the
// base's: no background shows through.
TEST_F(TerrainRendererTest, NoBackgroundAcrossAnInsetsBorder) {
  PBDAM_REQUIRE_DATASET(dir, "luxembourg");
  std::vector<CameraPose> poses;
  for (int k = 0; k < 24; ++k) {
    const double t = static_cast<double>(k) / 24.0;
    // Around the country (49.45–50.18°N, 5.73–6.53°E), looking inwards and outwards.
    poses.push_back({49.8 + 0.6 * std::sin(6.283185307 * t), 6.1 + 0.7 * std::cos(6.283185307 * t),
                     2000.0 * std::pow(100.0, static_cast<double>(k % 4) / 3.0),
                     360.0 * t + (k % 2 == 0 ? 0.0 : 180.0), -8.0 - 10.0 * (k % 3), 0.0});
  }
  expectNoHoles(dir, 10000.0, poses);
}

TEST_F(TerrainRendererTest, TheSilhouetteCheckFindsAMissingPatch) {
  // The crack tests are only as good as their hole detector: drop the patch nearest the view
  // centre from a cut and the background must show through (back faces are culled).
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera = test::cameraAt(view, {10.0, 20.0, 7e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  Cut cut = refine(view, camera, RefinementOptions{});
  double maxError = 0.0;
  std::size_t nearest = 0;
  double nearestDistance = 1e300;
  for (std::size_t i = 0; i < cut.patches.size(); ++i) {
    const NodeRecord n = view.node(cut.patches[i].node);
    maxError = std::max(maxError, static_cast<double>(n.errorMeters));
    const glm::dvec3 centre(n.sphereCenter[0], n.sphereCenter[1], n.sphereCenter[2]);
    const double d = glm::length(glm::cross(centre - camera.position(), camera.forward()));
    if (d < nearestDistance) {
      nearestDistance = d;
      nearest = i;
    }
  }
  cut.patches.erase(cut.patches.begin() + static_cast<std::ptrdiff_t>(nearest));
  auto renderer = makeRenderer(view, std::uint64_t{64} << 20);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  auto frame = renderer->render(cut, camera, magentaBackground());
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const double radius =
      view.planet().polarRadiusMeters() + view.manifest().minHeightMeters - maxError - 1.0;
  const test::SilhouetteCheck check =
      test::holesInsideSphere(frame->image, camera, radius, test::kMagentaRgb);
  EXPECT_GT(check.holes, 20u) << "of " << check.inside << " pixels inside";
}

TEST_F(TerrainRendererTest, TheSameCameraGivesTheSameBytes) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera =
      test::cameraAt(view, {kCubeCornerLatDegrees, 45.0, 3e5, 20.0, -40.0, 0.0}, kWidth, kHeight);
  const Cut cut = refine(view, camera, RefinementOptions{});
  auto renderer = makeRenderer(view, std::uint64_t{256} << 20);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  auto first = renderer->render(cut, camera);
  ASSERT_TRUE(first.ok()) << first.error().message;
  auto second = renderer->render(cut, camera);  // from the cache this time
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(first->image.rgba, second->image.rgba);
  // A fresh renderer (other slots, other upload order) draws the same bytes too.
  auto fresh = makeRenderer(view, std::uint64_t{64} << 20);
  ASSERT_TRUE(fresh.ok()) << fresh.error().message;
  auto third = fresh->render(refine(view, camera, RefinementOptions{}), camera);
  ASSERT_TRUE(third.ok()) << third.error().message;
  EXPECT_EQ(first->image.rgba, third->image.rgba);
  // The image is not trivially uniform: terrain was drawn.
  const auto [lo, hi] = std::minmax_element(first->image.rgba.begin(), first->image.rgba.end());
  EXPECT_LT(*lo + 100, *hi);
}

TEST_F(TerrainRendererTest, AnOverBudgetCutIsDrawnInPassesWithTheSameImage) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera = test::cameraAt(view, {20.0, -60.0, 4e6, 0.0, -80.0, 0.0}, kWidth, kHeight);
  const Cut cut = refine(view, camera, RefinementOptions{});
  auto large = makeRenderer(view, std::uint64_t{256} << 20);
  ASSERT_TRUE(large.ok()) << large.error().message;
  auto reference = large->render(cut, camera, magentaBackground());
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  EXPECT_FALSE(reference->stats.budgetExceeded);
  EXPECT_EQ(reference->stats.passes, 1u);

  // Budgets of a half and a fifth of what the one-pass frame kept resident.
  const std::uint64_t needed = reference->stats.peakResidentBytes;
  for (const std::uint64_t budget : {needed / 2, needed / 5}) {
    SCOPED_TRACE(budget);
    auto small = makeRenderer(view, budget);
    ASSERT_TRUE(small.ok()) << small.error().message;
    for (int repeat = 0; repeat < 2; ++repeat) {
      auto frame = small->render(cut, camera, magentaBackground());
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      EXPECT_TRUE(frame->stats.budgetExceeded);
      EXPECT_GT(frame->stats.passes, 1u);
      EXPECT_LE(frame->stats.peakResidentBytes, budget);
      EXPECT_LE(frame->stats.residentBytes, budget);
      EXPECT_LE(frame->stats.poolBytes, 2 * budget);
      EXPECT_GT(frame->stats.evictions, 0u);
      EXPECT_EQ(frame->stats.patches, cut.patches.size());
      EXPECT_TRUE(frame->image.rgba == reference->image.rgba)
          << "the multi-pass image differs from the one-pass image";
    }
  }
}

// The smallest budget holds one patch slot and two tile slots (its tile and its parent's): each
// pass draws one patch, or two or three that share a tile where a tile slot (colour and normal
// map) outweighs a patch slot, as on MOLA; the passes give the one-pass image.
TEST_F(TerrainRendererTest, TheSmallestBudgetDrawsAFewPatchesAPass) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera = test::cameraAt(view, {-30.0, 100.0, 5e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  RefinementOptions coarse;
  coarse.maxLevel = 3;
  const Cut cut = refine(view, camera, coarse);
  ASSERT_GT(cut.patches.size(), 4u);
  const std::uint64_t minimum = TerrainRenderer::minimumCacheBytes(context(), view);

  auto tooSmall = makeRenderer(view, minimum - 1);
  ASSERT_FALSE(tooSmall.ok());
  EXPECT_EQ(tooSmall.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(tooSmall.error().message.find("GPU cache budget of " + std::to_string(minimum - 1)),
            std::string::npos)
      << tooSmall.error().message;
  EXPECT_NE(tooSmall.error().message.find("minimum of " + std::to_string(minimum)),
            std::string::npos)
      << tooSmall.error().message;

  auto large = makeRenderer(view, std::uint64_t{256} << 20);
  ASSERT_TRUE(large.ok()) << large.error().message;
  auto reference = large->render(cut, camera, magentaBackground());
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  auto smallest = makeRenderer(view, minimum);
  ASSERT_TRUE(smallest.ok()) << smallest.error().message;
  auto frame = smallest->render(cut, camera, magentaBackground());
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  EXPECT_LE(frame->stats.passes, cut.patches.size());
  EXPECT_GE(3 * frame->stats.passes, cut.patches.size());
  EXPECT_LE(frame->stats.peakResidentBytes, minimum);
  EXPECT_TRUE(frame->image.rgba == reference->image.rgba);
}

TEST_F(TerrainRendererTest, TheCacheHitsOnRepeatAndEvictsWhenTheViewMoves) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera a = test::cameraAt(view, {0.0, 0.0, 3e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  const Camera b = test::cameraAt(view, {0.0, 180.0, 3e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  const Cut cutA = refine(view, a, RefinementOptions{});
  const Cut cutB = refine(view, b, RefinementOptions{});
  const std::uint64_t patchSlot =
      std::uint64_t{sizeof(streaming::PatchGpuVertex)} * view.maxPatchVertices() +
      std::uint64_t{6} * view.maxPatchTriangles();
  // The minimum holds one patch and two tiles (a patch's own and its parent's, texture morph).
  const std::uint64_t tileSlot =
      (TerrainRenderer::minimumCacheBytes(context(), view) - patchSlot) / 2;
  const auto bytesOf = [&](const Cut& cut) {
    return cut.patches.size() * patchSlot + cut.tiles.size() * tileSlot;
  };
  // Room for either cut, not for both.
  const std::uint64_t budget = std::max(bytesOf(cutA), bytesOf(cutB)) + patchSlot;
  ASSERT_LT(budget, bytesOf(cutA) + bytesOf(cutB));
  auto renderer = makeRenderer(view, budget);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;

  auto first = renderer->render(cutA, a);
  ASSERT_TRUE(first.ok()) << first.error().message;
  const std::uint64_t entriesA = cutA.patches.size() + cutA.tiles.size();
  EXPECT_EQ(first->stats.hits, 0u);
  EXPECT_EQ(first->stats.misses, entriesA);
  EXPECT_EQ(first->stats.evictions, 0u);
  EXPECT_EQ(first->stats.residentBytes, bytesOf(cutA));
  EXPECT_GT(first->stats.bytesUploaded, 0u);
  EXPECT_FALSE(first->stats.budgetExceeded);

  auto again = renderer->render(cutA, a);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->stats.hits, entriesA);
  EXPECT_EQ(again->stats.misses, 0u);
  EXPECT_EQ(again->stats.evictions, 0u);
  EXPECT_EQ(again->stats.bytesUploaded, 0u);
  EXPECT_EQ(again->image.rgba, first->image.rgba);

  auto moved = renderer->render(cutB, b);
  ASSERT_TRUE(moved.ok()) << moved.error().message;
  EXPECT_FALSE(moved->stats.budgetExceeded);
  EXPECT_GT(moved->stats.misses, 0u);
  EXPECT_GT(moved->stats.evictions, 0u);
  EXPECT_LE(moved->stats.peakResidentBytes, budget);
  EXPECT_LE(renderer->residentBytes(), budget);

  auto back = renderer->render(cutA, a);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_GT(back->stats.misses, 0u);  // some of A were evicted for B
  EXPECT_EQ(back->image.rgba, first->image.rgba);
}

TEST_F(TerrainRendererTest, Rgba8TilesLookLikeBc1Tiles) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera = test::cameraAt(view, {30.0, 10.0, 5e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  const Cut cut = refine(view, camera, RefinementOptions{});
  auto bc1 = makeRenderer(view, std::uint64_t{256} << 20);
  ASSERT_TRUE(bc1.ok()) << bc1.error().message;
  auto rgba8 = makeRenderer(view, std::uint64_t{256} << 20, true);
  ASSERT_TRUE(rgba8.ok()) << rgba8.error().message;
  EXPECT_EQ(bc1->usesBc1Textures(), context().caps().textureCompressionBC);
  EXPECT_FALSE(rgba8->usesBc1Textures());
  auto a = bc1->render(cut, camera);
  auto b = rgba8->render(cut, camera);
  ASSERT_TRUE(a.ok() && b.ok());
  // Two BC1 decoders (the device's, libsquish's) may round the interpolated colours differently.
  int maxDiff = 0;
  double sumDiff = 0.0;
  for (std::size_t i = 0; i < a->image.rgba.size(); ++i) {
    const int d = std::abs(int{a->image.rgba[i]} - int{b->image.rgba[i]});
    maxDiff = std::max(maxDiff, d);
    sumDiff += d;
  }
  EXPECT_LE(maxDiff, 4);
  EXPECT_LT(sumDiff / static_cast<double>(a->image.rgba.size()), 0.5);
}

TEST_F(TerrainRendererTest, RedrawLastDrawsTheSameBytesFromWhatIsResident) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera =
      test::cameraAt(view, {-15.0, -68.0, 90e3, 15.0, -30.0, 0.0}, kWidth, kHeight);
  const Cut cut = refine(view, camera, RefinementOptions{});
  auto renderer = makeRenderer(view, std::uint64_t{256} << 20);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;

  auto before = renderer->redrawLast();
  ASSERT_FALSE(before.ok());
  EXPECT_EQ(before.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(before.error().message.find("no previous frame"), std::string::npos)
      << before.error().message;

  // The background colour and sun are part of what is redrawn.
  FrameSettings settings = magentaBackground();
  settings.ambient = 0.2f;
  auto frame = renderer->render(cut, camera, settings);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_EQ(frame->stats.passes, 1u);
  const std::uint64_t entries = cut.patches.size() + cut.tiles.size();
  for (int repeat = 0; repeat < 2; ++repeat) {
    SCOPED_TRACE(repeat);
    auto redrawn = renderer->redrawLast();
    ASSERT_TRUE(redrawn.ok()) << redrawn.error().message;
    EXPECT_TRUE(redrawn->image.rgba == frame->image.rgba)
        << "the redrawn image differs from the rendered one";
    EXPECT_EQ(redrawn->stats.patches, cut.patches.size());
    EXPECT_EQ(redrawn->stats.triangles, cut.triangles);
    EXPECT_EQ(redrawn->stats.tiles, cut.tiles.size());
    EXPECT_EQ(redrawn->stats.hits, entries);
    EXPECT_EQ(redrawn->stats.misses, 0u);
    EXPECT_EQ(redrawn->stats.bytesUploaded, 0u);
    EXPECT_EQ(redrawn->stats.decodeMs, 0.0);
    EXPECT_EQ(redrawn->stats.uploadMs, 0.0);
    EXPECT_GT(redrawn->stats.frameMs, 0.0);
    EXPECT_EQ(redrawn->stats.residentBytes, renderer->residentBytes());
  }
  // A camera and cut the first frame did not have: redrawLast follows the latest frame.
  const Camera other = test::cameraAt(view, {0.0, 0.0, 8e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  auto second = renderer->render(refine(view, other, RefinementOptions{}), other);
  ASSERT_TRUE(second.ok()) << second.error().message;
  auto redrawnSecond = renderer->redrawLast();
  ASSERT_TRUE(redrawnSecond.ok()) << redrawnSecond.error().message;
  EXPECT_TRUE(redrawnSecond->image.rgba == second->image.rgba);
  EXPECT_FALSE(redrawnSecond->image.rgba == frame->image.rgba);

  // A failed render() leaves no frame to redraw.
  const Camera wrongSize = test::cameraAt(view, {0.0, 0.0, 8e6, 0.0, -90.0, 0.0}, 320, 200);
  ASSERT_FALSE(renderer->render(refine(view, wrongSize, RefinementOptions{}), wrongSize).ok());
  auto afterFailure = renderer->redrawLast();
  ASSERT_FALSE(afterFailure.ok());
  EXPECT_EQ(afterFailure.error().code, ErrorCode::InvalidArgument);
}

TEST_F(TerrainRendererTest, RedrawLastRejectsAFrameDrawnInSeveralPasses) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera camera = test::cameraAt(view, {20.0, -60.0, 4e6, 0.0, -80.0, 0.0}, kWidth, kHeight);
  auto small = makeRenderer(view, std::uint64_t{1} << 20);
  ASSERT_TRUE(small.ok()) << small.error().message;
  auto frame = small->render(refine(view, camera, RefinementOptions{}), camera);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_GT(frame->stats.passes, 1u);
  auto redrawn = small->redrawLast();
  ASSERT_FALSE(redrawn.ok());
  EXPECT_EQ(redrawn.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(redrawn.error().message.find(std::to_string(frame->stats.passes) + " passes"),
            std::string::npos)
      << redrawn.error().message;
}

TEST_F(TerrainRendererTest, RejectsACameraOfAnotherSize) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  auto renderer = makeRenderer(view, std::uint64_t{64} << 20);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Camera camera = test::cameraAt(view, {0.0, 0.0, 8e6, 0.0, -90.0, 0.0}, 320, 200);
  auto frame = renderer->render(refine(view, camera, RefinementOptions{}), camera);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(frame.error().message.find("320x200"), std::string::npos);
}

/// The bytes of a dataset's faces in memory, so that a test can damage them.
struct DatasetInMemory {
  Manifest manifest;
  std::array<std::vector<std::byte>, 6> faces;
  Result<DatasetView> view() const {
    std::array<std::span<const std::byte>, 6> spans;
    for (std::size_t f = 0; f < 6; ++f) spans[f] = faces[f];
    return DatasetView::open(manifest, spans, "memory");
  }
};

TEST_F(TerrainRendererTest, ACorruptPatchIsAnErrorAndLeavesNothingResident) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  DatasetInMemory data;
  auto manifest = readManifest(dir);
  ASSERT_TRUE(manifest.ok()) << manifest.error().message;
  data.manifest = *manifest;
  for (std::size_t f = 0; f < 6; ++f) {
    std::ifstream in(dir / data.manifest.faces[f].file, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in),
                                  std::istreambuf_iterator<char>()};
    data.faces[f].resize(bytes.size());
    std::memcpy(data.faces[f].data(), bytes.data(), bytes.size());
  }
  auto clean = data.view();
  ASSERT_TRUE(clean.ok()) << clean.error().message;
  const Camera camera = test::cameraAt(*clean, {0.0, 0.0, 8e6, 0.0, -90.0, 0.0}, kWidth, kHeight);
  // A fine tolerance, so that the cut reaches below level 1 even from this far out.
  RefinementOptions fine;
  fine.tolerancePixels = 0.25;
  const Cut cut = refine(*clean, camera, fine);
  // Damage one byte in the middle of the blob of a patch below level 1 (the cut the renderer
  // draws afterwards stops at level 1).
  const auto below = std::find_if(cut.patches.begin(), cut.patches.end(),
                                  [](const CutPatch& p) { return p.level > 1; });
  ASSERT_NE(below, cut.patches.end());
  const CutPatch& victim = *below;
  const NodeRecord record = clean->node(victim.node);
  data.faces[victim.node.face][record.blobOffset + record.blobBytes / 2] ^= std::byte{0x5a};
  auto damaged = data.view();
  ASSERT_TRUE(damaged.ok()) << damaged.error().message;

  auto renderer = makeRenderer(*damaged, std::uint64_t{256} << 20);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  auto frame = renderer->render(cut, camera);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, ErrorCode::CorruptData);
  const std::string where = "memory/" + data.manifest.faces[victim.node.face].file + "@" +
                            std::to_string(record.blobOffset);
  EXPECT_NE(frame.error().message.find(where), std::string::npos) << frame.error().message;
  EXPECT_EQ(renderer->residentBytes(), 0u);
  // The renderer still works for a cut without the damaged patch.
  RefinementOptions coarse;
  coarse.maxLevel = 1;
  const Cut other = refine(*damaged, camera, coarse);
  for (const CutPatch& p : other.patches) ASSERT_FALSE(p.node == victim.node);
  auto ok = renderer->render(other, camera);
  EXPECT_TRUE(ok.ok()) << ok.error().message;
}

}  // namespace
}  // namespace pbdam::gpu
