// Cuts selected by a predicate and closed upward (runtime/Selection.h): with no focus region the
// selection is refine()'s cut; with one, the cut reaches the leaves inside the region, stays
// conforming (a closed 2-manifold, Euler characteristic 2) and keeps the screen-error cut
// elsewhere; bad focus regions are refused.
#include <gtest/gtest.h>

#include <glm/geometric.hpp>
#include <memory>
#include <random>

#include "ClosedManifold.h"
#include "RefinementCuts.h"
#include "RuntimeTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam {
namespace {

std::unique_ptr<MappedDataset> open(const std::filesystem::path& dir) {
  auto dataset = MappedDataset::open(dir);
  EXPECT_TRUE(dataset.ok()) << (dataset.ok() ? "" : dataset.error().message);
  return dataset.ok() ? std::move(dataset).value() : nullptr;
}

TEST(Selection, WithoutAFocusItIsTheRefinementsCut) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  auto dataset = open(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok());
  const CutSelector selector(view);
  for (const test::ToleranceCamera& c : test::toleranceCameras(view, *dem)) {
    SelectionOptions options;
    options.refinement = {c.tolerance, true, -1, 0.25};
    SelectionStats stats;
    const Cut selected = selector.select(c.camera, options, &stats);
    const Cut refined = refine(view, c.camera, options.refinement);
    EXPECT_EQ(stats.closureSplits, 0u) << "saturated errors are closed already";
    ASSERT_EQ(selected.patches.size(), refined.patches.size());
    for (std::size_t i = 0; i < refined.patches.size(); ++i) {
      EXPECT_TRUE(selected.patches[i].node == refined.patches[i].node);
      EXPECT_EQ(selected.patches[i].morph, refined.patches[i].morph);
      EXPECT_EQ(selected.patches[i].screenErrorPixels, refined.patches[i].screenErrorPixels);
    }
    EXPECT_EQ(selected.tiles.size(), refined.tiles.size());
    EXPECT_EQ(selected.triangles, refined.triangles);
  }
}

TEST(Selection, AFocusCircleGetsLeavesInsideAndStaysWatertight) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = open(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  const CutSelector selector(view);
  const Planet& planet = view.planet();
  // 200 km around Olympus Mons' summit at full detail, 8 px elsewhere, seen from orbit.
  auto focus = focusCircle(planet, 18.65, 226.2, 200e3, 0.0);
  ASSERT_TRUE(focus.ok()) << focus.error().message;
  test::PatchStore store(view);
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t inside = 0;
  for (int c = 0; c < 12; ++c) {
    const CameraPose pose{
        -60.0 + 120.0 * unit(rng), 360.0 * unit(rng), 2e6 + 6e6 * unit(rng), 0.0, -90.0, 0.0};
    const Camera camera = Camera::fromPose(planet, pose, Viewport{320, 180, 60.0});
    SelectionOptions options;
    options.refinement = {8.0, false, -1, 0.25};
    options.focus = {*focus};
    SelectionStats stats;
    const Cut cut = selector.select(camera, options, &stats);
    const test::MeshCheck check = test::checkClosedManifold(view, cut, camera.position(), store);
    EXPECT_EQ(check.badEdges, 0u);
    EXPECT_EQ(check.euler(), 2) << check.vertices << " V, " << check.edges << " E, "
                                << check.triangles << " F";
    EXPECT_GT(stats.predicateSplits, 0u);
    for (const CutPatch& p : cut.patches) {
      const NodeRecord n = view.node(p.node);
      const glm::dvec3 centre(n.sphereCenter[0], n.sphereCenter[1], n.sphereCenter[2]);
      const double gap = glm::length(centre - focus->line.front()) -
                         static_cast<double>(n.sphereRadiusMeters) - focus->widthMeters;
      if (gap <= 0.0) {  // within the circle: a leaf
        EXPECT_TRUE(n.leaf()) << "level " << p.level;
        ++inside;
      } else {
        EXPECT_LE(p.screenErrorPixels, 8.0f * (1.0f + 1e-6f)) << "outside: the 8 px cut";
      }
    }
    // Without the focus, the same camera draws fewer patches: the circle adds detail.
    options.focus.clear();
    EXPECT_LT(selector.select(camera, options).patches.size(), cut.patches.size());
  }
  EXPECT_GT(inside, 12u);
}

// A predicate no saturation agrees with — every node of one tree of face 2 down to level 6,
// nothing elsewhere — needs the closure: its partners across the face's diagonal and across the
// face's edges are split too, and the whole-planet cut is a closed 2-manifold.
TEST(Selection, TheClosureMakesAOneSidedPredicateConforming) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = open(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  const CutSelector selector(view);
  const Camera camera =
      Camera::fromPose(view.planet(), {0.0, 0.0, 2e7, 0.0, -90.0, 0.0}, Viewport{320, 180, 60.0});
  SelectionOptions options;
  options.refinement = {1e9, false, -1, 0.25};  // no split by size
  options.split = [](const NodeKey& key, const NodeRecord&) {
    return key.face == 2 && key.tree == 0 && bintreeLevel(key.heap) < 6;
  };
  SelectionStats stats;
  const Cut cut = selector.select(camera, options, &stats);
  EXPECT_GT(stats.closureSplits, 0u);
  test::PatchStore store(view);
  const test::MeshCheck check = test::checkClosedManifold(view, cut, camera.position(), store);
  EXPECT_EQ(check.badEdges, 0u);
  EXPECT_EQ(check.euler(), 2);
  std::size_t otherTree = 0;
  for (const CutPatch& p : cut.patches) {
    otherTree += static_cast<std::size_t>(p.node.face == 2 && p.node.tree == 1 && p.level >= 5);
  }
  EXPECT_GT(otherTree, 0u) << "the partners across the diagonal were split";
}

TEST(Selection, BadFocusCirclesAreRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = open(dir);
  ASSERT_TRUE(dataset);
  const Planet& planet = dataset->view().planet();
  EXPECT_FALSE(focusCircle(planet, 95.0, 0.0, 1e3, 0.0));
  EXPECT_FALSE(focusCircle(planet, 0.0, 0.0, 0.0, 0.0));
  EXPECT_FALSE(focusCircle(planet, 0.0, 0.0, 2e7, 0.0));  // beyond half Mars' circumference
  EXPECT_FALSE(focusCircle(planet, 0.0, 0.0, 1e3, -1.0));
  EXPECT_TRUE(focusCircle(planet, 0.0, 0.0, 1e3, 10.0));
}

}  // namespace
}  // namespace pbdam
