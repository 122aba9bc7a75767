// Cuts selected by a predicate and closed upward (Selection.h).
#include "pbdam/runtime/Selection.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <tuple>
#include <unordered_set>
#include <utility>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

/// Distance from `p` to the segment a–b.
double distanceToSegment(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 e = b - a;
  const double ee = glm::dot(e, e);
  const double t = ee > 0.0 ? std::clamp(glm::dot(p - a, e) / ee, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * e));
}

}  // namespace

bool FocusRegion::reaches(const glm::dvec3& centre, double radius) const noexcept {
  if (line.empty()) return false;
  double d = glm::length(centre - line.front());
  for (std::size_t k = 1; k < line.size(); ++k) {
    d = std::min(d, distanceToSegment(centre, line[k - 1], line[k]));
  }
  return d - radius <= widthMeters;
}

Result<FocusRegion> focusCircle(const Planet& planet, double latDegrees, double lonDegrees,
                                double radiusMeters, double errorMeters) {
  const double halfCircumference = std::numbers::pi * planet.equatorialRadiusMeters();
  if (!(std::fabs(latDegrees) <= 90.0) || !std::isfinite(lonDegrees)) {
    return makeError(ErrorCode::InvalidArgument,
                     "focus: latitude must be in [-90, 90] and "
                     "longitude finite");
  }
  if (!(radiusMeters > 0.0 && radiusMeters <= halfCircumference)) {
    return makeError(ErrorCode::InvalidArgument, "focus: the radius must be in (0, " +
                                                     std::to_string(halfCircumference) +
                                                     "] metres (half the planet's circumference)");
  }
  if (!(errorMeters >= 0.0) || !std::isfinite(errorMeters)) {
    return makeError(ErrorCode::InvalidArgument, "focus: the error must be ≥ 0 metres");
  }
  FocusRegion region;
  region.line.push_back(planet.geodeticToEcef(latDegrees, lonDegrees, 0.0));
  region.widthMeters = radiusMeters;
  region.errorMeters = errorMeters;
  return region;
}

Result<FocusRegion> focusPath(const Planet& planet,
                              const std::vector<std::array<double, 2>>& latLonDegrees,
                              double halfWidthMeters, double errorMeters) {
  if (latLonDegrees.empty()) {
    return makeError(ErrorCode::InvalidArgument, "focus path: it has no points");
  }
  if (!(halfWidthMeters > 0.0) || !std::isfinite(halfWidthMeters)) {
    return makeError(ErrorCode::InvalidArgument, "focus path: the width must be > 0 metres");
  }
  FocusRegion region;
  for (const auto& [lat, lon] : latLonDegrees) {
    auto point = focusCircle(planet, lat, lon, halfWidthMeters, errorMeters);
    if (!point) return std::move(point).error();
    region.line.push_back(point->line.front());
  }
  region.widthMeters = halfWidthMeters;
  region.errorMeters = errorMeters;
  return region;
}

DiamondIndex::DiamondIndex(const DatasetView& dataset) {
  // Diamond partners share their hypotenuse: each node's hypotenuse (its corners' canonical
  // keys in order) is listed, the list sorted, and equal neighbours paired.
  struct Hypotenuse {
    PointKey a;
    PointKey b;
    std::uint32_t node;
  };
  std::vector<Hypotenuse> hypotenuses;
  for (std::uint8_t face = 0; face < 6; ++face) {
    const formats::FaceView& view = dataset.face(face);
    const auto first = static_cast<std::uint32_t>(nodes.size());
    for (std::uint64_t row = 0; row < view.header().nodeCount; ++row) {
      const NodeRecord record = view.nodeAt(row);
      Node n;
      n.key = NodeKey{face, static_cast<std::uint8_t>(row >= view.treeFirstNode(1) ? 1 : 0),
                      record.heapIndex};
      n.level = bintreeLevel(record.heapIndex);
      n.leaf = record.leaf();
      const auto self = static_cast<std::uint32_t>(nodes.size());
      n.parent = self;
      n.partner = self;
      if (!n.leaf) n.firstChild = first + static_cast<std::uint32_t>(view.firstChildOf(row));
      if (record.heapIndex == 0) roots.push_back(self);
      const BinTriangle t = dataset.triangle(n.key);
      PointKey a = latticePointKey(dataset.latticeCells(), face, t.left);
      PointKey b = latticePointKey(dataset.latticeCells(), face, t.right);
      if (b < a) std::swap(a, b);
      hypotenuses.push_back({a, b, self});
      nodes.push_back(n);
    }
  }
  std::sort(hypotenuses.begin(), hypotenuses.end(), [](const Hypotenuse& x, const Hypotenuse& y) {
    return std::tie(x.a, x.b, x.node) < std::tie(y.a, y.b, y.node);
  });
  for (std::size_t k = 0; k + 1 < hypotenuses.size(); ++k) {
    const Hypotenuse& x = hypotenuses[k];
    const Hypotenuse& y = hypotenuses[k + 1];
    if (x.a != y.a || x.b != y.b) continue;
    nodes[x.node].partner = y.node;
    nodes[y.node].partner = x.node;
    ++k;
  }
  for (std::uint32_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].leaf) continue;
    nodes[nodes[i].firstChild].parent = i;
    nodes[nodes[i].firstChild + 1].parent = i;
  }
}

CutSelector::CutSelector(const DatasetView& dataset) : dataset_(&dataset), index_(dataset) {}

Cut CutSelector::select(const Camera& camera, const SelectionOptions& options,
                        SelectionStats* stats) const {
  const DatasetView& dataset = *dataset_;
  const RefinementOptions& r = options.refinement;
  const int maxLevel = r.maxLevel < 0 ? dataset.depth() : std::min(r.maxLevel, dataset.depth());
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const std::size_t count = index_.nodes.size();
  const ExaggerationBounds bounds = exaggerationBounds(dataset, r.exaggeration);
  // 1. The predicate, per node.
  std::vector<double> screen(count, 0.0);
  std::vector<char> bySize(count, 0);  // split because its screen error exceeds the tolerance
  std::vector<std::uint32_t> work;
  for (std::uint32_t i = 0; i < count; ++i) {
    const DiamondIndex::Node& n = index_.nodes[i];
    const NodeRecord record = dataset.node(n.key);
    const RefinementBounds b = refinementBounds(dataset, record, n.level, bounds);
    const glm::dvec3& centre = b.centre;
    const double radius = b.radiusMeters;
    screen[i] = camera.screenError(b.errorMeters, centre, radius);
    if (n.leaf || n.level >= maxLevel) continue;
    bySize[i] = static_cast<char>(screen[i] > r.tolerancePixels);
    bool wants = bySize[i] != 0;
    for (const FocusRegion& f : options.focus) {
      wants = wants || (static_cast<double>(record.errorMeters) > f.errorMeters &&
                        f.reaches(centre, radius));
    }
    wants = wants || (options.split && options.split(n.key, record));
    if (wants) work.push_back(i);
  }
  // 2. The closure: with a node, its parent and its diamond partner.
  std::vector<char> split(count, 0);
  const std::size_t wanted = work.size();
  std::uint64_t splits = 0;
  while (!work.empty()) {
    const std::uint32_t i = work.back();
    work.pop_back();
    if (split[i] != 0 || index_.nodes[i].leaf) continue;
    split[i] = 1;
    ++splits;
    work.push_back(index_.nodes[i].parent);
    work.push_back(index_.nodes[i].partner);
  }
  if (stats != nullptr) {
    stats->predicateSplits = wanted;
    stats->closureSplits = splits - std::min<std::uint64_t>(splits, wanted);
  }
  // 3. The cut, depth-first from the roots; a split's morph window only when its size split it.
  Cut cut;
  std::unordered_set<std::uint64_t> seen;
  const auto visit = [&](auto&& self, std::uint32_t i, std::array<double, 2> up) -> void {
    const DiamondIndex::Node& n = index_.nodes[i];
    ++cut.nodesVisited;
    const NodeRecord record = dataset.node(n.key);
    const RefinementBounds b = refinementBounds(dataset, record, n.level, bounds);
    if (r.frustumCulling && !camera.sphereInFrustum(b.centre, b.radiusMeters)) {
      ++cut.nodesCulled;
      return;
    }
    if (split[i] != 0) {
      const std::array<double, 2> down{bySize[i] != 0 ? screen[i] : kNone, up[0]};
      self(self, n.firstChild, down);
      self(self, n.firstChild + 1, down);
      return;
    }
    CutPatch patch;
    patch.node = n.key;
    patch.level = n.level;
    patch.tile = dataset.tileOf(n.key);
    patch.screenErrorPixels = static_cast<float>(screen[i]);
    setPatchMorph(dataset, r, up[0], up[1], patch);
    addCutPatch(cut, patch, record.triangleCount, record.vertexCount, seen);
  };
  for (const std::uint32_t root : index_.roots) visit(visit, root, {kNone, kNone});
  return cut;
}

Cut selectFocus(const DatasetView& dataset, std::vector<FocusRegion> focus) {
  SelectionOptions options;
  options.focus = std::move(focus);
  options.refinement.tolerancePixels = std::numeric_limits<double>::infinity();
  options.refinement.frustumCulling = false;
  options.refinement.morphRange = 0.0;
  // No screen error and no culling: the camera is a formality of select().
  const Camera camera = Camera::fromPose(
      dataset.planet(),
      {0.0, 0.0, 10.0 * dataset.planet().equatorialRadiusMeters(), 0.0, -90.0, 0.0},
      Viewport{64, 64, 60.0});
  return CutSelector(dataset).select(camera, options);
}

}  // namespace pbdam::runtime
