// Vertical exaggeration (RefinementOptions::exaggeration, PatchVertexPlacement's factor) on the
// MOLA test dataset: decode draws each vertex at its terrain point at F times its height, cuts
// stay watertight with exaggerated heights, every exaggerated vertex lies in its node's widened
// bounding sphere, and over Olympus Mons no patch in view is culled.
#include <gtest/gtest.h>

#if defined(__SANITIZE_THREAD__)
#include <tbb/global_control.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <unordered_set>
#include <vector>

#include "CameraPrecision.h"
#include "ClosedManifold.h"
#include "RefinementCuts.h"
#include "RuntimeTestSupport.h"
#include "TestData.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/runtime/TerrainPoint.h"
#include "pbdam/streaming/DecodeScheduler.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/ResidencyLru.h"

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::runtime {
namespace {

#if defined(__SANITIZE_THREAD__)
// Debian's libtbb is not instrumented: TSan reports its task handoffs in the decoding as races.
// Under TSan the decoding runs on the calling thread (as tests/streaming/TestDecodeScheduler.cpp).
const tbb::global_control exaggerationSerialUnderTsan(tbb::global_control::max_allowed_parallelism,
                                                      1);
#endif

std::unique_ptr<MappedDataset> openMola(const std::filesystem::path& dir) {
  auto dataset = MappedDataset::open(dir);
  EXPECT_TRUE(dataset.ok()) << (dataset.ok() ? "" : dataset.error().message);
  return dataset.ok() ? std::move(dataset).value() : nullptr;
}

// A camera low over Olympus Mons's southern flank looking north at the summit (18.65° N,
// 226.2° E), high enough to stay above the five-fold flank.
Camera olympusCamera(const DatasetView& view, double pitchDegrees) {
  const CameraPose pose{15.4, -133.8, 60000.0, 0.0, pitchDegrees, 0.0};
  return Camera::fromPose(view.planet(), pose, Viewport{640, 360, 60.0});
}

TEST(Exaggeration, OneChangesNoBound) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const ExaggerationBounds one = exaggerationBounds(dataset->view(), 1.0);
  EXPECT_EQ(one.errorScale, 1.0);
  EXPECT_EQ(one.radiusGrowthMeters, 0.0);
  // Both directions widen the spheres; only F > 1 scales the errors.
  const Manifest& m = dataset->view().manifest();
  const double largest = std::max(std::abs(m.minHeightMeters), std::abs(m.maxHeightMeters));
  EXPECT_GE(exaggerationBounds(dataset->view(), 3.0).radiusGrowthMeters, 2.0 * largest);
  EXPECT_EQ(exaggerationBounds(dataset->view(), 3.0).errorScale, 3.0);
  EXPECT_GE(exaggerationBounds(dataset->view(), 0.5).radiusGrowthMeters, 0.5 * largest);
  EXPECT_EQ(exaggerationBounds(dataset->view(), 0.5).errorScale, 1.0);
}

TEST(Exaggeration, DecodedVerticesAreTheTerrainPointsAtThreeTimesTheirHeights) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr double kF = 3.0;
  const Camera camera = olympusCamera(view, -20.0);
  RefinementOptions options;
  options.exaggeration = kF;
  const Cut cut = refine(view, camera, options);
  ASSERT_FALSE(cut.patches.empty());

  // What the renderer uploads: the decode workers' vertices under F.
  const DecodeScheduler decoder(view, DecodeScheduler::datasetTexels(view), kF);
  std::vector<DecodeJob> jobs;
  for (const CutPatch& p : cut.patches) {
    DecodeJob job;
    job.key = ResidentKey::patch(p.node);
    job.node = p.node;
    jobs.push_back(job);
  }
  std::vector<std::byte> out(decoder.layout(jobs));
  const auto decoded = decoder.decode(jobs, out);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;

  test::PatchStore store(view);
  const double step = view.manifest().heightStepMeters;
  const glm::dvec3 eye = camera.position();
  std::size_t checked = 0, raised = 0;
  double worstDecode = 0.0, worstDrawn = 0.0;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const CutPatch& p = cut.patches[j];
    const NodeRecord record = view.node(p.node);
    const PatchVertexPlacement placement(view, p.node, record, kF);
    const PatchDrawRecord draw = makePatchDrawRecord(view, {.node = p.node, .record = record}, eye);
    const PatchMesh& mesh = store.mesh(p.node);
    ASSERT_EQ(jobs[j].vertexBytes, mesh.vertices.size() * sizeof(PatchGpuVertex));
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const PatchVertex& pv = mesh.vertices[v];
      LatticeXY q{0};
      ASSERT_TRUE(placement.latticePoint(pv.b1, pv.b2, q));
      const double trueHeight = static_cast<double>(pv.heightSteps) * step;
      const glm::dvec3 expected =
          latticeTerrainPoint(view.planet(), view.latticeCells(), p.node.face, q, kF * trueHeight);
      // Bit for bit the terrain point at three times the height.
      const glm::dvec3 t = placement.terrainPoint(q, pv.heightSteps);
      ASSERT_TRUE(t.x == expected.x && t.y == expected.y && t.z == expected.z)
          << "patch " << j << " vertex " << v;
      // The decoded GPU vertex rebuilds it: Pflat + h·N + o.
      PatchGpuVertex gpu{};
      std::memcpy(&gpu, out.data() + jobs[j].offset + v * sizeof gpu, sizeof gpu);
      ASSERT_EQ(gpu.b1, pv.b1);
      ASSERT_EQ(gpu.b2, pv.b2);
      const PatchVertexBase base = placement.base(pv.b1, pv.b2);
      const glm::dvec3 rebuilt =
          base.flat + static_cast<double>(gpu.heightMeters) * base.normal +
          glm::dvec3(gpu.offsetMeters[0], gpu.offsetMeters[1], gpu.offsetMeters[2]);
      worstDecode = std::max(worstDecode, glm::length(rebuilt - expected));
      // And the vertex shader's camera-relative position (no morph) is T(3h) − camera.
      PatchVertexDisplacement d;
      d.heightMeters = gpu.heightMeters;
      d.targetHeightMeters = gpu.heightMeters;
      d.offsetMeters = glm::vec3(gpu.offsetMeters[0], gpu.offsetMeters[1], gpu.offsetMeters[2]);
      const glm::dvec3 drawn(shaderVertexPosition(draw, pv.b1, pv.b2, d));
      const glm::dvec3 relative = expected - eye;
      worstDrawn = std::max(worstDrawn,
                            glm::length(drawn - relative) / std::max(1.0, glm::length(relative)));
      // Not the true terrain point: the height really is tripled.
      const glm::dvec3 flat =
          latticeTerrainPoint(view.planet(), view.latticeCells(), p.node.face, q, trueHeight);
      if (std::abs(trueHeight) > 1000.0) {
        EXPECT_NEAR(glm::length(expected - flat), 2.0 * std::abs(trueHeight),
                    1e-6 * std::abs(trueHeight));
        ++raised;
      }
      ++checked;
    }
  }
  std::printf(
      "%zu vertices checked, %zu raised by over 2 km; rebuilt within %.3g m, drawn within "
      "%.3g of the distance\n",
      checked, raised, worstDecode, worstDrawn);
  EXPECT_GT(raised, checked / 4);
  EXPECT_LT(worstDecode, 0.01);  // float offsets of up to kilometres
  EXPECT_LT(worstDrawn, 1e-6);   // float camera-relative arithmetic
}

TEST(Exaggeration, CutsWithThreeFoldHeightsAreWatertight) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  constexpr double kF = 3.0;
  test::PatchStore store(view);
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double radius = view.planet().equatorialRadiusMeters();
  const double top = kF * view.manifest().maxHeightMeters;
  std::size_t differing = 0;
  constexpr int kCameras = 10;
  for (int c = 0; c < kCameras; ++c) {
    CameraPose pose{std::asin(2.0 * unit(rng) - 1.0) * 180.0 / 3.14159265358979323846,
                    360.0 * unit(rng) - 180.0,
                    top + std::exp(std::log(1000.0) + unit(rng) * std::log(4.0 * radius / 1000.0)),
                    360.0 * unit(rng),
                    -5.0 - 85.0 * unit(rng),
                    0.0};
    if (c == 0) pose = {15.4, -133.8, 90000.0, 0.0, -20.0, 0.0};  // Olympus Mons
    SCOPED_TRACE("camera " + std::to_string(c) + ": " + std::to_string(pose.latDegrees) + "," +
                 std::to_string(pose.lonDegrees) + "," + std::to_string(pose.altitudeMeters));
    const Camera camera = Camera::fromPose(view.planet(), pose, Viewport{320, 180, 60.0});
    RefinementOptions options;
    options.frustumCulling = false;
    options.exaggeration = kF;
    const Cut whole = refine(view, camera, options);
    const test::MeshCheck check =
        test::checkClosedManifold(view, whole, camera.position(), store, kF);
    EXPECT_EQ(check.badEdges, 0u);
    EXPECT_EQ(check.degenerate, 0u);
    EXPECT_EQ(check.euler(), 2) << check.vertices << " V, " << check.edges << " E, "
                                << check.triangles << " F";
    // The same camera's true-height cut is coarser or equal, never finer (errors × 3).
    RefinementOptions flat = options;
    flat.exaggeration = 1.0;
    const Cut trueCut = refine(view, camera, flat);
    EXPECT_GE(whole.patches.size(), trueCut.patches.size());
    differing += static_cast<std::size_t>(test::serializeCut(whole) != test::serializeCut(trueCut));
    // Culled, it is a subsequence of the whole cut: culling only drops subtrees.
    options.frustumCulling = true;
    const Cut visible = refine(view, camera, options);
    auto it = whole.patches.begin();
    for (const CutPatch& p : visible.patches) {
      it = std::find_if(it, whole.patches.end(),
                        [&](const CutPatch& q) { return q.node == p.node; });
      ASSERT_NE(it, whole.patches.end()) << "visible patch not in the unculled cut";
    }
  }
  EXPECT_GT(differing, 0u) << "exaggeration refined no cut further";
}

// Camera-relative drawing stays millimetre-accurate next to the camera with ten-fold heights
// (Olympus Mons 213 km high): the reference heights follow the exaggerated relief.
TEST(Exaggeration, MillimetreAccurateTwoMetresAboveTenFoldOlympusMons) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const precision::PrecisionFigures f = precision::measurePrecision(dir, 18.4, -133.9, 300e3, 10.0);
  ASSERT_GT(f.vertices, 0u);
  EXPECT_LE(f.cameraRelative, 1e-3);
}

// The refinement tree kept from frame to frame (IncrementalRefiner) gives refine()'s cuts with
// exaggerated bounds, and a change of exaggeration rebuilds it.
TEST(Exaggeration, ReusedRefinementTreesGiveTheSameCuts) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  IncrementalRefiner reuse(view);
  std::size_t differing = 0;
  for (int k = 0; k < 24; ++k) {
    const double f = k < 16 ? 3.0 : 0.5;
    const CameraPose pose{
        12.0 + 0.3 * k, -140.0 + 0.6 * k, 200000.0 - 4000.0 * k, 20.0, -25.0, 0.0};
    const Camera camera = Camera::fromPose(view.planet(), pose, Viewport{640, 360, 60.0});
    RefinementOptions options;
    options.exaggeration = f;
    const Cut expected = refine(view, camera, options);
    const Cut got = reuse.update(camera, options);
    ASSERT_EQ(got.patches.size(), expected.patches.size()) << "frame " << k;
    for (std::size_t i = 0; i < got.patches.size(); ++i) {
      ASSERT_TRUE(got.patches[i].node == expected.patches[i].node) << "frame " << k;
      EXPECT_EQ(got.patches[i].screenErrorPixels, expected.patches[i].screenErrorPixels);
      EXPECT_EQ(got.patches[i].morph, expected.patches[i].morph);
    }
    options.exaggeration = 1.0;
    differing += static_cast<std::size_t>(test::serializeCut(refine(view, camera, options)) !=
                                          test::serializeCut(expected));
  }
  EXPECT_GT(differing, 0u);
}

// What culling relies on: every exaggerated vertex of every node of a cut (and of its ancestors,
// whose spheres nest) lies in the node's widened sphere.
TEST(Exaggeration, ExaggeratedVerticesLieInTheirNodesWidenedSpheres) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  test::PatchStore store(view);
  const Camera camera = olympusCamera(view, -20.0);
  for (const double f : {0.25, 5.0, 100.0}) {
    SCOPED_TRACE("exaggeration " + std::to_string(f));
    RefinementOptions options;
    options.frustumCulling = false;
    options.exaggeration = f;
    const Cut cut = refine(view, camera, options);
    const ExaggerationBounds bounds = exaggerationBounds(view, f);
    std::size_t outsideTrueSpheres = 0;
    for (const CutPatch& p : cut.patches) {
      const NodeRecord record = view.node(p.node);
      const PatchVertexPlacement placement(view, p.node, record, f);
      const RefinementBounds b = refinementBounds(view, record, p.level, bounds);
      const double trueRadius = static_cast<double>(record.sphereRadiusMeters);
      for (const PatchVertex& pv : store.mesh(p.node).vertices) {
        LatticeXY q{0};
        ASSERT_TRUE(placement.latticePoint(pv.b1, pv.b2, q));
        const double d = glm::length(placement.terrainPoint(q, pv.heightSteps) - b.centre);
        ASSERT_LE(d, b.radiusMeters) << "node " << p.node.face << "/" << p.node.heap;
        outsideTrueSpheres += static_cast<std::size_t>(d > trueRadius);
      }
    }
    // The widening is needed: without it some vertices would fall outside.
    if (f >= 5.0) {
      EXPECT_GT(outsideTrueSpheres, 0u);
    }
  }
}

// Cameras low over Olympus Mons: every patch that culling drops lies wholly outside one frustum
// plane with its exaggerated vertices, so none that is visible is dropped. Five-fold from the
// southern flank looking north at pitches −5°, −20°, −45°; and at 25-fold poses where spheres not
// widened (radiusGrowthMeters 0) would drop a patch in view (on this 4 px/deg dataset the
// spheres are wide enough at five-fold to hide that mistake).
TEST(Exaggeration, NoVisiblePatchIsCulledOverOlympusMons) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto dataset = openMola(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  test::PatchStore store(view);
  struct Case {
    double exaggeration;
    CameraPose pose;
  };
  const std::vector<Case> cases = {
      {5.0, {15.4, -133.8, 60000.0, 0.0, -5.0, 0.0}},
      {5.0, {15.4, -133.8, 60000.0, 0.0, -20.0, 0.0}},
      {5.0, {15.4, -133.8, 60000.0, 0.0, -45.0, 0.0}},
      {25.0, {17.0, -133.8, 60000.0, 180.0, -15.0, 0.0}},
      {25.0, {12.0, -133.8, 150000.0, 90.0, -30.0, 0.0}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE("exaggeration " + std::to_string(c.exaggeration) + ", pitch " +
                 std::to_string(c.pose.pitchDegrees) + ", heading " +
                 std::to_string(c.pose.headingDegrees));
    const Camera camera = Camera::fromPose(view.planet(), c.pose, Viewport{640, 360, 60.0});
    RefinementOptions options;
    options.exaggeration = c.exaggeration;
    options.tolerancePixels = 1.0;
    const Cut visible = refine(view, camera, options);
    options.frustumCulling = false;
    const Cut whole = refine(view, camera, options);
    ASSERT_GT(visible.nodesCulled, 0u);
    std::unordered_set<std::uint64_t> kept;
    for (const CutPatch& p : visible.patches) kept.insert(packKey(p.node));
    std::size_t dropped = 0, seen = 0;
    for (const CutPatch& p : whole.patches) {
      const NodeRecord record = view.node(p.node);
      const PatchVertexPlacement placement(view, p.node, record, c.exaggeration);
      std::vector<glm::dvec3> points;
      for (const PatchVertex& pv : store.mesh(p.node).vertices) {
        LatticeXY q{0};
        ASSERT_TRUE(placement.latticePoint(pv.b1, pv.b2, q));
        points.push_back(placement.terrainPoint(q, pv.heightSteps));
      }
      bool outside = false;
      for (const glm::dvec4& plane : camera.frustumPlanes()) {
        outside = outside || std::all_of(points.begin(), points.end(), [&](const glm::dvec3& t) {
                    return glm::dot(glm::dvec3(plane), t) + plane.w < 0.0;
                  });
      }
      seen += static_cast<std::size_t>(!outside);
      if (kept.count(packKey(p.node)) != 0) continue;
      ++dropped;
      EXPECT_TRUE(outside) << "patch " << int{p.node.face} << "/" << p.node.heap
                           << " is in view but was culled";
    }
    EXPECT_GT(dropped, 0u);
    EXPECT_GT(seen, 0u);
  }
}

}  // namespace
}  // namespace pbdam::runtime
