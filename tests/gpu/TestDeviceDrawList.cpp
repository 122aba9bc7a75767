// Draw lists made on the device (TerrainRenderer::renderSelected, gpu/src/DeviceDrawList.h) on
// lavapipe with validation on: for Mars and Earth cameras, with geomorphing and with a focus
// region, the indirect frame is byte-identical to render() of the read-back cut, the draws are
// that cut's drawable patches with its triangles, and every record is makePatchDrawRecord's bit
// for bit, also when the scan is dispatched in rows of groups; a budget that cannot hold the
// whole dataset is refused naming the bytes. CTest also
// runs these on lavapipe as it runs on an x86-64 CPU without AVX-512 (tests/gpu/CMakeLists.txt),
// whose double rounding once made the records differ.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Selection.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kDrawListWidth = 320;
constexpr std::uint32_t kDrawListHeight = 200;

class DeviceDrawListTest : public test::GpuTest {
 protected:
  bool supported() {
    const DeviceCaps& caps = context().caps();
    return caps.shaderFloat64 && caps.multiDrawIndirect && caps.drawIndirectCount &&
           caps.shaderDrawParameters;
  }

  /// A renderer whose private cache holds `budgetBytes` in one pool chunk.
  Result<TerrainRenderer> makeRenderer(const DatasetView& view, std::uint64_t budgetBytes,
                                       double exaggeration = 1.0) {
    TerrainRendererOptions ro;
    ro.exaggeration = exaggeration;
    ro.widthPixels = kDrawListWidth;
    ro.heightPixels = kDrawListHeight;
    ro.gpuCacheBytes = budgetBytes;
    ro.poolChunkBytes = budgetBytes;
    return TerrainRenderer::create(context(), view, ro);
  }

  void expectReadBackFrames(const std::filesystem::path& dir, std::uint64_t seed, bool focus,
                            std::uint32_t groupsPerRow = 65535, double exaggeration = 1.0) {
    if (!supported()) GTEST_SKIP() << "no indirect draw counts or draw parameters";
    const auto dataset = test::openDataset(dir);
    ASSERT_NE(dataset, nullptr);
    const DatasetView& view = dataset->view();
    auto selector = GpuSelector::create(context(), view, std::uint64_t{256} << 20, groupsPerRow);
    ASSERT_TRUE(selector.ok()) << selector.error().message;
    if (groupsPerRow < 65535) {
      ASSERT_GT(selector->index().nodes.size(), std::size_t{256} * groupsPerRow * 2)
          << "the scan spans several rows of groups";
    }
    auto renderer = makeRenderer(view, GpuCache::bytesForEverything(context(), view), exaggeration);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    const double radius = view.planet().equatorialRadiusMeters();
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uint64_t morphing = 0;
    for (int c = 0; c < 6; ++c) {
      const CameraPose pose{std::asin(2.0 * unit(rng) - 1.0) * 180.0 / std::numbers::pi,
                            360.0 * unit(rng) - 180.0,
                            2e4 * std::pow(radius / 2e4, unit(rng)),
                            360.0 * unit(rng),
                            -90.0 + 70.0 * unit(rng),
                            0.0};
      SCOPED_TRACE(test::describe(pose));
      const Camera camera = test::cameraAt(view, pose, kDrawListWidth, kDrawListHeight);
      SelectionOptions selection;
      selection.refinement.tolerancePixels = 2.0 + 3.0 * unit(rng);
      selection.refinement.morphRange = c % 3 == 2 ? 0.0 : 0.25;
      selection.refinement.exaggeration = exaggeration;
      if (focus) {
        auto circle = focusCircle(view.planet(), pose.latDegrees, pose.lonDegrees, 300e3, 0.0);
        ASSERT_TRUE(circle.ok()) << circle.error().message;
        selection.focus = {*circle};
      }
      auto cut = selector->select(camera, selection);
      ASSERT_TRUE(cut.ok()) << cut.error().message;
      morphing += summarizeMorph(*cut).morphingPatches;
      auto readBack = renderer->render(*cut, camera);
      ASSERT_TRUE(readBack.ok()) << readBack.error().message;
      auto device = renderer->renderSelected(*selector, camera, selection, {}, true);
      ASSERT_TRUE(device.ok()) << device.error().message;
      EXPECT_EQ(device->stats.patches, cut->patches.size());
      EXPECT_EQ(device->stats.triangles, cut->triangles);
      EXPECT_TRUE(device->image.rgba == readBack->image.rgba) << "frames differ";
      EXPECT_FALSE(renderer->redrawLast().ok()) << "no host-drawn frame to draw again";

      auto records = renderer->lastSelectedRecords();
      ASSERT_TRUE(records.ok()) << records.error().message;
      ASSERT_EQ(records->size(), cut->patches.size());
      for (std::size_t i = 0; i < records->size(); ++i) {
        const CutPatch& patch = cut->patches[i];
        const PatchDrawRecord& got = (*records)[i];
        PatchDrawInput input;
        input.node = patch.node;
        input.record = view.node(patch.node);
        input.textureLayer = static_cast<std::uint32_t>(got.corner[0][3]);
        input.morph = patch.morph;
        if (patch.blendsTile()) {
          input.morphTile = patch.morphTile;
          input.morphTextureLayer = static_cast<std::uint32_t>(got.morph[3]);
        }
        const PatchDrawRecord expected =
            makePatchDrawRecord(view, input, camera.position(), exaggeration);
        using Words = std::array<float, sizeof(PatchDrawRecord) / 4>;
        using Bits = std::array<std::uint32_t, sizeof(PatchDrawRecord) / 4>;
        const Bits gotBits = std::bit_cast<Bits>(got), expectedBits = std::bit_cast<Bits>(expected);
        for (std::size_t w = 0; w < gotBits.size(); ++w) {
          ASSERT_EQ(gotBits[w], expectedBits[w])
              << "record " << i << ", vec4 " << w / 4 << " component " << w % 4 << ": device "
              << std::bit_cast<Words>(got)[w] << ", host " << std::bit_cast<Words>(expected)[w];
        }
      }
    }
    if (!focus) {
      EXPECT_GT(morphing, 0u) << "some patches morphed part-way";
    }
  }
};

TEST_F(DeviceDrawListTest, MarsFramesAreTheReadBackCutsFramesOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectReadBackFrames(dir, 11, false);
}

TEST_F(DeviceDrawListTest, EarthFramesAreTheReadBackCutsFramesOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  expectReadBackFrames(dir, 12, false);
}

TEST_F(DeviceDrawListTest, FocusCutsAreDrawnFromTheDeviceList) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectReadBackFrames(dir, 13, true);
}

// With four-fold heights: the device's records are the host's for that exaggeration (reference
// height ranges scaled), and the frames the read-back cut's.
TEST_F(DeviceDrawListTest, ExaggeratedMarsFramesAreTheReadBackCutsFrames) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectReadBackFrames(dir, 15, false, 65535, 4.0);
}

// The list's scan in rows of 2 groups of 256 nodes (past 65,535 groups, 16.8 M nodes, a
// dispatch is made of rows): the same frames and records.
TEST_F(DeviceDrawListTest, ListsScannedInRowsOfGroupsDrawTheSameFrames) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectReadBackFrames(dir, 14, false, 2);
}

TEST_F(DeviceDrawListTest, ABudgetBelowTheWholeDatasetIsRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  if (!supported()) GTEST_SKIP() << "no indirect draw counts or draw parameters";
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  auto selector = GpuSelector::create(context(), view);
  ASSERT_TRUE(selector.ok()) << selector.error().message;
  auto renderer = makeRenderer(view, GpuCache::bytesForEverything(context(), view) / 2);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Camera camera =
      test::cameraAt(view, {0.0, 0.0, 4e6, 0.0, -90.0, 0.0}, kDrawListWidth, kDrawListHeight);
  auto refused = renderer->renderSelected(*selector, camera, {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("need every patch and tile resident"), std::string::npos)
      << refused.error().message;
}

}  // namespace
}  // namespace pbdam::gpu
