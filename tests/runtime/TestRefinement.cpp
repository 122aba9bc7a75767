// Refinement and camera-relative vertices on real datasets (MOLA and ETOPO5, built by the
// datasets fixture): cuts are deterministic and bounded in screen error, the cut's triangles as
// the shader computes them form a closed 2-manifold (watertight), and camera-relative positions
// are millimetre-accurate next to the camera where absolute float positions are not.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "CameraPrecision.h"
#include "ClosedManifold.h"
#include "RefinementCuts.h"
#include "RuntimeTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/Camera.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::runtime {
namespace {

using test::checkClosedManifold;
using test::MeshCheck;
using test::randomPose;
using test::serializeToleranceCuts;
using test::ToleranceCamera;
using test::toleranceCameras;

std::unique_ptr<MappedDataset> openDataset(const std::filesystem::path& dir) {
  auto dataset = MappedDataset::open(dir);
  EXPECT_TRUE(dataset.ok()) << (dataset.ok() ? "" : dataset.error().message);
  return dataset.ok() ? std::move(dataset).value() : nullptr;
}

constexpr std::array<double, 5> kMorphRanges = {0.0, 0.05, 0.1, 0.175, 0.25};

/// Cuts for each of `cameras` poses from pose(rng) are closed 2-manifolds (Euler 2), capped ones
/// too, and culling only drops subtrees. Each whole cut is checked with the geomorph of five
/// morph ranges (0: off, up to the datasets' error margin 0.25); the morphing ones must have
/// patches of different levels meet at vertices moved part-way.
void expectWatertightFor(const DatasetView& view, int cameras, std::uint64_t seed,
                         const std::function<CameraPose(std::mt19937_64&)>& nextPose) {
  test::PatchStore store(view);
  std::mt19937_64 rng(seed);
  const Viewport viewport{320, 180, 60.0};
  std::size_t totalTriangles = 0;
  std::array<std::size_t, kMorphRanges.size()> morphing{};
  for (int c = 0; c < cameras; ++c) {
    const CameraPose pose = nextPose(rng);
    SCOPED_TRACE("camera " + std::to_string(c) + ": " + std::to_string(pose.latDegrees) + "," +
                 std::to_string(pose.lonDegrees) + "," + std::to_string(pose.altitudeMeters));
    const Camera camera = Camera::fromPose(view.planet(), pose, viewport);
    // The whole planet's cut for this camera's level of detail (no culling), and the culled one.
    const Cut visible = refine(view, camera, {3.0, true, -1});
    Cut whole;
    for (std::size_t r = 0; r < kMorphRanges.size(); ++r) {
      SCOPED_TRACE("morph range " + std::to_string(kMorphRanges[r]));
      whole = refine(view, camera, {3.0, false, -1, kMorphRanges[r]});
      const MeshCheck check = checkClosedManifold(view, whole, camera.position(), store);
      totalTriangles += check.triangles;
      morphing[r] += check.morphingSharedVertices;
      EXPECT_EQ(check.badEdges, 0u);
      EXPECT_EQ(check.degenerate, 0u);
      EXPECT_EQ(check.euler(), 2) << check.vertices << " V, " << check.edges << " E, "
                                  << check.triangles << " F";
    }
    // Level-capped cuts (what no-stall mode draws while finer data arrives) are conforming too.
    if (c % 10 == 0) {
      const Cut capped = refine(view, camera, {3.0, false, view.depth() - 1 - c % 3});
      const MeshCheck cappedCheck = checkClosedManifold(view, capped, camera.position(), store);
      EXPECT_EQ(cappedCheck.badEdges, 0u);
      EXPECT_EQ(cappedCheck.euler(), 2);
    }
    // Culling only drops subtrees: the visible cut is a subsequence of the whole one.
    auto it = whole.patches.begin();
    for (const CutPatch& p : visible.patches) {
      it = std::find_if(it, whole.patches.end(),
                        [&](const CutPatch& q) { return q.node == p.node; });
      ASSERT_NE(it, whole.patches.end()) << "visible patch not in the unculled cut";
    }
  }
  std::printf("%d cameras, %zu triangles checked\n", cameras, totalTriangles);
  EXPECT_EQ(morphing[0], 0u) << "morph range 0 is no morph";
  for (std::size_t r = 1; r < kMorphRanges.size(); ++r) {
    EXPECT_GT(morphing[r], 0u) << "morph range " << kMorphRanges[r];
  }
}

void expectWatertight(const std::filesystem::path& dir, const std::filesystem::path& demPath,
                      int cameras, std::uint64_t seed) {
  auto dataset = openDataset(dir);
  ASSERT_TRUE(dataset);
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const double radius = dataset->view().planet().equatorialRadiusMeters();
  expectWatertightFor(dataset->view(), cameras, seed,
                      [&](std::mt19937_64& rng) { return randomPose(rng, *dem, radius); });
}

// ≥ 200 cameras over both planets; sanitizer builds check fewer (they look for memory errors,
// not for more camera positions).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr int kWatertightCameras = 12;
#else
constexpr int kWatertightCameras = 100;
#endif

TEST(Refinement, MarsCutsAreWatertightForRandomCameras) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  expectWatertight(dir, dem, kWatertightCameras, 2026);
}

TEST(Refinement, EarthCutsAreWatertightForRandomCameras) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  PBDAM_REQUIRE_DATA(dem, PBDAM_ETOPO5_PATH);
  expectWatertight(dir, dem, kWatertightCameras, 1123);
}

// ETOPO5 with the Luxembourg inset: leaves of level 20 over the inset meet leaves of level 6
// across the closure around it. Oblique cameras across its border, from 1 to 300 km up.
TEST(Refinement, CutsAcrossAnInsetsBorderAreWatertight) {
  PBDAM_REQUIRE_DATASET(dir, "luxembourg");
  auto dataset = openDataset(dir);
  ASSERT_TRUE(dataset);
  ASSERT_EQ(dataset->view().manifest().insets.size(), 1u);
  expectWatertightFor(dataset->view(), kWatertightCameras / 2, 77, [](std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    CameraPose p;
    p.latDegrees = 49.2 + 1.2 * u(rng);
    p.lonDegrees = 5.5 + 1.3 * u(rng);
    p.altitudeMeters = 1000.0 * std::pow(300.0, u(rng));
    p.headingDegrees = 360.0 * u(rng);
    p.pitchDegrees = -5.0 - 55.0 * u(rng);
    return p;
  });
}

}  // namespace
}  // namespace pbdam::runtime

namespace pbdam::runtime {
namespace {

using precision::measurePrecision;
using precision::PrecisionFigures;

TEST(CameraRelative, MillimetreAccurateTwoMetresAboveOlympusMons) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const PrecisionFigures f = measurePrecision(dir, 18.4, -133.9);
  ASSERT_GT(f.vertices, 0u);
  EXPECT_LE(f.cameraRelative, 1e-3);
  EXPECT_GT(f.absoluteFloat, 0.1);  // the test fails without the technique
}

TEST(CameraRelative, MillimetreAccurateTwoMetresAboveTheHighestEtopo5Point) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  const PrecisionFigures f = measurePrecision(dir, 27.98, 86.92);
  ASSERT_GT(f.vertices, 0u);
  EXPECT_LE(f.cameraRelative, 1e-3);
  EXPECT_GT(f.absoluteFloat, 0.1);
}

TEST(PatchTexCoord, APatchIsTexturedFromTheTileItsDrawBindsInASparseQuadtree) {
  // The Luxembourg hybrid's texture quadtree is deep over the inset only: elsewhere a patch's
  // texture level has no tile and its draw binds the nearest coarser one (DatasetView::tileOf).
  // Its texture coordinates must place it in that tile; placed in the missing finer tile, they
  // drew another region's texels on it. Every vertex of a cut from 300 km over the inset's
  // surroundings: the shader's coordinate against the lattice-linear one in the bound tile.
  PBDAM_REQUIRE_DATASET(dir, "luxembourg");
  auto dataset = openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  const Manifest& m = view.manifest();
  test::PatchStore store(view);
  const Camera camera = Camera::fromPose(view.planet(), {48.0, 4.0, 300e3, 40.0, -50.0, 0.0},
                                         Viewport{640, 360, 60.0});
  const glm::dvec3 eye = camera.position();
  const Cut cut = refine(view, camera, {3.0, true, -1});
  const double size = static_cast<double>(m.textureTileTexels);
  const double inner = size - 2.0 * static_cast<double>(m.textureBorderTexels);
  std::size_t coarser = 0;
  std::size_t vertices = 0;
  double worstTexels = 0.0;
  for (const CutPatch& p : cut.patches) {
    const NodeRecord record = view.node(p.node);
    const TileKey tile = view.tileOf(p.node);
    const std::uint32_t tl = textureLevelOfHeap(tile.heap);
    if (tl < view.textureLevelOf(p.level)) ++coarser;
    const std::uint64_t inLevel = tile.heap - textureHeapIndex(tl, 0, 0);
    const double side = static_cast<double>(view.latticeCells() >> tl);
    const double qi = static_cast<double>(inLevel & ((std::uint64_t{1} << tl) - 1));
    const double qj = static_cast<double>(inLevel >> tl);
    const PatchDrawRecord draw =
        makePatchDrawRecord(view, PatchDrawInput{.node = p.node, .record = record}, eye);
    const PatchVertexPlacement placement(view, p.node, record);
    for (const PatchVertex& v : store.mesh(p.node).vertices) {
      LatticeXY q;
      ASSERT_TRUE(placement.latticePoint(v.b1, v.b2, q));
      const glm::dvec3 relative = exactVertexPosition(placement, v, eye);
      const glm::vec2 tc = shaderTexCoord(draw, glm::vec3(relative));
      const double ex = (m.textureBorderTexels + (q.x - qi * side) / side * inner) / size;
      const double ey = (m.textureBorderTexels + (q.y - qj * side) / side * inner) / size;
      worstTexels = std::max({worstTexels, std::abs(static_cast<double>(tc.x) - ex) * size,
                              std::abs(static_cast<double>(tc.y) - ey) * size});
      ++vertices;
    }
  }
  std::printf(
      "%zu patches (%zu in a coarser tile than their level's), %zu vertices: worst %.3g "
      "texels\n",
      cut.patches.size(), coarser, vertices, worstTexels);
  EXPECT_GT(coarser, 10u);
  EXPECT_GT(vertices, 10000u);
  EXPECT_LT(worstTexels, 0.05);
}

TEST(Refinement, CutsAreWithinTolerance) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  auto dataset = openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok());
  const std::vector<ToleranceCamera> cameras = toleranceCameras(view, *dem);
  ASSERT_EQ(cameras.size(), 60u);
  for (const ToleranceCamera& c : cameras) {
    const Cut cut = refine(view, c.camera, {c.tolerance, true, -1});
    for (const CutPatch& p : cut.patches) {
      const NodeRecord n = view.node(p.node);
      const double screen = c.camera.screenError(
          refinementErrorMeters(view, p.level, static_cast<double>(n.errorMeters)),
          {n.sphereCenter[0], n.sphereCenter[1], n.sphereCenter[2]},
          static_cast<double>(n.sphereRadiusMeters));
      // Every drawn patch is within the tolerance or a leaf.
      EXPECT_TRUE(p.level == view.depth() || screen <= c.tolerance)
          << "level " << p.level << " screen error " << screen;
      EXPECT_TRUE(p.tile == view.tileOf(p.node));
    }
  }
}

// The geomorph weights (docs/architecture.md "Geomorphing"): each patch's are 1 − f of its
// parent's and grandparent's screen errors; the windows nest, so a patch whose parent's diamond
// is part-way has a grandparent's that is fully on (weight 0); a patch blends its parent's tile
// exactly where the texture quadtree steps and its weight is above 0; refreshMorph of a cut
// gives what the refinement gave for the same camera; and the texture term shrinks by the
// dataset's margin per level.
TEST(Refinement, MorphWeightsFollowTheAncestorsAndTheirWindowsNest) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  auto dataset = openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& view = dataset->view();
  const double margin = view.manifest().errorMargin;
  for (int level = 0; level < view.depth(); ++level) {
    EXPECT_GE(view.textureTermOfLevel(level), (1.0 + margin) * view.textureTermOfLevel(level + 1));
  }
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok());
  const auto screenOf = [&](const Camera& camera, const NodeKey& key, int level) {
    const NodeRecord n = view.node(key);
    return camera.screenError(
        refinementErrorMeters(view, level, static_cast<double>(n.errorMeters)),
        {n.sphereCenter[0], n.sphereCenter[1], n.sphereCenter[2]},
        static_cast<double>(n.sphereRadiusMeters));
  };
  std::size_t partWay = 0, blending = 0;
  for (const ToleranceCamera& c : toleranceCameras(view, *dem)) {
    RefinementOptions options{c.tolerance, true, -1, 0.25};
    const Cut cut = refine(view, c.camera, options);
    for (const CutPatch& p : cut.patches) {
      NodeKey up = p.node;
      for (std::size_t k = 0; k < 2; ++k) {
        if (up.heap == 0) {
          EXPECT_EQ(p.morph[k], 0.0f);
          continue;
        }
        up.heap = (up.heap - 1) / 2;
        const double s = screenOf(c.camera, up, p.level - 1 - static_cast<int>(k));
        EXPECT_EQ(p.morph[k], morphWeight(s, c.tolerance, 0.25));
        EXPECT_GT(s, c.tolerance);  // an ancestor of a drawn patch is split
      }
      EXPECT_GE(p.morph[0], 0.0f);
      EXPECT_LT(p.morph[0], 1.0f);
      if (p.morph[0] > 0.0f) {
        ++partWay;
        EXPECT_EQ(p.morph[1], 0.0f) << "the grandparent's window overlaps the parent's";
      }
      const bool steps =
          p.level > 0 &&
          !(view.tileOf(NodeKey{p.node.face, p.node.tree, (p.node.heap - 1) / 2}) == p.tile);
      EXPECT_EQ(p.blendsTile(), steps && p.morph[0] > 0.0f);
      blending += static_cast<std::size_t>(p.blendsTile());
    }
    Cut again = cut;
    for (CutPatch& p : again.patches) p.morph = {0.5f, 0.5f};
    refreshMorph(view, c.camera, options, again);
    for (std::size_t i = 0; i < cut.patches.size(); ++i) {
      EXPECT_EQ(again.patches[i].morph, cut.patches[i].morph);
      EXPECT_TRUE(again.patches[i].morphTile == cut.patches[i].morphTile);
    }
    EXPECT_EQ(again.tiles.size(), cut.tiles.size());
    options.morphRange = 0.0;
    for (const CutPatch& p : refine(view, c.camera, options).patches) {
      EXPECT_EQ(p.morph[0], 0.0f);
      EXPECT_FALSE(p.blendsTile());
    }
  }
  EXPECT_GT(partWay, 0u);
  EXPECT_GT(blending, 0u);
  EXPECT_FALSE(checkMorphRange(view, margin + 0.01));
  EXPECT_FALSE(checkMorphRange(view, -0.1));
  EXPECT_TRUE(checkMorphRange(view, margin));
}

// Runs tests/runtime/CutWriter.cpp in a child process with `env` (shell assignments) before it
// and returns what it wrote.
std::string cutsOfChildProcess(const test::TempDir& tmp, const std::string& name,
                               const std::string& env) {
  const std::filesystem::path out = tmp / name;
  const std::string command = env + " '" + std::string(PBDAM_CUT_WRITER) + "' >'" + out.string() +
                              "' 2>'" + (tmp / (name + ".err")).string() + "'";
  const int status = std::system(command.c_str());
  std::ifstream in(out, std::ios::binary);
  std::string cuts{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::ifstream err(tmp / (name + ".err"));
  EXPECT_EQ(status, 0) << command << "\n" << err.rdbuf();
  return cuts;
}

// Cuts must not depend on where things land in memory (hash or pointer order) nor on the
// environment: the same cameras give byte-identical cuts here and in two child processes, each
// with its own address-space layout, one with a different environment size (moving the stack),
// glibc's malloc filling fresh memory with a pattern and a different arena count.
TEST(Refinement, CutsAreIdenticalAcrossProcesses) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  const std::string here = serializeToleranceCuts(dir, demPath);
  ASSERT_NE(here.find("cut 59\n"), std::string::npos);  // all 60 cameras, and no more
  ASSERT_EQ(here.find("cut 60\n"), std::string::npos);
  EXPECT_NE(here.find("patch "), std::string::npos);
  test::TempDir tmp;
  const std::string plain = cutsOfChildProcess(tmp, "plain.txt", "");
  const std::string perturbed = cutsOfChildProcess(
      tmp, "perturbed.txt",
      "PBDAM_STACK_SHIFT=" + std::string(4093, 'x') + " MALLOC_PERTURB_=165 MALLOC_ARENA_MAX=1");
  EXPECT_TRUE(plain == here) << "a child process computed different cuts (" << plain.size()
                             << " vs " << here.size() << " bytes)";
  EXPECT_TRUE(perturbed == here) << "a child process with another environment computed "
                                    "different cuts ("
                                 << perturbed.size() << " vs " << here.size() << " bytes)";
}

}  // namespace
}  // namespace pbdam::runtime
