// Stateless top-down refinement (Refinement.h).
#include "pbdam/runtime/Refinement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
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
        bounds_(exaggerationBounds(dataset, options.exaggeration)),
        maxLevel_(options.maxLevel < 0 ? dataset.depth()
                                       : std::min(options.maxLevel, dataset.depth())) {}

  // `row` is the node's table index in its face file; `up` the screen errors of its parent
  // and grandparent (infinite where it has none).
  void visit(const NodeKey& key, std::uint64_t row, int level, std::array<double, 2> up) {
    ++cut_.nodesVisited;
    const FaceView& face = dataset_.face(key.face);
    const NodeRecord node = face.nodeAt(row);
    const RefinementBounds b = refinementBounds(dataset_, node, level, bounds_);
    if (options_.frustumCulling && !camera_.sphereInFrustum(b.centre, b.radiusMeters)) {
      ++cut_.nodesCulled;
      return;
    }
    const double screen = camera_.screenError(b.errorMeters, b.centre, b.radiusMeters);
    const bool descend = screen > options_.tolerancePixels && level < maxLevel_ && !node.leaf();
    const std::uint64_t first = descend ? face.firstChildOf(row) : 0;
    if (descend && options_.residentRecordsOnly &&
        !(face.nodeRecordResident(first) && face.nodeRecordResident(first + 1))) {
      if (cut_.unresidentRecordLevel < 0 || level + 1 < cut_.unresidentRecordLevel) {
        cut_.unresidentRecordLevel = level + 1;
      }
    } else if (descend) {
      visit(NodeKey{key.face, key.tree, 2 * key.heap + 1}, first, level + 1, {screen, up[0]});
      visit(NodeKey{key.face, key.tree, 2 * key.heap + 2}, first + 1, level + 1, {screen, up[0]});
      return;
    }
    // A leaf of the cut (or, with resident records only, a node whose children cannot be read
    // yet: the caller lowers its level cap and refines again).
    CutPatch patch;
    patch.node = key;
    patch.level = level;
    patch.tile = dataset_.tileOf(key);
    patch.screenErrorPixels = static_cast<float>(screen);
    setPatchMorph(dataset_, options_, up[0], up[1], patch);
    addCutPatch(cut_, patch, node.triangleCount, node.vertexCount, seenTiles_);
  }

  Cut take() { return std::move(cut_); }

 private:
  const DatasetView& dataset_;
  const Camera& camera_;
  const RefinementOptions& options_;
  ExaggerationBounds bounds_;
  int maxLevel_;
  Cut cut_;
  std::unordered_set<std::uint64_t> seenTiles_;  // packKey() of the tiles listed
};

}  // namespace

double refinementErrorMeters(const DatasetView& dataset, int level,
                             double geometryErrorMeters) noexcept {
  return std::max(geometryErrorMeters, dataset.textureTermOfLevel(level));
}

ExaggerationBounds exaggerationBounds(const DatasetView& dataset, double exaggeration) noexcept {
  const Manifest& m = dataset.manifest();
  // Stored heights are the lattice's rounded to the height step: within a step of its range.
  const double largest =
      std::max(std::abs(m.minHeightMeters), std::abs(m.maxHeightMeters)) + m.heightStepMeters;
  return {std::max(exaggeration, 1.0), std::abs(exaggeration - 1.0) * largest};
}

RefinementBounds refinementBounds(const DatasetView& dataset, const NodeRecord& record, int level,
                                  const ExaggerationBounds& bounds) noexcept {
  return {glm::dvec3(record.sphereCenter[0], record.sphereCenter[1], record.sphereCenter[2]),
          static_cast<double>(record.sphereRadiusMeters) + bounds.radiusGrowthMeters,
          refinementErrorMeters(dataset, level, static_cast<double>(record.errorMeters)) *
              bounds.errorScale};
}

void addCutPatch(Cut& cut, const CutPatch& patch, std::uint32_t triangles, std::uint32_t vertices,
                 std::unordered_set<std::uint64_t>& seenTiles) {
  cut.patches.push_back(patch);
  cut.triangles += triangles;
  cut.vertices += vertices;
  if (seenTiles.insert(packKey(patch.tile)).second) cut.tiles.push_back(patch.tile);
  if (patch.blendsTile() && seenTiles.insert(packKey(patch.morphTile)).second) {
    cut.tiles.push_back(patch.morphTile);
  }
}

float morphWeight(double screenErrorPixels, double tolerancePixels, double range) noexcept {
  if (!(range > 0.0)) return 0.0f;
  const double f = std::clamp((screenErrorPixels / tolerancePixels - 1.0) / range, 0.0, 1.0);
  return static_cast<float>(1.0 - f);
}

void setPatchMorph(const DatasetView& dataset, const RefinementOptions& options,
                   double parentScreenError, double grandparentScreenError, CutPatch& patch) {
  patch.morph = {morphWeight(parentScreenError, options.tolerancePixels, options.morphRange),
                 morphWeight(grandparentScreenError, options.tolerancePixels, options.morphRange)};
  patch.morphTile = patch.tile;
  if (patch.morph[0] > 0.0f && patch.level > 0) {
    const TileKey parentTile =
        dataset.tileOf(NodeKey{patch.node.face, patch.node.tree, (patch.node.heap - 1) / 2});
    patch.morphTile = parentTile;
  }
}

void refreshMorph(const DatasetView& dataset, const Camera& camera,
                  const RefinementOptions& options, Cut& cut) {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  cut.tiles.clear();
  const ExaggerationBounds bounds = exaggerationBounds(dataset, options.exaggeration);
  std::unordered_set<std::uint64_t> seen;
  for (CutPatch& patch : cut.patches) {
    std::array<double, 2> up{kNone, kNone};
    NodeKey ancestor = patch.node;
    for (std::size_t k = 0; k < 2 && ancestor.heap > 0; ++k) {
      ancestor.heap = (ancestor.heap - 1) / 2;
      const RefinementBounds b = refinementBounds(dataset, dataset.node(ancestor),
                                                  patch.level - 1 - static_cast<int>(k), bounds);
      up[k] = camera.screenError(b.errorMeters, b.centre, b.radiusMeters);
    }
    setPatchMorph(dataset, options, up[0], up[1], patch);
    if (seen.insert(packKey(patch.tile)).second) cut.tiles.push_back(patch.tile);
    if (patch.blendsTile() && seen.insert(packKey(patch.morphTile)).second) {
      cut.tiles.push_back(patch.morphTile);
    }
  }
}

CutMorphSummary summarizeMorph(const Cut& cut) noexcept {
  CutMorphSummary s;
  for (const CutPatch& p : cut.patches) {
    const float largest = std::max(p.morph[0], p.morph[1]);
    const bool partWay =
        (p.morph[0] > 0.0f && p.morph[0] < 1.0f) || (p.morph[1] > 0.0f && p.morph[1] < 1.0f);
    s.morphingPatches += static_cast<std::uint64_t>(partWay);
    s.blendingPatches += static_cast<std::uint64_t>(p.blendsTile());
    s.largestWeight = std::max(s.largestWeight, static_cast<double>(largest));
  }
  return s;
}

Result<void> checkMorphRange(const DatasetView& dataset, double range) {
  const double margin = dataset.manifest().errorMargin;
  if (!(range >= 0.0 && range <= margin)) {
    std::ostringstream what;
    what << "--morph-range " << range << " is outside [0, " << margin
         << "], the dataset's error margin: beyond it the morph windows of successive levels "
            "overlap (rebuild with a larger --error-margin)";
    return makeError(ErrorCode::InvalidArgument, what.str());
  }
  return {};
}

Cut refine(const DatasetView& dataset, const Camera& camera, const RefinementOptions& options) {
  Refiner refiner(dataset, camera, options);
  for (std::uint8_t face = 0; face < 6; ++face) {
    for (std::uint8_t tree = 0; tree < 2; ++tree) {
      constexpr double kNone = std::numeric_limits<double>::infinity();
      refiner.visit(NodeKey{face, tree, 0}, dataset.face(face).treeFirstNode(tree), 0,
                    {kNone, kNone});
    }
  }
  return refiner.take();
}

}  // namespace pbdam::runtime
