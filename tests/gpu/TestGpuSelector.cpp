// The cut selected on the device (gpu/GpuSelector.h) on lavapipe with validation on: over 200
// random cameras on Mars and Earth, with and without culling and level caps, it is refine()'s
// cut patch for patch — order, screen errors bit for bit, geomorph weights, tiles — also when
// its dispatches are split into rows of groups, and a node-table budget below the tables' size
// is refused naming both. With vertical exaggeration (three-fold, half) too.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/runtime/Selection.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

class GpuSelectorTest : public test::GpuTest {
 protected:
  void expectSameCuts(const std::filesystem::path& dir, int cameras, std::uint64_t seed,
                      std::uint32_t groupsPerRow = 65535, double exaggeration = 1.0) {
    if (!context().caps().shaderFloat64) GTEST_SKIP() << "no 64-bit floats in shaders";
    const auto dataset = test::openDataset(dir);
    ASSERT_NE(dataset, nullptr);
    const DatasetView& view = dataset->view();
    auto selector = GpuSelector::create(context(), view, std::uint64_t{256} << 20, groupsPerRow);
    ASSERT_TRUE(selector.ok()) << selector.error().message;
    if (groupsPerRow < 65535) {
      ASSERT_GT(selector->index().nodes.size(), std::size_t{64} * groupsPerRow * 2)
          << "the dispatch spans several rows of groups";
    }
    const double radius = view.planet().equatorialRadiusMeters();
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::size_t patches = 0;
    for (int c = 0; c < cameras; ++c) {
      const CameraPose pose{std::asin(2.0 * unit(rng) - 1.0) * 180.0 / std::numbers::pi,
                            360.0 * unit(rng) - 180.0,
                            2e4 * std::pow(2.0 * radius / 2e4, unit(rng)),
                            360.0 * unit(rng),
                            -90.0 + 85.0 * unit(rng),
                            0.0};
      SCOPED_TRACE(test::describe(pose));
      const Camera camera = test::cameraAt(view, pose, 640, 360);
      RefinementOptions options;
      options.tolerancePixels = 1.0 + 4.0 * unit(rng);
      options.frustumCulling = c % 4 != 3;
      options.exaggeration = exaggeration;
      if (c % 5 == 4) options.maxLevel = view.depth() - 2;
      const Cut cpu = refine(view, camera, options);
      SelectionOptions selection;
      selection.refinement = options;
      auto gpu = selector->select(camera, selection);
      ASSERT_TRUE(gpu.ok()) << gpu.error().message;
      ASSERT_EQ(gpu->patches.size(), cpu.patches.size());
      for (std::size_t i = 0; i < cpu.patches.size(); ++i) {
        const CutPatch& a = cpu.patches[i];
        const CutPatch& b = gpu->patches[i];
        ASSERT_TRUE(a.node == b.node) << "patch " << i;
        EXPECT_EQ(std::bit_cast<std::uint32_t>(a.screenErrorPixels),
                  std::bit_cast<std::uint32_t>(b.screenErrorPixels));
        EXPECT_EQ(a.morph, b.morph);
        EXPECT_TRUE(a.tile == b.tile);
      }
      EXPECT_EQ(gpu->tiles.size(), cpu.tiles.size());
      EXPECT_EQ(gpu->triangles, cpu.triangles);
      patches += cpu.patches.size();
    }
    EXPECT_GT(patches, static_cast<std::size_t>(cameras) * 10);
  }
};

TEST_F(GpuSelectorTest, MarsCutsAreTheCpusOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectSameCuts(dir, 100, 41);
}

TEST_F(GpuSelectorTest, EarthCutsAreTheCpusOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  expectSameCuts(dir, 100, 42);
}

// Vertical exaggeration widens the spheres and scales the errors in select.comp as on the host
// (runtime::refinementBounds): the same cuts, bit for bit, at three-fold and at half heights.
TEST_F(GpuSelectorTest, ExaggeratedMarsCutsAreTheCpusOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectSameCuts(dir, 40, 44, 65535, 3.0);
  expectSameCuts(dir, 20, 45, 65535, 0.5);
}

TEST_F(GpuSelectorTest, ExaggeratedEarthCutsAreTheCpusOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  expectSameCuts(dir, 40, 46, 65535, 3.0);
}

// Past 65,535 groups a dispatch is made of rows of groups (4.2 M nodes at 64 a group; the
// paper-scale dataset has 6.3 M): rows of 3 groups here select the same cuts.
TEST_F(GpuSelectorTest, CutsSelectedInRowsOfGroupsAreTheCpus) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  expectSameCuts(dir, 20, 43, 3);
}

// Focus regions (a circle and a path) and a one-sided caller's predicate, which only the
// closure — here the device's — makes conforming: the CPU selector's cut, patch for patch.
TEST_F(GpuSelectorTest, FocusAndClosureCutsAreTheCpuSelectorsOnLavapipe) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  if (!context().caps().shaderFloat64) GTEST_SKIP() << "no 64-bit floats in shaders";
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  const DatasetView& view = dataset->view();
  auto gpu = GpuSelector::create(context(), view);
  ASSERT_TRUE(gpu.ok()) << gpu.error().message;
  const CutSelector cpu(view);
  const Planet& planet = view.planet();
  auto circle = focusCircle(planet, 18.65, 226.2, 200e3, 0.0);
  auto path = focusPath(planet, {{0.0, -60.0}, {-8.0, -75.0}, {-10.0, -80.0}}, 30e3, 50.0);
  ASSERT_TRUE(circle.ok() && path.ok());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uint64_t closureSplits = 0;
  for (int c = 0; c < 24; ++c) {
    const CameraPose pose{-60.0 + 120.0 * unit(rng), 360.0 * unit(rng) - 180.0,
                          3e5 + 6e6 * unit(rng),     360.0 * unit(rng),
                          -90.0 + 60.0 * unit(rng),  0.0};
    SCOPED_TRACE(test::describe(pose));
    const Camera camera = test::cameraAt(view, pose, 640, 360);
    SelectionOptions options;
    options.refinement = {6.0, c % 3 != 2, -1, 0.25};
    options.focus = {*circle, *path};
    if (c % 2 == 1) {
      options.split = [](const NodeKey& key, const NodeRecord&) {
        return key.face == 2 && key.tree == 0 && bintreeLevel(key.heap) < 6;
      };
    }
    SelectionStats stats;
    const Cut expected = cpu.select(camera, options, &stats);
    closureSplits += stats.closureSplits;
    auto got = gpu->select(camera, options);
    ASSERT_TRUE(got.ok()) << got.error().message;
    ASSERT_EQ(got->patches.size(), expected.patches.size());
    for (std::size_t i = 0; i < expected.patches.size(); ++i) {
      ASSERT_TRUE(got->patches[i].node == expected.patches[i].node) << "patch " << i;
      EXPECT_EQ(got->patches[i].morph, expected.patches[i].morph);
    }
  }
  EXPECT_GT(closureSplits, 0u) << "the closure had work to do";
}

TEST_F(GpuSelectorTest, ATableBudgetBelowTheTablesIsRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = test::openDataset(dir);
  ASSERT_NE(dataset, nullptr);
  auto refused = GpuSelector::create(context(), dataset->view(), 1024);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("budget of 1024"), std::string::npos)
      << refused.error().message;
}

}  // namespace
}  // namespace pbdam::gpu
