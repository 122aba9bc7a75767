// The shape of an adaptive forest: complete to the base depth without regions; with regions,
// leaves of the region's level where it lies and of the base's far from it, and a closed set of
// split diamonds (checked here independently, from the diamonds' spine keys), across face edges
// and at a cube corner too, whatever the regions' order.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <glm/geometric.hpp>
#include <map>

#include "pbdam/builder/ForestShape.h"
#include "pbdam/runtime/CubeMap.h"

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// Every split node's diamond partner exists and is split, and every node's parent is split.
void expectClosed(const Lattice& lattice, const ForestShape& shape) {
  const int depth = shape.depth();
  for (int level = 0; level <= depth; ++level) {
    std::map<EdgeKey, std::vector<std::pair<std::uint64_t, bool>>> bySpine;
    const auto& nodes = shape.nodesOfLevel(level);
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const BinTriangle t = triangleOfNode(lattice, nodes[k], depth);
      ASSERT_EQ(t.level, level);
      bySpine[lattice.edgeKey(t.face, t.left, t.right)].emplace_back(nodes[k],
                                                                     shape.splitOfLevel(level)[k]);
      if (level > 0) {
        const std::uint64_t parent = nodes[k] - t.index + (t.index - 1) / 2;
        EXPECT_TRUE(shape.isSplit(level - 1, parent)) << "node " << nodes[k];
      }
      if (level == depth) {
        EXPECT_FALSE(shape.splitOfLevel(level)[k]);
      }
    }
    for (const auto& [spine, pair] : bySpine) {
      const bool anySplit =
          std::any_of(pair.begin(), pair.end(), [](const auto& p) { return p.second; });
      if (!anySplit) continue;
      ASSERT_EQ(pair.size(), 2u) << "a split node at level " << level << " has no partner";
      EXPECT_TRUE(pair[0].second && pair[1].second)
          << "a diamond at level " << level << " is split on one side only";
    }
  }
}

/// The level of the leaf containing (lat, lon).
int leafLevelAt(const Lattice& lattice, const ForestShape& shape, double lat, double lon) {
  const FaceUv fuv = CubeMap::latLonToFaceUv(lat, lon);
  const glm::dvec2 xy = fuv.uv * static_cast<double>(lattice.sideCells());
  BinTriangle t = lattice.root(cubeFaceIndex(fuv.face), xy.x >= xy.y ? 0 : 1);
  while (shape.isSplit(t.level, nodeId(t, shape.depth()))) {
    t = Lattice::children(t)[static_cast<std::size_t>(bintreeChildContaining(t, xy))];
  }
  return t.level;
}

// A region's box is geodetic, as a DEM's samples are placed: on WGS84 the deep leaves lie over
// the box, not 0.19° north of it where a box taken as geocentric directions would put them
// (two hypotenuses of level 24 are about 7 km; the shift is 21 km at 49.8°N).
TEST(ForestShape, RegionsAreGeodeticOnAnEllipsoid) {
  const Lattice lattice(16384);
  const Planet earth = Planet::earthWgs84();
  const ForestShape shape =
      ForestShape::make(lattice, earth, 2, {DeepRegion{{49.82, 5.86, 49.86, 5.92}, 24}});
  const auto levelAt = [&](double lat, double lon) {
    const FaceUv fuv = CubeMap::directionToFaceUv(earth.geodeticToDirection(lat, lon));
    const glm::dvec2 xy = fuv.uv * static_cast<double>(lattice.sideCells());
    BinTriangle t = lattice.root(cubeFaceIndex(fuv.face), xy.x >= xy.y ? 0 : 1);
    while (shape.isSplit(t.level, nodeId(t, shape.depth()))) {
      t = Lattice::children(t)[static_cast<std::size_t>(bintreeChildContaining(t, xy))];
    }
    return t.level;
  };
  EXPECT_EQ(levelAt(49.84, 5.89), 24);
  EXPECT_EQ(levelAt(49.821, 5.861), 24);
  EXPECT_LE(levelAt(50.03, 5.89), 22);  // where the geocentric reading would have gone deep
}

TEST(ForestShape, WithoutRegionsItIsTheCompleteForestOfTheBaseDepth) {
  const Lattice lattice(64);
  const ForestShape shape = ForestShape::make(lattice, Planet::mars(), 4, {});
  EXPECT_EQ(shape.depth(), 4);
  EXPECT_EQ(shape.nodeCount(), 12u * 31u);
  EXPECT_EQ(shape.leafCount(), 12u * 16u);
  expectClosed(lattice, shape);
}

TEST(ForestShape, DeeperNearARegionClosedEverywhere) {
  // Luxembourg's box wanting level 12 on a base of depth 4 (2048 cells, 32-cell leaves at 12).
  const Lattice lattice(2048);
  const DeepRegion luxembourg{{49.44, 5.74, 50.19, 6.53}, 12};
  const ForestShape shape = ForestShape::make(lattice, Planet::mars(), 4, {luxembourg});
  EXPECT_EQ(shape.depth(), 12);
  expectClosed(lattice, shape);
  EXPECT_EQ(leafLevelAt(lattice, shape, 49.8, 6.1), 12);
  EXPECT_EQ(leafLevelAt(lattice, shape, 49.45, 6.5), 12);
  EXPECT_EQ(leafLevelAt(lattice, shape, -30.0, 100.0), 4);
  EXPECT_EQ(leafLevelAt(lattice, shape, 10.0, -120.0), 4);
  // Between, the levels step down: 40° away it is still level 6 (each level splits within two of
  // its hypotenuses of the region).
  EXPECT_EQ(leafLevelAt(lattice, shape, 10.0, 6.0), 6);
  // Work grows with the region, not with the planet: far fewer nodes than a complete forest.
  EXPECT_LT(shape.nodeCount(), 12u * ((1u << 13) - 1) / 20);
  std::printf("%llu nodes, %llu leaves\n", static_cast<unsigned long long>(shape.nodeCount()),
              static_cast<unsigned long long>(shape.leafCount()));
}

TEST(ForestShape, ClosedAcrossFaceEdgesAndACubeCornerInAnyOrder) {
  const Lattice lattice(1024);
  // (1, 1, 1)/√3 is a corner of three faces; the second box straddles the seam at 180°.
  const DeepRegion corner{{33.0, 43.0, 37.5, 47.0}, 10};
  const DeepRegion seam{{-5.0, 178.0, 5.0, 182.0}, 8};
  const ForestShape ab = ForestShape::make(lattice, Planet::mars(), 2, {corner, seam});
  const ForestShape ba = ForestShape::make(lattice, Planet::mars(), 2, {seam, corner});
  expectClosed(lattice, ab);
  EXPECT_EQ(leafLevelAt(lattice, ab, 35.26, 45.0), 10);
  EXPECT_EQ(leafLevelAt(lattice, ab, 0.0, 180.0), 8);
  EXPECT_EQ(leafLevelAt(lattice, ab, 0.0, -179.0), 8);
  // A rule that splits little more than the nodes over the region is far from closed: the
  // closure does the rest.
  const ForestShape tight = ForestShape::make(lattice, Planet::mars(), 2, {corner, seam}, 0.6);
  expectClosed(lattice, tight);
  EXPECT_EQ(leafLevelAt(lattice, tight, 35.26, 45.0), 10);
  EXPECT_LT(tight.nodeCount(), ab.nodeCount());
  EXPECT_GT(tight.closureSplits(), 0u);
  std::printf("closure splits: %llu of %llu nodes (reach 0.6), %llu of %llu (reach 2)\n",
              static_cast<unsigned long long>(tight.closureSplits()),
              static_cast<unsigned long long>(tight.nodeCount()),
              static_cast<unsigned long long>(ab.closureSplits()),
              static_cast<unsigned long long>(ab.nodeCount()));
  ASSERT_EQ(ab.depth(), ba.depth());
  for (int level = 0; level <= ab.depth(); ++level) {
    EXPECT_EQ(ab.nodesOfLevel(level), ba.nodesOfLevel(level));
    EXPECT_EQ(ab.splitOfLevel(level), ba.splitOfLevel(level));
  }
}

// The size of the acceptance inset: 32° × 32° at 256 px/deg on MOLA (base depth 8 on 512 cells,
// the inset's leaves 6 levels of lattice deeper: level 20 on 32768 cells).
TEST(ForestShape, AMolaSizedInset) {
  const Lattice lattice(32768);
  const auto start = std::chrono::steady_clock::now();
  const ForestShape shape =
      ForestShape::make(lattice, Planet::mars(), 8, {DeepRegion{{-16.0, 120.0, 16.0, 152.0}, 20}});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%llu nodes, %llu leaves, %llu closure splits in %.2f s\n",
              static_cast<unsigned long long>(shape.nodeCount()),
              static_cast<unsigned long long>(shape.leafCount()),
              static_cast<unsigned long long>(shape.closureSplits()), seconds);
  EXPECT_EQ(leafLevelAt(lattice, shape, 0.0, 136.0), 20);
  EXPECT_EQ(leafLevelAt(lattice, shape, 0.0, -44.0), 8);
  expectClosed(lattice, shape);
}

}  // namespace
}  // namespace pbdam::builder
