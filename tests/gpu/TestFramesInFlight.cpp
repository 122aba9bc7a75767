// Frames in flight (TerrainRenderer::submit/collect), on lavapipe with the validation layer
// (synchronisation validation included): a flight over Mars drawn with 1, 2 and 3 frames in
// flight gives the bytes of render()'s frames, with the cuts of the host's refinement, of the
// refinement tree kept from frame to frame and of the no-stall policy's capped cuts, with and
// without morphing; so does a budget so small that every frame evicts what the frames before it
// drew (and a cut that takes several passes); two renderers of one shared cache, each with two
// frames in flight, give the private cache's frames; a frame submitted without readback has no
// image and the same statistics; and the misuse cases are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/streaming/NoStallPolicy.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kInFlightWidth = 320;
constexpr std::uint32_t kInFlightHeight = 240;
constexpr std::size_t kFrames = 16;

/// One frame of a flight: its camera and cut.
struct FlightFrame {
  Camera camera;
  Cut cut;
};

std::vector<CameraPose> flightPoses() { return test::tharsisDescent(kFrames); }

enum class CutKind { Fresh, Reused, NoStall };

std::vector<FlightFrame> flight(const streaming::MappedDataset& dataset, CutKind kind,
                                double morphRange) {
  const DatasetView& view = dataset.view();
  RefinementOptions options;
  options.morphRange = morphRange;
  IncrementalRefiner reused(view);
  const streaming::NoStallPolicy noStall(dataset);
  int cap = -1;
  std::vector<FlightFrame> frames;
  for (const CameraPose& pose : flightPoses()) {
    const Camera camera = test::cameraAt(view, pose, kInFlightWidth, kInFlightHeight);
    Cut cut;
    switch (kind) {
      case CutKind::Fresh:
        cut = refine(view, camera, options);
        break;
      case CutKind::Reused:
        cut = reused.update(camera, options);
        break;
      case CutKind::NoStall: {
        streaming::NoStallCut capped = noStall.cutAfter(camera, options, cap);
        cap = capped.levelCap;
        cut = std::move(capped.cut);
        break;
      }
    }
    frames.push_back({camera, std::move(cut)});
  }
  return frames;
}

FrameSettings magentaBackground() {
  FrameSettings settings;
  settings.clearRgb = test::kMagentaRgb;
  return settings;
}

class FramesInFlightTest : public test::GpuTest {
 protected:
  Result<TerrainRenderer> makeRenderer(const DatasetView& view, std::uint32_t inFlight,
                                       std::uint64_t budgetBytes = std::uint64_t{128} << 20,
                                       std::shared_ptr<GpuCache> cache = nullptr) {
    TerrainRendererOptions options;
    options.widthPixels = kInFlightWidth;
    options.heightPixels = kInFlightHeight;
    options.gpuCacheBytes = budgetBytes;
    options.framesInFlight = inFlight;
    options.sharedCache = std::move(cache);
    options.warnWhenBudgetExceeded = false;
    return TerrainRenderer::create(context(), view, options);
  }

  /// render() of every frame: the reference.
  std::vector<RgbaImage> oneAtATime(const DatasetView& view, const std::vector<FlightFrame>& frames,
                                    std::uint64_t budgetBytes) {
    auto renderer = makeRenderer(view, 1, budgetBytes);
    EXPECT_TRUE(renderer.ok()) << (renderer.ok() ? "" : renderer.error().message);
    std::vector<RgbaImage> images;
    if (!renderer.ok()) return images;
    for (const FlightFrame& f : frames) {
      auto frame = renderer->render(f.cut, f.camera, magentaBackground());
      EXPECT_TRUE(frame.ok()) << (frame.ok() ? "" : frame.error().message);
      if (!frame.ok()) return {};
      images.push_back(std::move(frame->image));
    }
    return images;
  }

  /// The frames submitted as a render loop with `inFlight` frames in flight does: a frame is
  /// collected only when every slot is taken, the rest at the end.
  std::vector<RenderedFrame> pipelined(TerrainRenderer& renderer,
                                       const std::vector<FlightFrame>& frames) {
    std::vector<RenderedFrame> out;
    for (const FlightFrame& f : frames) {
      if (renderer.framesPending() == renderer.framesInFlight()) {
        auto frame = renderer.collect();
        EXPECT_TRUE(frame.ok()) << (frame.ok() ? "" : frame.error().message);
        if (!frame.ok()) return out;
        out.push_back(std::move(*frame));
      }
      auto submitted = renderer.submit(f.cut, f.camera, magentaBackground());
      EXPECT_TRUE(submitted.ok()) << (submitted.ok() ? "" : submitted.error().message);
      if (!submitted.ok()) return out;
    }
    while (renderer.framesPending() > 0) {
      auto frame = renderer.collect();
      EXPECT_TRUE(frame.ok()) << (frame.ok() ? "" : frame.error().message);
      if (!frame.ok()) return out;
      out.push_back(std::move(*frame));
    }
    return out;
  }

  void expectTheSameFrames(const DatasetView& view, const std::vector<FlightFrame>& frames,
                           std::uint64_t budgetBytes, std::uint64_t* evictions = nullptr) {
    const std::vector<RgbaImage> reference = oneAtATime(view, frames, budgetBytes);
    ASSERT_EQ(reference.size(), frames.size());
    for (const std::uint32_t inFlight : {1u, 2u, 3u}) {
      SCOPED_TRACE(std::to_string(inFlight) + " frames in flight");
      auto renderer = makeRenderer(view, inFlight, budgetBytes);
      ASSERT_TRUE(renderer.ok()) << renderer.error().message;
      EXPECT_EQ(renderer->framesInFlight(), inFlight);
      const std::vector<RenderedFrame> drawn = pipelined(*renderer, frames);
      ASSERT_EQ(drawn.size(), frames.size());
      for (std::size_t i = 0; i < frames.size(); ++i) {
        EXPECT_TRUE(drawn[i].image.rgba == reference[i].rgba) << "frame " << i << " differs";
        EXPECT_EQ(drawn[i].stats.patches, frames[i].cut.patches.size());
        EXPECT_LE(drawn[i].stats.peakResidentBytes, budgetBytes);
        if (evictions != nullptr && inFlight == 3) *evictions += drawn[i].stats.evictions;
      }
      EXPECT_LE(renderer->residentBytes(), budgetBytes);
    }
  }
};

TEST_F(FramesInFlightTest, OneTwoAndThreeInFlightGiveRendersBytes) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  for (const CutKind kind : {CutKind::Fresh, CutKind::Reused, CutKind::NoStall}) {
    for (const double morphRange : {0.0, 0.5}) {
      SCOPED_TRACE("cuts " + std::to_string(static_cast<int>(kind)) + ", morph range " +
                   std::to_string(morphRange));
      expectTheSameFrames(dataset->view(), flight(*dataset, kind, morphRange),
                          std::uint64_t{128} << 20);
    }
  }
}

TEST_F(FramesInFlightTest, ThreeInFlightUnderABudgetThatEvictsEveryFrame) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const std::vector<FlightFrame> frames = flight(*dataset, CutKind::Fresh, 0.5);
  // The largest frame's slot bytes, and a third of them: the frames in flight cannot all stay
  // resident, and the largest cuts take several passes.
  auto probe = makeRenderer(view, 1);
  ASSERT_TRUE(probe.ok()) << probe.error().message;
  std::uint64_t largest = 0;
  for (const FlightFrame& f : frames) {
    auto frame = probe->render(f.cut, f.camera);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    auto alone = makeRenderer(view, 1);
    ASSERT_TRUE(alone.ok()) << alone.error().message;
    auto fresh = alone->render(f.cut, f.camera);
    ASSERT_TRUE(fresh.ok()) << fresh.error().message;
    largest = std::max(largest, fresh->stats.peakResidentBytes);
  }
  for (const std::uint64_t budget : {largest + largest / 4, largest / 3}) {
    SCOPED_TRACE("budget " + std::to_string(budget));
    std::uint64_t evictions = 0;
    expectTheSameFrames(view, frames, budget, &evictions);
    EXPECT_GE(evictions, frames.size() - 1);
  }
}

TEST_F(FramesInFlightTest, TwoRenderersOfASharedCacheWithTwoInFlightEach) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const std::vector<FlightFrame> frames = flight(*dataset, CutKind::Fresh, 0.5);
  const std::vector<RgbaImage> reference = oneAtATime(view, frames, std::uint64_t{128} << 20);
  ASSERT_EQ(reference.size(), frames.size());
  GpuCacheOptions cacheOptions;
  cacheOptions.budgetBytes = std::uint64_t{24} << 20;  // less than the two renderers' cuts
  auto cache = GpuCache::create(context(), view, cacheOptions);
  ASSERT_TRUE(cache.ok()) << cache.error().message;
  auto a = makeRenderer(view, 2, 0, *cache);
  auto b = makeRenderer(view, 2, 0, *cache);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  // Interleaved on one thread: a draws the flight forwards, b backwards.
  std::vector<RenderedFrame> fromA, fromB;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    for (auto [renderer, out, k] :
         {std::tuple{&*a, &fromA, i}, std::tuple{&*b, &fromB, frames.size() - 1 - i}}) {
      if (renderer->framesPending() == 2) {
        auto frame = renderer->collect();
        ASSERT_TRUE(frame.ok()) << frame.error().message;
        out->push_back(std::move(*frame));
      }
      auto submitted = renderer->submit(frames[k].cut, frames[k].camera, magentaBackground());
      ASSERT_TRUE(submitted.ok()) << submitted.error().message;
    }
  }
  for (auto [renderer, out] : {std::pair{&*a, &fromA}, std::pair{&*b, &fromB}}) {
    while (renderer->framesPending() > 0) {
      auto frame = renderer->collect();
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      out->push_back(std::move(*frame));
    }
  }
  ASSERT_EQ(fromA.size(), frames.size());
  ASSERT_EQ(fromB.size(), frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_TRUE(fromA[i].image.rgba == reference[i].rgba) << "a: frame " << i;
    EXPECT_TRUE(fromB[i].image.rgba == reference[frames.size() - 1 - i].rgba) << "b: frame " << i;
  }
  EXPECT_LE((*cache)->stats().residentBytes, cacheOptions.budgetBytes);
  EXPECT_EQ((*cache)->stats().pinnedBytes, 0u);
}

TEST_F(FramesInFlightTest, WithoutReadbackTheFrameHasNoImageAndTheSameStatistics) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const std::vector<FlightFrame> frames = flight(*dataset, CutKind::Fresh, 0.0);
  auto withPixels = makeRenderer(view, 2);
  auto without = makeRenderer(view, 2);
  ASSERT_TRUE(withPixels.ok()) << withPixels.error().message;
  ASSERT_TRUE(without.ok()) << without.error().message;
  for (const FlightFrame& f : frames) {
    ASSERT_TRUE(withPixels->submit(f.cut, f.camera).ok());
    FrameSettings noReadback;
    noReadback.readback = false;
    ASSERT_TRUE(without->submit(f.cut, f.camera, noReadback).ok());
    auto a = withPixels->collect();
    auto b = without->collect();
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_EQ(a->image.rgba.size(), std::size_t{4} * kInFlightWidth * kInFlightHeight);
    EXPECT_TRUE(b->image.rgba.empty());
    EXPECT_EQ(b->image.widthPixels, 0u);
    EXPECT_EQ(a->stats.patches, b->stats.patches);
    EXPECT_EQ(a->stats.triangles, b->stats.triangles);
    EXPECT_EQ(a->stats.misses, b->stats.misses);
    EXPECT_EQ(a->stats.hits, b->stats.hits);
  }
  // A frame without pixels cannot be redrawn: there is nothing to read back.
  auto redrawn = without->redrawLast();
  ASSERT_FALSE(redrawn.ok());
  EXPECT_EQ(redrawn.error().code, ErrorCode::InvalidArgument);
}

TEST_F(FramesInFlightTest, MisuseIsRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  for (const std::uint32_t bad : {0u, TerrainRenderer::kMaxFramesInFlight + 1}) {
    auto refused = makeRenderer(view, bad);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(refused.error().message.find("frames in flight must be 1 to 8"), std::string::npos)
        << refused.error().message;
  }
  auto renderer = makeRenderer(view, 2);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  auto nothing = renderer->collect();
  ASSERT_FALSE(nothing.ok());
  EXPECT_EQ(nothing.error().code, ErrorCode::InvalidArgument);
  const std::vector<FlightFrame> frames = flight(*dataset, CutKind::Fresh, 0.0);
  ASSERT_TRUE(renderer->submit(frames[0].cut, frames[0].camera).ok());
  for (const auto& refused :
       {renderer->render(frames[1].cut, frames[1].camera), renderer->redrawLast()}) {
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  }
  EXPECT_EQ(renderer->resize(160, 120).error().code, ErrorCode::InvalidArgument);
  ASSERT_TRUE(renderer->submit(frames[1].cut, frames[1].camera).ok());
  auto full = renderer->submit(frames[2].cut, frames[2].camera);
  ASSERT_FALSE(full.ok());
  EXPECT_EQ(full.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(full.error().message.find("collect()"), std::string::npos) << full.error().message;
  EXPECT_EQ(renderer->framesPending(), 2u);
  // What the frames in flight draw stays pinned until they are collected.
  EXPECT_GT(renderer->cache()->stats().pinnedBytes, 0u);
  ASSERT_TRUE(renderer->collect().ok());
  ASSERT_TRUE(renderer->collect().ok());
  EXPECT_EQ(renderer->cache()->stats().pinnedBytes, 0u);
  // Drained, the renderer takes render(), redrawLast() and resize() again.
  ASSERT_TRUE(renderer->render(frames[2].cut, frames[2].camera).ok());
  EXPECT_TRUE(renderer->redrawLast().ok());
  EXPECT_TRUE(renderer->resize(160, 120).ok());
}

TEST_F(FramesInFlightTest, DestroyedWithFramesInFlightItHandsTheSharedCachesPinsBack) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  const std::vector<FlightFrame> frames = flight(*dataset, CutKind::Fresh, 0.0);
  GpuCacheOptions cacheOptions;
  cacheOptions.budgetBytes = std::uint64_t{64} << 20;
  auto cache = GpuCache::create(context(), view, cacheOptions);
  ASSERT_TRUE(cache.ok()) << cache.error().message;
  {
    auto renderer = makeRenderer(view, 3, 0, *cache);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    for (std::size_t i = 0; i < 3; ++i) {
      ASSERT_TRUE(renderer->submit(frames[i].cut, frames[i].camera).ok());
    }
  }
  // Nothing stays pinned: another renderer can fill the whole budget.
  EXPECT_EQ((*cache)->stats().pinnedBytes, 0u);
}

}  // namespace
}  // namespace pbdam::gpu
