// Forests whose depth varies (dataset format 3: sparse node and texture tables with leaf flags):
// MOLA's test dataset pruned to the builder's closed forest shape for a box on Olympus Mons: full
// depth there, level 2 far away.
// The runtime refines such a forest to the same cut as the complete one stopped at the pruned
// leaves, the cut is watertight, every tile it names exists, height queries end at leaves of any
// level, and face files whose tables are not a forest are rejected with a clear error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <set>

#include "ClosedManifold.h"
#include "SparseForest.h"
#include "TestData.h"
#include "pbdam/builder/ForestShape.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::runtime {
namespace {

constexpr double kLat = 18.65, kLon = -133.8;  // Olympus Mons
constexpr double kRadius = 0.03;               // on the unit sphere: ~100 km on Mars

// Keeps every tile (a pruned quadtree changes the per-level texture term, and with it the cut).
test::PruneRules withAllTiles(test::PruneRules rules) {
  rules.splitTile = [](int, std::uint32_t, std::uint32_t, std::uint32_t) { return true; };
  return rules;
}

// Full depth over a 3° box on Olympus Mons, level 2 elsewhere: the builder's closed forest shape
// (ForestShape). A tile splits when its square's centre is within the radius plus its side:
// only Olympus Mons's face keeps more than its root.
test::PruneRules aroundOlympus(std::uint32_t n, int depth) {
  const glm::dvec3 target = CubeMap::faceUvToDirection(CubeMap::latLonToFaceUv(kLat, kLon));
  auto shape = std::make_shared<const builder::ForestShape>(builder::ForestShape::make(
      builder::Lattice(n), Planet::mars(), 2,
      {builder::DeepRegion{{kLat - 1.5, 360.0 + kLon - 1.5, kLat + 1.5, 360.0 + kLon + 1.5},
                           depth}}));
  test::PruneRules rules;
  rules.splitNode = [shape](const BinTriangle& t) {
    return shape->isSplit(t.level, builder::nodeId(t, shape->depth()));
  };
  rules.splitTile = [target](int face, std::uint32_t level, std::uint32_t qi, std::uint32_t qj) {
    const double side = 1.0 / static_cast<double>(1U << level);
    const glm::dvec3 c =
        CubeMap::faceUvToDirection(cubeFaceFromIndex(face), glm::dvec2(qi + 0.5, qj + 0.5) * side);
    return glm::length(c - target) < kRadius + side;
  };
  return rules;
}

class SparseForest : public ::testing::Test {
 protected:
  void SetUp() override {
    PBDAM_REQUIRE_DATASET(complete, "mola");
    completeDir_ = complete;
    prunedDir_ = std::filesystem::temp_directory_path() /
                 ("pbdam-sparse-forest-" + std::to_string(::getpid()));
    auto manifest = readManifest(complete);
    ASSERT_TRUE(manifest.ok());
    rules_ = aroundOlympus(manifest->latticeCells, static_cast<int>(manifest->depth));
    test::writePrunedDataset(complete, prunedDir_, withAllTiles(rules_));
    auto full = MappedDataset::open(complete);
    auto pruned = MappedDataset::open(prunedDir_);
    ASSERT_TRUE(full.ok()) << full.error().message;
    ASSERT_TRUE(pruned.ok()) << pruned.error().message;
    full_ = std::move(full).value();
    pruned_ = std::move(pruned).value();
  }
  void TearDown() override {
    pruned_.reset();
    if (!prunedDir_.empty()) std::filesystem::remove_all(prunedDir_);
  }

  test::PruneRules rules_;
  std::filesystem::path completeDir_, prunedDir_;
  std::unique_ptr<MappedDataset> full_, pruned_;
};

TEST_F(SparseForest, LeavesLieAtManyLevelsAndTheFileIsSmaller) {
  const DatasetView& view = pruned_->view();
  std::set<int> leafLevels;
  std::uint64_t nodes = 0, completeNodes = 0;
  for (int f = 0; f < 6; ++f) {
    const FaceView& face = view.face(f);
    EXPECT_FALSE(face.completeForest());
    EXPECT_TRUE(full_->view().face(f).completeForest());
    nodes += face.header().nodeCount;
    completeNodes += full_->view().face(f).header().nodeCount;
    for (std::uint64_t k = 0; k < face.header().nodeCount; ++k) {
      const NodeRecord n = face.nodeAt(k);
      if (n.leaf()) leafLevels.insert(bintreeLevel(n.heapIndex));
    }
  }
  std::printf("leaf levels %d .. %d, %llu of %llu nodes\n", *leafLevels.begin(),
              *leafLevels.rbegin(), static_cast<unsigned long long>(nodes),
              static_cast<unsigned long long>(completeNodes));
  EXPECT_LE(*leafLevels.begin(), 3);
  EXPECT_EQ(*leafLevels.rbegin(), view.depth());
  EXPECT_GE(leafLevels.size(), 5u);
  EXPECT_LT(nodes * 4, completeNodes);
}

// Every cut of the pruned forest is the complete forest's cut for the same camera, each patch
// replaced by its pruned ancestor; and it is watertight.
TEST_F(SparseForest, CutsAreTheCompleteCutsStoppedAtTheLeavesAndWatertight) {
  const DatasetView& view = pruned_->view();
  test::PatchStore store(view);
  const Viewport viewport{320, 180, 60.0};
  for (const double altitude : {20e3, 300e3, 3000e3}) {
    SCOPED_TRACE("altitude " + std::to_string(altitude));
    const Camera camera =
        Camera::fromPose(view.planet(), {kLat, kLon, altitude, 0, -60, 0}, viewport);
    const Cut fullCut = refine(full_->view(), camera, {1.0, false, -1});
    const Cut cut = refine(view, camera, {1.0, false, -1});
    std::vector<NodeKey> expected;
    for (const CutPatch& p : fullCut.patches) {
      NodeKey k = p.node;
      while (!view.hasNode(k)) k.heap = (k.heap - 1) / 2;
      if (expected.empty() || !(expected.back() == k)) expected.push_back(k);
    }
    ASSERT_EQ(cut.patches.size(), expected.size());
    std::set<int> levels;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      ASSERT_EQ(cut.patches[i].node, expected[i]) << "patch " << i;
      levels.insert(cut.patches[i].level);
      // Every tile a cut names exists, at the patch's tile level or the finest above it.
      const TileKey tile = cut.patches[i].tile;
      ASSERT_TRUE(view.face(tile.face).findTexture(tile.heap).has_value());
      EXPECT_LE(textureLevelOfHeap(tile.heap), view.textureLevelOf(cut.patches[i].level));
    }
    EXPECT_GE(levels.size(), 3u);
    const test::MeshCheck check = test::checkClosedManifold(view, cut, camera.position(), store);
    EXPECT_EQ(check.badEdges, 0u);
    EXPECT_EQ(check.degenerate, 0u);
    EXPECT_EQ(check.euler(), 2);
  }
}

TEST_F(SparseForest, TilesFallBackToTheFinestThatExists) {
  const std::filesystem::path dir = prunedDir_ / "tiles";
  test::writePrunedDataset(completeDir_, dir, rules_);
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  std::uint64_t tiles = 0;
  for (int f = 0; f < 6; ++f) tiles += view.face(f).header().textureNodeCount;
  EXPECT_LT(tiles, 6 * ((std::uint64_t{1} << (2 * view.textureLevels())) - 1) / 3);
  // Level-2 nodes far from Olympus Mons: the level-1 tile that contains them exists only on
  // Olympus Mons's face; elsewhere they fall back to the root tile.
  std::size_t coarser = 0;
  for (std::uint8_t f = 0; f < 6; ++f) {
    for (std::uint64_t heap = 3; heap < 7; ++heap) {
      const NodeKey key{f, 0, heap};
      const TileKey tile = view.tileOf(key);
      ASSERT_TRUE(view.face(f).findTexture(tile.heap).has_value());
      if (textureLevelOfHeap(tile.heap) < view.textureLevelOf(2)) ++coarser;
    }
  }
  EXPECT_GT(coarser, 0u);
  // And the cuts over it are still watertight (the texture term is a function of the level).
  test::PatchStore store(view);
  const Camera camera =
      Camera::fromPose(view.planet(), {kLat, kLon, 50e3, 0, -60, 0}, Viewport{320, 180, 60.0});
  const Cut cut = refine(view, camera, {1.0, false, -1});
  for (const CutPatch& p : cut.patches) {
    ASSERT_TRUE(view.face(p.tile.face).findTexture(p.tile.heap).has_value());
  }
  const test::MeshCheck check = test::checkClosedManifold(view, cut, camera.position(), store);
  EXPECT_EQ(check.badEdges, 0u);
  EXPECT_EQ(check.euler(), 2);
}

TEST_F(SparseForest, HeightsComeFromLeavesOfAnyLevel) {
  PBDAM_REQUIRE_DATA(demPath, test::dataDir() / "mars/megt90n000cb.lbl");
  auto dem = readDem(demPath);
  ASSERT_TRUE(dem.ok()) << dem.error().message;
  const DatasetView& view = pruned_->view();
  std::set<int> levels;
  for (const auto& [lat, lon] : {std::pair{kLat, kLon}, std::pair{-40.0, 60.0},
                                 std::pair{70.0, 10.0}, std::pair{kLat + 0.3, kLon - 0.2}}) {
    const auto h = surfaceHeightAt(view, lat, lon);
    ASSERT_TRUE(h.ok()) << h.error().message;
    EXPECT_TRUE(view.node(h->leaf).leaf());
    levels.insert(bintreeLevel(h->leaf.heap));
    const auto sample = dem->sampleBilinear(lat, lon);
    ASSERT_TRUE(sample);
    EXPECT_LE(std::abs(h->heightMeters - *sample), h->leafErrorMeters + 1.0) << lat << "," << lon;
  }
  EXPECT_TRUE(levels.contains(view.depth()));
  EXPECT_LE(*levels.begin(), 4);
}

// Rewrites record fields of a face file and its table CRC, as a damaged or hostile file would.
std::vector<std::byte> withNodeTable(std::vector<std::byte> file,
                                     const std::function<void(std::vector<NodeRecord>&)>& edit) {
  auto view = FaceView::open(file, "edit");
  EXPECT_TRUE(view.ok());
  FaceHeader h = view->header();
  std::vector<NodeRecord> nodes;
  for (std::uint64_t k = 0; k < h.nodeCount; ++k) nodes.push_back(view->nodeAt(k));
  edit(nodes);
  const auto table = std::span(file).subspan(h.nodeTableOffset, h.nodeCount * kNodeRecordBytes);
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    encodeNodeRecord(nodes[k], table.subspan(k * kNodeRecordBytes).first<kNodeRecordBytes>());
  }
  h.nodeTableCrc = crc32(table);
  encodeFaceHeader(h, std::span(file).first<kFaceHeaderBytes>());
  return file;
}

TEST_F(SparseForest, TablesThatAreNotAForestAreRejected) {
  const std::vector<std::byte> good = test::readAll(prunedDir_ / "face0.pbdam");
  ASSERT_TRUE(FaceView::open(good, "face0").ok());
  const auto lastInner = [](const std::vector<NodeRecord>& nodes) {
    std::size_t k = nodes.size() - 1;
    while (nodes[k].leaf()) --k;
    return k;
  };
  const std::vector<std::pair<std::string, std::function<void(std::vector<NodeRecord>&)>>> cases = {
      {"children are missing or out of order",
       [](std::vector<NodeRecord>& n) { std::swap(n[1].heapIndex, n[2].heapIndex); }},
      {"children are missing or out of order",
       [](std::vector<NodeRecord>& n) { n[1].flags = kRecordLeaf; }},
      {"is not the child of a node before it",
       [&](std::vector<NodeRecord>& n) { n[lastInner(n)].flags = kRecordLeaf; }},
      {"unknown flags", [](std::vector<NodeRecord>& n) { n[5].flags = 4; }},
      {"sources on a node that is not a leaf",
       [](std::vector<NodeRecord>& n) { n[0].sources = 1; }},
      {"does not start at its root", [](std::vector<NodeRecord>& n) { n[0].heapIndex = 1; }},
  };
  for (const auto& [message, edit] : cases) {
    const auto bad = FaceView::open(withNodeTable(good, edit), "face0.pbdam");
    ASSERT_FALSE(bad.ok()) << message;
    EXPECT_EQ(bad.error().code, ErrorCode::CorruptData);
    EXPECT_NE(bad.error().message.find(message), std::string::npos) << bad.error().message;
    EXPECT_NE(bad.error().message.find("face0.pbdam"), std::string::npos);
  }
}

}  // namespace
}  // namespace pbdam::runtime
