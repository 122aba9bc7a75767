// pbdam build on real data (MOLA 4 px/deg, ETOPO5) checked by verify against the source DEM,
// determinism across thread counts, atomicity, rejection of bad options, and detection of a
// corrupted byte in every section of a face file ([P-BDAM 2003] §3–5; docs/builder.md); the
// out-of-core sample grid (files written in row ranges, mapped) equals the in-memory one.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <tuple>
#include <utility>

#include "SparseForest.h"
#include "TestData.h"
#include "pbdam/builder/Builder.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/builder/ForestShape.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/MorphTargets.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/builder/Verify.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

void writeFile(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Every file of dataset `a` has the same bytes in dataset `b`.
void expectSameFiles(const fs::path& a, const fs::path& b) {
  for (const auto& entry : fs::directory_iterator(a)) {
    const auto name = entry.path().filename();
    EXPECT_EQ(test::readFile(a / name), test::readFile(b / name)) << name;
  }
}

/// A small MOLA build: 17-vertex leaves, depth 6 (lattice 128), RGBA8 64-texel tiles.
/// Every node's stored error is at least (1 + margin) times each child's, and every interior
/// patch has at least `minTriangles` triangles (MOLA has no exact block), within the 16-bit
/// index limit.
void expectErrorTargetsHold(const fs::path& dataset, std::uint32_t minTriangles, double margin) {
  auto manifest = readManifest(dataset);
  ASSERT_TRUE(manifest) << manifest.error().message;
  EXPECT_EQ(manifest->minPatchTriangles, minTriangles);
  EXPECT_EQ(manifest->errorMargin, margin);
  std::size_t checked = 0;
  for (const ManifestFace& f : manifest->faces) {
    const std::string bytes = test::readFile(dataset / f.file);
    auto view =
        FaceView::open(std::as_bytes(std::span<const char>(bytes.data(), bytes.size())), f.file);
    ASSERT_TRUE(view) << view.error().message;
    for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
      const NodeRecord n = view->nodeAt(k);
      if (n.leaf()) continue;
      EXPECT_GE(n.triangleCount, minTriangles) << f.file << " node " << k;
      EXPECT_LE(n.vertexCount, kPatchMaxVertices);
      const std::uint64_t first = view->firstChildOf(k);
      for (const std::uint64_t child : {first, first + 1}) {
        const double e = static_cast<double>(view->nodeAt(child).errorMeters);
        EXPECT_GE(static_cast<double>(n.errorMeters), (1.0 + margin) * e * (1.0 - 1e-6))
            << f.file << " node " << k << " child " << child;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000u);
}

BuildOptions smallMola(const fs::path& dem, const fs::path& out) {
  BuildOptions o;
  o.demPath = dem;
  o.planetSpec = "mars";
  o.outDir = out;
  o.leafVertices = 17;
  o.minPatchTriangles = 128;
  o.depth = 6;
  o.textureTileTexels = 64;
  o.textureFormat = TexelFormat::Rgba8;
  o.threads = 2;
  return o;
}

VerifyReport verify(const fs::path& dir, const fs::path& dem = {},
                    const std::vector<InsetSpec>& insets = {}) {
  VerifyOptions v;
  v.datasetDir = dir;
  v.demPath = dem;
  v.insets = insets;
  auto r = verifyDataset(v);
  EXPECT_TRUE(r) << (r ? "" : r.error().message);
  return r ? *r : VerifyReport{};
}

std::string describe(const VerifyReport& r) {
  std::string s = std::to_string(r.violationCount) + " violations";
  for (const auto& v : r.violations) s += "\n  " + v;
  return s;
}

TEST(Builder, MolaBuildPassesVerifyAgainstTheDem) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  auto summary = buildDataset(smallMola(dem, dir / "mola"));
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->latticeCells, 128u);
  EXPECT_EQ(summary->depth, 6u);
  EXPECT_EQ(summary->patches, 12u * 127u);
  EXPECT_EQ(summary->leafTriangles, 12u * 64u * 256u);
  EXPECT_EQ(summary->halvesOverTarget, 0u);
  EXPECT_LT(summary->patchBytesCompressed, summary->patchBytesRaw / 2);  // ≤ 50% compressed
  // Interior patches carry what their error targets need: far fewer triangles than leaves.
  EXPECT_LT(summary->totalTriangles, 3 * summary->leafTriangles);
  expectErrorTargetsHold(dir / "mola", 128, 0.25);

  const VerifyReport r = verify(dir / "mola", dem);
  EXPECT_TRUE(r.ok()) << describe(r);
  EXPECT_EQ(r.patchesDecoded, 12u * 127u);
  EXPECT_EQ(r.morphTargetsChecked, 12u * 127u);
  EXPECT_GT(r.edgesCompared, 1000u);
  EXPECT_GT(r.demSamplesChecked, 1000000u);  // every level covers all 1,036,800 samples
  EXPECT_LE(r.worstErrorRatio, 1.0);

  auto manifest = readManifest(dir / "mola");
  ASSERT_TRUE(manifest) << manifest.error().message;
  EXPECT_EQ(manifest->planetSpec, "mars");
  EXPECT_NEAR(manifest->maxHeightMeters, 21000.0, 500.0);  // Olympus Mons, resampled
  EXPECT_NEAR(manifest->minHeightMeters, -8000.0, 500.0);  // Hellas
}

// Morph targets (dataset format 4, MorphTargets.h): every patch that has a vertex governed by
// the same diamond gives it the same target, across diamond partners, levels and cube faces —
// what keeps a morphing cut watertight — and a vertex the governing patch passes through keeps
// its own height. Roots have none.
TEST(Builder, MorphTargetsAgreeWherePatchesShareAVertexAndItsGoverningDiamond) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  auto summary = buildDataset(smallMola(dem, dir / "mola"));
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_GT(summary->morphTargetBytes, 0u);
  auto manifest = readManifest(dir / "mola");
  ASSERT_TRUE(manifest) << manifest.error().message;
  const int depth = static_cast<int>(manifest->depth);
  const Lattice lattice(manifest->latticeCells);
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  // (vertex key, governing diamond's diagonal) -> (target, patches that gave it)
  std::map<std::pair<runtime::PointKey, EdgeKey>, std::pair<std::int32_t, int>> seen;
  std::size_t moved = 0;
  for (std::size_t f = 0; f < 6; ++f) {
    const std::string bytes = test::readFile(dir / "mola" / manifest->faces[f].file);
    auto view = FaceView::open(std::as_bytes(std::span<const char>(bytes.data(), bytes.size())),
                               manifest->faces[f].file);
    ASSERT_TRUE(view) << view.error().message;
    std::vector<std::byte> buffer;
    PatchMesh mesh;
    std::vector<std::int32_t> targets;
    for (std::uint64_t row = 0; row < view->header().nodeCount; ++row) {
      const NodeRecord record = view->nodeAt(row);
      const std::uint64_t tree = row >= view->treeFirstNode(1) ? 1 : 0;
      const std::uint64_t id = (f * 2 + tree) * perTree + record.heapIndex;
      const runtime::BinTriangle t = triangleOfNode(lattice, id, depth);
      auto blobs = view->readPatchBlobs(record, buffer);
      ASSERT_TRUE(blobs) << blobs.error().message;
      ASSERT_TRUE(decodePatch(blobs->patch, mesh, "patch"));
      ASSERT_TRUE(decodeMorphTargets(blobs->morph, mesh, targets, "targets"));
      if (t.level == 0) {
        EXPECT_EQ(record.morphBytes, 0u);
        continue;
      }
      EXPECT_GT(record.morphBytes, 0u);
      const auto points = patchLatticePoints(t, mesh);
      ASSERT_TRUE(points);
      const NodeAncestors up = nodeAncestors(id, perTree);
      for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        const bool hypotenuse =
            std::uint32_t{mesh.vertices[v].b1} + mesh.vertices[v].b2 == kPatchBarycentricOne;
        const std::optional<std::uint64_t> governing = hypotenuse ? up.grandparent : up.parent;
        const std::int32_t own = mesh.vertices[v].heightSteps;
        if (!governing) {
          EXPECT_EQ(targets[v], own);
          continue;
        }
        const runtime::BinTriangle g = triangleOfNode(lattice, *governing, depth);
        const runtime::LatticeXY q = (*points)[v];
        if (q == g.apex || q == g.left || q == g.right) {
          EXPECT_EQ(targets[v], own);
        }
        moved += static_cast<std::size_t>(targets[v] != own);
        const auto key = std::make_pair(lattice.key(static_cast<int>(f), q),
                                        lattice.edgeKey(static_cast<int>(f), g.left, g.right));
        const auto [it, inserted] = seen.try_emplace(key, targets[v], 0);
        EXPECT_EQ(it->second.first, targets[v]) << "face " << f << " node " << id;
        ++it->second.second;
      }
    }
  }
  std::size_t shared = 0;
  for (const auto& [key, value] : seen) shared += static_cast<std::size_t>(value.second >= 2);
  EXPECT_GT(shared, 10000u);
  EXPECT_GT(moved, 10000u);
}

// Verify walks forests of any shape (dataset format 3): the small MOLA build pruned to full depth
// only near a box (ForestShape's closed set of split diamonds) passes against the DEM; with a
// rule that splits one tree of a face but not its neighbour across the face's diagonal, verify
// names the diamonds split on one side.
TEST(Builder, VerifyWalksAPrunedForestAndNamesAnUnclosedOne) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  ASSERT_TRUE(buildDataset(smallMola(dem, dir / "mola")));
  // Leaves of level 6 (the build's depth) over a box on Mars, level 2 elsewhere, closed.
  const Lattice lattice(128);
  const ForestShape shape =
      ForestShape::make(lattice, Planet::mars(), 2, {DeepRegion{{10.0, 60.0, 20.0, 75.0}, 6}});
  ASSERT_EQ(shape.depth(), 6);
  test::PruneRules closed;
  closed.splitNode = [&](const BinTriangle& t) {
    return shape.isSplit(t.level, nodeId(t, shape.depth()));
  };
  closed.splitTile = [](int face, std::uint32_t, std::uint32_t, std::uint32_t) {
    return face == 2;
  };
  test::writePrunedDataset(dir / "mola", dir / "pruned", closed);
  const VerifyReport r = verify(dir / "pruned", dem);
  EXPECT_TRUE(r.ok()) << describe(r);
  EXPECT_LT(r.patchesDecoded, 12u * 127u / 2);
  EXPECT_GT(r.edgesCompared, 100u);

  test::PruneRules oneSided = closed;
  oneSided.splitNode = [](const BinTriangle& t) {
    return t.level < 1 || (t.face == 0 && t.tree == 0 && t.level < 3);
  };
  test::writePrunedDataset(dir / "mola", dir / "unclosed", oneSided);
  const VerifyReport bad = verify(dir / "unclosed");
  EXPECT_FALSE(bad.ok());
  const std::string all = describe(bad);
  EXPECT_NE(all.find("split, but its diamond partner does not exist"), std::string::npos) << all;
}

// An adaptive forest built directly: MOLA at depth 2 with leaves of level 6 over a box (the
// lattice of the deepest leaves everywhere). Verify against the DEM passes: errors bound every
// sample, diamonds are closed, every shared edge agrees — at the border too, where an odd leaf
// without a partner keeps its hypotenuse coarse.
TEST(Builder, AnAdaptiveForestPassesVerifyAgainstTheDem) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  BuildOptions o = smallMola(dem, dir / "adaptive");
  o.depth = 2;
  o.deepRegions = {DeepRegion{{10.0, 60.0, 20.0, 75.0}, 6}};
  auto summary = buildDataset(o);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->latticeCells, 128u);
  EXPECT_EQ(summary->depth, 6u);
  EXPECT_LT(summary->patches, 12u * 127u / 2);
  // The lattice is dense only where the deep leaves are. Its tiles are the base's squares
  // (here a quarter face each); those away from the region keep every 4th point of each row
  // and column (the base leaves' spacing).
  EXPECT_LT(summary->latticeSamples, 6u * 129u * 129u / 2u);
  const VerifyReport r = verify(dir / "adaptive", dem);
  EXPECT_TRUE(r.ok()) << describe(r);
  EXPECT_EQ(r.patchesDecoded, summary->patches);
  EXPECT_GT(r.edgesCompared, 100u);
  EXPECT_LE(r.worstErrorRatio, 1.0);
  // Leaves at several levels, odd ones among them, some without a diamond partner.
  std::set<int> leafLevels;
  std::size_t oddLeaves = 0;
  auto manifest = readManifest(dir / "adaptive");
  ASSERT_TRUE(manifest) << manifest.error().message;
  for (const ManifestFace& f : manifest->faces) {
    const std::string bytes = test::readFile(dir / "adaptive" / f.file);
    auto view =
        FaceView::open(std::as_bytes(std::span<const char>(bytes.data(), bytes.size())), f.file);
    ASSERT_TRUE(view) << view.error().message;
    for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
      const NodeRecord n = view->nodeAt(k);
      if (!n.leaf()) continue;
      const int level = bintreeLevel(n.heapIndex);
      leafLevels.insert(level);
      oddLeaves += level % 2 == 1 ? 1U : 0U;
    }
  }
  EXPECT_GE(leafLevels.size(), 4u);
  EXPECT_TRUE(leafLevels.contains(2));
  EXPECT_TRUE(leafLevels.contains(6));
  EXPECT_GT(oddLeaves, 0u);
  // Tiles only as deep as the leaves under them: fewer than the complete quadtree's.
  EXPECT_EQ(r.tilesDecoded, summary->textureTiles);
  EXPECT_LT(summary->textureTiles,
            6 * ((std::uint64_t{1} << (2 * manifest->textureLevels)) - 1) / 3);
  EXPECT_GT(manifest->textureLevels, 1u);
}

TEST(Builder, Etopo5BuildPassesVerifyAgainstTheDem) {
  PBDAM_REQUIRE_DATA(dem, PBDAM_ETOPO5_PATH);
  test::TempDir dir;
  BuildOptions o = smallMola(dem, dir / "earth");
  o.planetSpec = "earth";
  o.textureFormat = TexelFormat::Bc1;
  auto summary = buildDataset(o);
  ASSERT_TRUE(summary) << summary.error().message;
  const VerifyReport r = verify(dir / "earth", dem);
  EXPECT_TRUE(r.ok()) << describe(r);
  EXPECT_GT(r.demSamplesChecked, 9000000u);
}

// ETOPO5 (5′) with the Luxembourg GeoTIFF (30″) joined to it: the forest goes to the inset's
// density only around it, the stored errors bound the composite's samples (verify with the
// inset), and inside the inset beyond its band the terrain is the GeoTIFF's within the leaf's
// stored error.
TEST(Builder, Etopo5WithTheLuxembourgInsetVerifiesAndAnswersTheInsetsHeights) {
  PBDAM_REQUIRE_DATA(dem, PBDAM_ETOPO5_PATH);
  PBDAM_REQUIRE_DATA(luxembourg, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  test::TempDir dir;
  BuildOptions o = smallMola(dem, dir / "lux");
  o.planetSpec = "earth";
  o.insets = {InsetSpec{luxembourg, {}, {}}};
  auto summary = buildDataset(o);
  ASSERT_TRUE(summary) << summary.error().message;
  // 30″ needs 10800 cells across 90°: 16384, leaves of 16 cells at level 20.
  EXPECT_EQ(summary->latticeCells, 16384u);
  EXPECT_EQ(summary->depth, 20u);
  EXPECT_LT(summary->latticeSamples, 6u * 16385u * 16385u / 100u);
  auto manifest = readManifest(dir / "lux");
  ASSERT_TRUE(manifest) << manifest.error().message;
  ASSERT_EQ(manifest->insets.size(), 1u);
  EXPECT_EQ(manifest->insets[0].file, "terra_elev_luxembourg.tif");
  EXPECT_EQ(manifest->insets[0].leafLevel, 20u);
  EXPECT_EQ(manifest->insets[0].bandSamples, 16u);
  EXPECT_NEAR(manifest->insets[0].northDegrees, 50.19, 0.01);
  const VerifyReport report = verify(dir / "lux", dem, o.insets);
  EXPECT_TRUE(report.ok()) << describe(report);
  EXPECT_LE(report.worstErrorRatio, 1.0);

  auto etopo = readDem(dem);
  auto lux = readDem(luxembourg);
  ASSERT_TRUE(etopo && lux);
  const HeightGrid grid = *lux;
  auto made = CompositeSurface::make(*etopo, o.insets, std::vector<HeightGrid>{*lux});
  ASSERT_TRUE(made) << made.error().message;
  const CompositeSurface& composite = *made;
  auto dataset = streaming::MappedDataset::open(dir / "lux");
  ASSERT_TRUE(dataset) << dataset.error().message;
  std::size_t checked = 0;
  double worst = 0.0;  // of |height − GeoTIFF| / stored leaf error
  for (std::int64_t r = 0; r < grid.height(); r += 3) {
    for (std::int64_t c = 0; c < grid.width(); c += 3) {
      // Between samples, where bilinear interpolation differs from the samples.
      const double lat = grid.latOfRowDegrees(r) + 0.3 * grid.geometry().latSpacingDegrees;
      const double lon = grid.lonOfColumnDegrees(c) + 0.6 * grid.geometry().lonSpacingDegrees;
      if (composite.weightOf(0, lat, lon) < 1.0) continue;
      const auto expected = grid.sampleBilinear(lat, lon);
      auto h = runtime::surfaceHeightAt((*dataset)->view(), lat, lon);
      ASSERT_TRUE(h && expected);
      EXPECT_LE(std::abs(h->heightMeters - *expected), h->leafErrorMeters + 1e-3)
          << lat << ", " << lon;
      worst = std::max(worst, std::abs(h->heightMeters - *expected) / h->leafErrorMeters);
      EXPECT_NE(h->leafSources & 2U, 0U) << "the answer names the inset as its source";
      ++checked;
    }
  }
  std::printf("%zu points inside Luxembourg, worst at %.0f%% of the leaf error\n", checked,
              100.0 * worst);
  EXPECT_GT(checked, 20u);
  // Far from it, only the base.
  auto paris = runtime::surfaceHeightAt((*dataset)->view(), 48.85, 2.35);
  ASSERT_TRUE(paris);
  EXPECT_EQ(paris->leafSources, 1U);
}

// Past the 2^15 cells a patch's barycentrics address exactly: a 1″ (~30 m) inset made from
// the real Luxembourg DEM (bilinear, plus deterministic detail down to its spacing) on ETOPO5
// needs 2^19 cells a face side. Coarse patches put their vertices on the sub-lattice their legs
// address; the dataset verifies against the base and the inset, and inside the inset the
// terrain is the inset's within the leaf's stored error, from leaves of the inset's level.
TEST(Builder, AnInsetFinerThan2To15CellsAFaceBuildsVerifiesAndAnswersItsHeights) {
  PBDAM_REQUIRE_DATA(dem, PBDAM_ETOPO5_PATH);
  PBDAM_REQUIRE_DATA(luxembourg, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  test::TempDir dir;
  auto lux = readDem(luxembourg);
  ASSERT_TRUE(lux) << lux.error().message;
  // 0.05° × 0.05° at 1″: 180 × 180 samples over 49.80–49.85°N, 6.05–6.10°E.
  constexpr int kSide = 180;
  constexpr double kStep = 1.0 / 3600.0;
  const fs::path fine = dir / "lux_1s.asc";
  {
    std::ofstream out(fine);
    out << "ncols " << kSide << "\nnrows " << kSide << "\nxllcorner 6.05\nyllcorner 49.80\n"
        << "cellsize " << kStep << "\nNODATA_value -9999\n";
    out.precision(9);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) {
        const double lat = 49.85 - (r + 0.5) * kStep;
        const double lon = 6.05 + (c + 0.5) * kStep;
        const double detail =
            12.0 * std::sin(0.37 * c) * std::cos(0.23 * r) + 3.0 * std::sin(1.9 * c + 1.3 * r);
        out << lux->sampleBilinear(lat, lon).value_or(300.0) + detail
            << (c + 1 < kSide ? " " : "\n");
      }
    }
    std::ofstream prj(dir / "lux_1s.prj");
    prj << R"(GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],)"
        << R"(PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]])";
  }
  BuildOptions o = smallMola(dem, dir / "fine");
  o.planetSpec = "earth";
  o.depth = 4;
  o.insets = {InsetSpec{fine, {}, {}}};
  auto summary = buildDataset(o);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_GE(summary->latticeCells, 1u << 19);
  EXPECT_GE(summary->depth, 30u);
  const VerifyReport report = verify(dir / "fine", dem, o.insets);
  EXPECT_TRUE(report.ok()) << describe(report);

  auto grid = readDem(fine);
  ASSERT_TRUE(grid) << grid.error().message;
  auto dataset = streaming::MappedDataset::open(dir / "fine");
  ASSERT_TRUE(dataset) << dataset.error().message;
  std::size_t checked = 0;
  for (std::int64_t r = 50; r < kSide - 50; r += 7) {
    for (std::int64_t c = 50; c < kSide - 50; c += 7) {
      const double lat = grid->latOfRowDegrees(r) + 0.3 * kStep;
      const double lon = grid->lonOfColumnDegrees(c) + 0.6 * kStep;
      const auto expected = grid->sampleBilinear(lat, lon);
      auto h = runtime::surfaceHeightAt((*dataset)->view(), lat, lon);
      ASSERT_TRUE(h && expected);
      EXPECT_LE(std::abs(h->heightMeters - *expected), h->leafErrorMeters + 1e-3)
          << lat << ", " << lon;
      EXPECT_EQ(runtime::bintreeLevel(h->leaf.heap), static_cast<int>(summary->depth))
          << "not a leaf of the inset's level at " << lat << ", " << lon;
      EXPECT_LT(h->leafErrorMeters, 10.0);
      ++checked;
    }
  }
  EXPECT_GT(checked, 20u);
}

TEST(Builder, SameInputsGiveIdenticalBytesForAnyThreadCountAndDemStorage) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  BuildOptions a = smallMola(dem, dir / "a");
  a.depth = 4;
  a.threads = 1;
  BuildOptions b = a;
  b.outDir = dir / "b";
  b.threads = 2;
  // b reads the DEM out of core (an unnamed scratch file, mapped) as large DEMs are; MOLA
  // counts as large with demMapAtBytes 0. Neither may change a byte, and nothing is left behind.
  b.demMapAtBytes = 0;
  ASSERT_TRUE(buildDataset(a));
  ASSERT_TRUE(buildDataset(b));
  expectSameFiles(dir / "a", dir / "b");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), 2)
      << "a scratch file was left in " << dir.path();
  // Rebuilding over the same directory needs --force and reproduces the same bytes.
  const std::string before = test::readFile(dir / "a" / "face3.pbdam");
  auto again = buildDataset(a);
  ASSERT_FALSE(again);
  EXPECT_NE(again.error().message.find("--force"), std::string::npos);
  a.force = true;
  ASSERT_TRUE(buildDataset(a));
  EXPECT_EQ(test::readFile(dir / "a" / "face3.pbdam"), before);
}

TEST(Builder, ADirectoryWithoutManifestIsNotADataset) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  BuildOptions o = smallMola(dem, dir / "d");
  o.depth = 2;
  ASSERT_TRUE(buildDataset(o));
  // A build killed before its last step leaves face files but no manifest.
  fs::remove(dir / "d" / "manifest.json");
  VerifyOptions v;
  v.datasetDir = dir / "d";
  auto r = verifyDataset(v);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::NotFound);
  EXPECT_FALSE(readManifest(dir / "d"));
}

// Version 5 added the normal-map tiles (formats/FORMAT.md): a version-4 dataset is refused, naming
// the file, its version and what to do, for the manifest and for each face file.
TEST(Builder, AnOlderFormatVersionIsRefusedNamingTheFileAndTheRebuild) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  BuildOptions o = smallMola(dem, dir / "d");
  o.depth = 2;
  const auto built = buildDataset(o);
  ASSERT_TRUE(built) << built.error().message;
  ASSERT_EQ(kDatasetFormatVersion, 5u);

  // A face file whose header says version 4 (its header checksum made valid again): the version
  // is read before the texture records, whose last field version 5 added.
  const fs::path facePath = dir / "d" / "face4.pbdam";
  std::string face = test::readFile(facePath);
  const auto headerBytes = std::as_bytes(std::span(face.data(), kFaceHeaderBytes));
  auto header = decodeFaceHeader(headerBytes, face.size(), facePath.string());
  ASSERT_TRUE(header) << header.error().message;
  header->version = 4;
  std::array<std::byte, kFaceHeaderBytes> patched{};
  encodeFaceHeader(*header, patched);
  std::memcpy(face.data(), patched.data(), patched.size());
  const auto old =
      decodeFaceHeader(std::as_bytes(std::span(face.data(), face.size())), facePath.string());
  ASSERT_FALSE(old);
  EXPECT_EQ(old.error().code, ErrorCode::CorruptData);
  for (const std::string& part :
       {facePath.string(), std::string("format version 4"), std::string("reads version 5"),
        std::string("rebuild the dataset")}) {
    EXPECT_NE(old.error().message.find(part), std::string::npos) << old.error().message;
  }

  // A manifest that says version 4 (its own checksum recomputed).
  auto manifest = readManifest(dir / "d");
  ASSERT_TRUE(manifest) << manifest.error().message;
  manifest->version = 4;
  writeFile(dir / "d" / "manifest.json", manifestToJson(*manifest));
  const auto refused = readManifest(dir / "d");
  ASSERT_FALSE(refused);
  for (const std::string& part : {std::string("manifest.json"), std::string("format version 4"),
                                  std::string("rebuild the dataset")}) {
    EXPECT_NE(refused.error().message.find(part), std::string::npos) << refused.error().message;
  }
}

TEST(Builder, RejectsBadOptions) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  auto expectRejected = [&](const BuildOptions& o, const std::string& mention) {
    auto r = buildDataset(o);
    ASSERT_FALSE(r) << mention;
    EXPECT_NE(r.error().message.find(mention), std::string::npos) << r.error().message;
  };
  BuildOptions o = smallMola(dem, dir / "x");
  o.leafVertices = 20;
  expectRejected(o, "--leaf-vertices");
  o = smallMola(dem, dir / "x");
  o.depth = 5;
  expectRejected(o, "--levels");
  o = smallMola(dem, dir / "x");
  o.textureTileTexels = 30;
  expectRejected(o, "--texture-tile");
  o.textureTileTexels = 20;  // BC1's multiple of 4, but its normal map would be 10
  expectRejected(o, "multiple of 8");
  o = smallMola(dem, dir / "x");
  o.planetSpec = "pluto";
  expectRejected(o, "pluto");
  o = smallMola(dem, dir / "x");
  o.planetSpec = "earth";  // MOLA's CRS is on Mars
  expectRejected(o, "mars");
  o = smallMola(dir / "missing.lbl", dir / "x");
  expectRejected(o, "missing.lbl");
  EXPECT_FALSE(fs::exists(dir / "x" / "manifest.json"));
}

class CorruptionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const fs::path dem = test::dataDir() / "mars/megt90n000cb.lbl";
    if (!test::missingFileMessage(dem).empty()) return;
    dir_ = std::make_unique<test::TempDir>();
    BuildOptions o = smallMola(dem, dir_->path() / "ds");
    o.depth = 2;
    ASSERT_TRUE(buildDataset(o));
  }
  static void TearDownTestSuite() { dir_.reset(); }
  static std::unique_ptr<test::TempDir> dir_;
};
std::unique_ptr<test::TempDir> CorruptionTest::dir_;

TEST_F(CorruptionTest, AByteFlippedInAnySectionIsCaughtByVerifyAndByDecode) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  ASSERT_NE(dir_, nullptr);
  const fs::path face = dir_->path() / "ds" / "face2.pbdam";
  const std::string original = test::readFile(face);
  auto span = [](const std::string& s) {
    return std::as_bytes(std::span<const char>(s.data(), s.size()));
  };
  auto view = FaceView::open(span(original), "face2");
  ASSERT_TRUE(view);
  const FaceHeader h = view->header();
  const NodeRecord node = view->node(1, 2);
  const TextureRecord tile = view->textureNode(0);
  const std::vector<std::pair<std::string, std::uint64_t>> sections = {
      {"header", 20},
      {"node table", h.nodeTableOffset + 5 * kNodeRecordBytes + 17},
      {"texture table", h.textureTableOffset + 3},
      {"patch blob", node.blobOffset + node.blobBytes / 2},
      {"texture tile", tile.blobOffset + tile.blobBytes / 3},
  };
  for (const auto& [section, offset] : sections) {
    std::string damaged = original;
    damaged[offset] = static_cast<char>(damaged[offset] ^ 0x20);
    writeFile(face, damaged);
    const VerifyReport r = verify(dir_->path() / "ds");
    EXPECT_FALSE(r.ok()) << section;
    // Decoding the damaged section fails too.
    auto damagedView = FaceView::open(span(damaged), "face2");
    if (section == "header" || section == "node table" || section == "texture table") {
      EXPECT_FALSE(damagedView) << section;
    } else if (section == "patch blob") {
      ASSERT_TRUE(damagedView);
      PatchMesh mesh;
      std::vector<std::byte> blob;
      const auto bytes = damagedView->readPatchBlob(damagedView->node(1, 2), blob);
      ASSERT_TRUE(bytes);
      EXPECT_FALSE(decodePatch(*bytes, mesh, "x"));
    } else {
      ASSERT_TRUE(damagedView);
      std::vector<std::byte> blob;
      const auto bytes = damagedView->readTextureBlobs(damagedView->textureNode(0), blob);
      ASSERT_TRUE(bytes);
      EXPECT_FALSE(decodeTextureTile(bytes->colour, "x"));
    }
  }
  writeFile(face, original);
  EXPECT_TRUE(verify(dir_->path() / "ds").ok());
  // The manifest carries its own checksum.
  const fs::path manifestPath = dir_->path() / "ds" / "manifest.json";
  const std::string manifest = test::readFile(manifestPath);
  std::string edited = manifest;
  const auto at = edited.find("\"min_patch_triangles\": 128");
  ASSERT_NE(at, std::string::npos);
  edited.replace(at, 26, "\"min_patch_triangles\": 129");
  writeFile(manifestPath, edited);
  EXPECT_FALSE(verify(dir_->path() / "ds").ok());
  writeFile(manifestPath, manifest);
  // A truncated face file.
  writeFile(face, original.substr(0, original.size() - 100));
  EXPECT_FALSE(verify(dir_->path() / "ds").ok());
  writeFile(face, original);
}

TEST(Lattice, DiamondsPairEveryHypotenuseAcrossFaces) {
  const Lattice lattice(64);
  for (int level = 0; level <= 6; ++level) {
    const auto diamonds = diamondsOfLevel(lattice, 6, level);
    EXPECT_EQ(diamonds.size(), 6u << level) << level;
    int crossFace = 0;
    for (const Diamond& d : diamonds) {
      const BinTriangle a = triangleOfNode(lattice, d[0], 6);
      const BinTriangle b = triangleOfNode(lattice, d[1], 6);
      EXPECT_EQ(lattice.edgeKey(a.face, a.left, a.right), lattice.edgeKey(b.face, b.left, b.right));
      EXPECT_EQ(a.level, level);
      crossFace += a.face != b.face;
    }
    // Odd levels' hypotenuses are axis-aligned; those on face edges pair across faces.
    if (level == 1) {
      EXPECT_EQ(crossFace, 12);
    }
    if (level == 0) {
      EXPECT_EQ(crossFace, 0);
    }
  }
}

}  // namespace
}  // namespace pbdam::builder
