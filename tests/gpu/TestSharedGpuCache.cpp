// One GpuCache shared by several TerrainRenderers (pbdam serve's render contexts), on lavapipe
// with the validation layer: what one renderer uploads the other draws without uploading it
// again; renderers drawing at the same time from their own threads under a budget too small for
// their cuts together still give the exact frames (byte-identical to a private cache's), never
// exceed the budget and leave nothing pinned; two frames in flight at once while the cache evicts
// (and one renderer resizes, retiring its target to deferred destruction) give no validation
// message; and the misuse cases are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <latch>
#include <string>
#include <thread>
#include <vector>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/streaming/DecodeScheduler.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kSharedCacheWidth = 320;
constexpr std::uint32_t kSharedCacheHeight = 240;

class SharedGpuCacheTest : public test::GpuTest {
 protected:
  Result<TerrainRenderer> makeRenderer(const DatasetView& view, std::shared_ptr<GpuCache> cache) {
    TerrainRendererOptions options;
    options.widthPixels = kSharedCacheWidth;
    options.heightPixels = kSharedCacheHeight;
    options.sharedCache = std::move(cache);
    options.warnWhenBudgetExceeded = false;
    return TerrainRenderer::create(context(), view, options);
  }

  std::shared_ptr<GpuCache> makeCache(const DatasetView& view, std::uint64_t budgetBytes) {
    GpuCacheOptions options;
    options.budgetBytes = budgetBytes;
    auto cache = GpuCache::create(context(), view, options);
    EXPECT_TRUE(cache.ok()) << (cache.ok() ? "" : cache.error().message);
    return cache.ok() ? std::move(cache).value() : nullptr;
  }

  /// Slot bytes a cut needs resident.
  std::uint64_t bytesOf(const DatasetView& view, const Cut& cut) {
    const std::uint64_t patchSlot =
        std::uint64_t{sizeof(streaming::PatchGpuVertex)} * view.maxPatchVertices() +
        std::uint64_t{6} * view.maxPatchTriangles();
    // The minimum holds one patch and two tiles (a patch's own and its parent's, texture morph).
    const std::uint64_t tileSlot = (GpuCache::minimumBytes(context(), view) - patchSlot) / 2;
    return cut.patches.size() * patchSlot + cut.tiles.size() * tileSlot;
  }
};

TEST_F(SharedGpuCacheTest, WhatOneRendererUploadsTheOtherDraws) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const auto cache = makeCache(view, std::uint64_t{128} << 20);
  ASSERT_NE(cache, nullptr);
  auto a = makeRenderer(view, cache);
  ASSERT_TRUE(a.ok()) << a.error().message;
  auto b = makeRenderer(view, cache);
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(a->cache(), b->cache());

  const Camera camera = test::cameraAt(view, {10.0, 230.0, 2.5e6, 0.0, -70.0, 0.0},
                                       kSharedCacheWidth, kSharedCacheHeight);
  const Cut cut = refine(view, camera, RefinementOptions{});
  const std::uint64_t entries = cut.patches.size() + cut.tiles.size();
  auto first = a->render(cut, camera);
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(first->stats.misses, entries);
  auto second = b->render(cut, camera);
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(second->stats.misses, 0u);
  EXPECT_EQ(second->stats.hits, entries);
  EXPECT_EQ(second->stats.bytesUploaded, 0u);
  EXPECT_EQ(second->image.rgba, first->image.rgba);

  const GpuCacheStats stats = cache->stats();
  EXPECT_EQ(stats.residentBytes, bytesOf(view, cut));  // once, not once per renderer
  EXPECT_EQ(stats.residentPatches, cut.patches.size());
  EXPECT_EQ(stats.residentTiles, cut.tiles.size());
  EXPECT_EQ(stats.pinnedBytes, 0u);
  EXPECT_EQ(a->residentBytes(), stats.residentBytes);
}

TEST_F(SharedGpuCacheTest, ConcurrentRenderersDrawExactFramesWithinTheBudget) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const double r = view.planet().equatorialRadiusMeters();
  // Three renderers, each with its own flight of views around the planet.
  const std::vector<std::vector<CameraPose>> flights = {
      {{0.0, 0.0, 0.8 * r, 0.0, -90.0, 0.0},
       {20.0, 60.0, 0.4 * r, 30.0, -60.0, 0.0},
       {-30.0, 140.0, 0.6 * r, 0.0, -80.0, 0.0}},
      {{0.0, 180.0, 0.8 * r, 0.0, -90.0, 0.0},
       {60.0, 250.0, 0.3 * r, 90.0, -50.0, 0.0},
       {10.0, 230.0, 0.7 * r, 0.0, -70.0, 0.0}},
      {{90.0, 0.0, 0.7 * r, 0.0, -90.0, 0.0},
       {-60.0, 300.0, 0.4 * r, 200.0, -45.0, 0.0},
       {-90.0, 0.0, 0.7 * r, 0.0, -90.0, 0.0}},
  };
  std::vector<std::vector<Camera>> cameras(flights.size());
  std::vector<std::vector<Cut>> cuts(flights.size());
  std::uint64_t largest = 0;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    for (const CameraPose& pose : flights[t]) {
      cameras[t].push_back(test::cameraAt(view, pose, kSharedCacheWidth, kSharedCacheHeight));
      cuts[t].push_back(refine(view, cameras[t].back(), RefinementOptions{}));
      largest = std::max(largest, bytesOf(view, cuts[t].back()));
    }
  }
  // The reference frames, from a renderer with a private cache large enough for everything.
  std::vector<std::vector<std::vector<std::uint8_t>>> expected(flights.size());
  {
    TerrainRendererOptions options;
    options.widthPixels = kSharedCacheWidth;
    options.heightPixels = kSharedCacheHeight;
    options.gpuCacheBytes = std::uint64_t{256} << 20;
    auto reference = TerrainRenderer::create(context(), view, options);
    ASSERT_TRUE(reference.ok()) << reference.error().message;
    for (std::size_t t = 0; t < flights.size(); ++t) {
      for (std::size_t i = 0; i < cuts[t].size(); ++i) {
        auto frame = reference->render(cuts[t][i], cameras[t][i]);
        ASSERT_TRUE(frame.ok()) << frame.error().message;
        expected[t].push_back(std::move(frame->image.rgba));
      }
    }
  }

  // Room for about one and a half cuts: the renderers evict each other's entries, and a
  // pass often has to wait for another renderer's pinned entries.
  const std::uint64_t budget = largest + largest / 2;
  const auto cache = makeCache(view, budget);
  ASSERT_NE(cache, nullptr);
  std::vector<TerrainRenderer> renderers;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    auto renderer = makeRenderer(view, cache);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    renderers.push_back(std::move(*renderer));
  }
  constexpr int kRounds = 2;
  std::vector<std::string> failures(flights.size());
  std::vector<std::uint64_t> evictions(flights.size(), 0);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    threads.emplace_back([&, t] {
      for (int round = 0; round < kRounds; ++round) {
        for (std::size_t i = 0; i < cuts[t].size(); ++i) {
          auto frame = renderers[t].render(cuts[t][i], cameras[t][i]);
          if (!frame) {
            failures[t] += "renderer " + std::to_string(t) + " frame " + std::to_string(i) + ": " +
                           frame.error().message + "\n";
            continue;
          }
          evictions[t] += frame->stats.evictions;
          if (frame->stats.peakResidentBytes > budget) {
            failures[t] += "renderer " + std::to_string(t) + " frame " + std::to_string(i) +
                           " saw " + std::to_string(frame->stats.peakResidentBytes) +
                           " bytes resident over a budget of " + std::to_string(budget) + "\n";
          }
          if (frame->image.rgba != expected[t][i]) {
            failures[t] += "renderer " + std::to_string(t) + " frame " + std::to_string(i) +
                           " round " + std::to_string(round) +
                           " differs from the private cache's frame\n";
          }
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const std::string& failure : failures) EXPECT_TRUE(failure.empty()) << failure;
  const GpuCacheStats stats = cache->stats();
  EXPECT_LE(stats.residentBytes, budget);
  EXPECT_EQ(stats.pinnedBytes, 0u);
  std::uint64_t totalEvictions = 0;
  for (const std::uint64_t e : evictions) totalEvictions += e;
  EXPECT_GT(totalEvictions, 0u) << "the budget was meant to be contended";
  RecordProperty("evictions", std::to_string(totalEvictions));
  RecordProperty("waits_for_room", std::to_string(stats.waits));
}

TEST_F(SharedGpuCacheTest, TwoFramesInFlightWhileTheCacheEvicts) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const double r = view.planet().equatorialRadiusMeters();
  const std::vector<std::vector<CameraPose>> flights = {
      {{0.0, 0.0, 0.6 * r, 0.0, -90.0, 0.0}, {30.0, 90.0, 0.5 * r, 0.0, -70.0, 0.0}},
      {{0.0, 180.0, 0.6 * r, 0.0, -90.0, 0.0}, {-30.0, 270.0, 0.5 * r, 0.0, -70.0, 0.0}},
  };
  std::vector<std::vector<Camera>> cameras(flights.size());
  std::vector<std::vector<Cut>> cuts(flights.size());
  std::uint64_t largest = 0;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    for (const CameraPose& pose : flights[t]) {
      cameras[t].push_back(test::cameraAt(view, pose, kSharedCacheWidth, kSharedCacheHeight));
      cuts[t].push_back(refine(view, cameras[t].back(), RefinementOptions{}));
      largest = std::max(largest, bytesOf(view, cuts[t].back()));
    }
  }
  // Reference frames drawn one at a time by one renderer with room for everything.
  std::vector<std::vector<std::vector<std::uint8_t>>> expected(flights.size());
  {
    auto reference = makeRenderer(view, makeCache(view, std::uint64_t{256} << 20));
    ASSERT_TRUE(reference.ok()) << reference.error().message;
    for (std::size_t t = 0; t < flights.size(); ++t) {
      for (std::size_t i = 0; i < cuts[t].size(); ++i) {
        auto frame = reference->render(cuts[t][i], cameras[t][i]);
        ASSERT_TRUE(frame.ok()) << frame.error().message;
        expected[t].push_back(std::move(frame->image.rgba));
      }
    }
  }
  // Room for about one and a quarter cuts: the two renderers' frames evict each other's.
  const auto cache = makeCache(view, largest + largest / 4);
  ASSERT_NE(cache, nullptr);
  std::vector<TerrainRenderer> renderers;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    auto renderer = makeRenderer(view, cache);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    renderers.push_back(std::move(*renderer));
  }
  constexpr int kRounds = 3;
  std::atomic<int> inFlight{0};
  std::atomic<int> mostInFlight{0};
  std::vector<std::string> failures(flights.size());
  std::vector<std::uint64_t> evictions(flights.size(), 0);
  std::latch start(static_cast<std::ptrdiff_t>(flights.size()));
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < flights.size(); ++t) {
    threads.emplace_back([&, t] {
      start.arrive_and_wait();
      for (int round = 0; round < kRounds; ++round) {
        if (t == 1 && round == 1) {
          // A resize retires the old target while the other renderer's frame is in flight.
          if (!renderers[t].resize(kSharedCacheWidth / 2, kSharedCacheHeight / 2) ||
              !renderers[t].resize(kSharedCacheWidth, kSharedCacheHeight)) {
            failures[t] += "resize failed\n";
          }
        }
        for (std::size_t i = 0; i < cuts[t].size(); ++i) {
          const int now = ++inFlight;
          int most = mostInFlight.load();
          while (now > most && !mostInFlight.compare_exchange_weak(most, now)) {
          }
          auto frame = renderers[t].render(cuts[t][i], cameras[t][i]);
          --inFlight;
          if (!frame) {
            failures[t] += "frame " + std::to_string(i) + ": " + frame.error().message + "\n";
            continue;
          }
          evictions[t] += frame->stats.evictions;
          if (frame->image.rgba != expected[t][i]) {
            failures[t] += "renderer " + std::to_string(t) + " frame " + std::to_string(i) +
                           " round " + std::to_string(round) + " differs from the reference\n";
          }
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (const std::string& failure : failures) EXPECT_TRUE(failure.empty()) << failure;
  EXPECT_GE(mostInFlight.load(), 2) << "the two renderers never had frames in flight together";
  EXPECT_GT(evictions[0] + evictions[1], 0u) << "the budget was meant to make the cache evict";
  EXPECT_EQ(cache->stats().pinnedBytes, 0u);
  // Validation messages (none allowed) are checked by the fixture's TearDown.
}

TEST_F(SharedGpuCacheTest, RedrawLastRefusesWhenAnotherRendererEvictedItsEntries) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const Camera ca =
      test::cameraAt(view, {0.0, 0.0, 3e6, 0.0, -90.0, 0.0}, kSharedCacheWidth, kSharedCacheHeight);
  const Camera cb = test::cameraAt(view, {0.0, 180.0, 3e6, 0.0, -90.0, 0.0}, kSharedCacheWidth,
                                   kSharedCacheHeight);
  const Cut cutA = refine(view, ca, RefinementOptions{});
  const Cut cutB = refine(view, cb, RefinementOptions{});
  const auto cache = makeCache(view, std::max(bytesOf(view, cutA), bytesOf(view, cutB)));
  ASSERT_NE(cache, nullptr);
  auto a = makeRenderer(view, cache);
  ASSERT_TRUE(a.ok()) << a.error().message;
  auto b = makeRenderer(view, cache);
  ASSERT_TRUE(b.ok()) << b.error().message;

  auto frameA = a->render(cutA, ca);
  ASSERT_TRUE(frameA.ok()) << frameA.error().message;
  auto redrawn = a->redrawLast();  // nothing evicted yet: the same bytes
  ASSERT_TRUE(redrawn.ok()) << redrawn.error().message;
  EXPECT_EQ(redrawn->image.rgba, frameA->image.rgba);

  auto frameB = b->render(cutB, cb);  // evicts A's entries
  ASSERT_TRUE(frameB.ok()) << frameB.error().message;
  ASSERT_GT(frameB->stats.evictions, 0u);
  redrawn = a->redrawLast();
  ASSERT_FALSE(redrawn.ok());
  EXPECT_EQ(redrawn.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(redrawn.error().message.find("evicted"), std::string::npos) << redrawn.error().message;
  EXPECT_EQ(cache->stats().pinnedBytes, 0u);
}

TEST_F(SharedGpuCacheTest, RejectsACacheOfAnotherDatasetAndABudgetBelowTheMinimum) {
  PBDAM_REQUIRE_DATASET(mola, "mola");
  PBDAM_REQUIRE_DATASET(earth, "earth");
  const auto mars = test::openDataset(mola);
  const auto globe = test::openDataset(earth);
  ASSERT_NE(mars, nullptr);
  ASSERT_NE(globe, nullptr);
  const auto cache = makeCache(mars->view(), std::uint64_t{16} << 20);
  ASSERT_NE(cache, nullptr);
  auto renderer = makeRenderer(globe->view(), cache);
  ASSERT_FALSE(renderer.ok());
  EXPECT_EQ(renderer.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(renderer.error().message.find("another"), std::string::npos)
      << renderer.error().message;

  GpuCacheOptions tiny;
  tiny.budgetBytes = GpuCache::minimumBytes(context(), mars->view()) - 1;
  auto refused = GpuCache::create(context(), mars->view(), tiny);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("below the minimum"), std::string::npos)
      << refused.error().message;
}

}  // namespace
}  // namespace pbdam::gpu
