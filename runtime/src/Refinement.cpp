// Stateless top-down refinement (Refinement.h).
#include "pbdam/runtime/Refinement.h"

#include <algorithm>
#include <unordered_set>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

class Refiner {
 public:
  Refiner(const DatasetView& dataset, const Camera& camera, const RefinementOptions& options)
      : dataset_(dataset),
        camera_(camera),
        options_(options),
        maxLevel_(options.maxLevel < 0 ? dataset.depth()
                                       : std::min(options.maxLevel, dataset.depth())) {}

  // `row` is the node's table index in its face file.
  void visit(const NodeKey& key, std::uint64_t row, int level) {
    ++cut_.nodesVisited;
    const FaceView& face = dataset_.face(key.face);
    const NodeRecord node = face.nodeAt(row);
    const glm::dvec3 centre(node.sphereCenter[0], node.sphereCenter[1], node.sphereCenter[2]);
    const double radius = static_cast<double>(node.sphereRadiusMeters);
    if (options_.frustumCulling && !camera_.sphereInFrustum(centre, radius)) {
      ++cut_.nodesCulled;
      return;
    }
    const double error =
        refinementErrorMeters(dataset_, level, static_cast<double>(node.errorMeters));
    const double screen = camera_.screenError(error, centre, radius);
    if (screen > options_.tolerancePixels && level < maxLevel_ && !node.leaf()) {
      const std::uint64_t first = face.firstChildOf(row);
      visit(NodeKey{key.face, key.tree, 2 * key.heap + 1}, first, level + 1);
      visit(NodeKey{key.face, key.tree, 2 * key.heap + 2}, first + 1, level + 1);
      return;
    }
    CutPatch patch;
    patch.node = key;
    patch.level = level;
    patch.tile = dataset_.tileOf(key);
    patch.screenErrorPixels = static_cast<float>(screen);
    cut_.patches.push_back(patch);
    cut_.triangles += node.triangleCount;
    cut_.vertices += node.vertexCount;
    if (seenTiles_.insert(packKey(patch.tile)).second) cut_.tiles.push_back(patch.tile);
  }

  Cut take() { return std::move(cut_); }

 private:
  const DatasetView& dataset_;
  const Camera& camera_;
  const RefinementOptions& options_;
  int maxLevel_;
  Cut cut_;
  std::unordered_set<std::uint64_t> seenTiles_;  // packKey() of the tiles listed
};

}  // namespace

double refinementErrorMeters(const DatasetView& dataset, int level,
                             double geometryErrorMeters) noexcept {
  const std::uint32_t t = dataset.textureLevelOf(level);
  const double texture = t + 1 < dataset.textureLevels() ? dataset.textureErrorOfLevel(t) : 0.0;
  return std::max(geometryErrorMeters, texture);
}

Cut refine(const DatasetView& dataset, const Camera& camera, const RefinementOptions& options) {
  Refiner refiner(dataset, camera, options);
  for (std::uint8_t face = 0; face < 6; ++face) {
    for (std::uint8_t tree = 0; tree < 2; ++tree) {
      refiner.visit(NodeKey{face, tree, 0}, dataset.face(face).treeFirstNode(tree), 0);
    }
  }
  return refiner.take();
}

}  // namespace pbdam::runtime
