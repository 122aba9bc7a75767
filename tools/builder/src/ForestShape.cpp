// The split diamonds of an adaptive forest (ForestShape.h).
#include "pbdam/builder/ForestShape.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <unordered_map>

#include "pbdam/runtime/CubeMap.h"

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

double wrap360(double degrees) noexcept {
  const double d = std::fmod(degrees, 360.0);
  return d < 0.0 ? d + 360.0 : d;
}

glm::dvec3 directionOf(const Planet& planet, double lat, double lon) {
  return planet.geodeticToDirection(lat, lon);
}

/// Chord distance (unit sphere) from `p` to the nearest point of a lat/lon box, taking the
/// box's point of clamped latitude and longitude (exact along meridians and parallels, close
/// enough elsewhere for a split rule the closure corrects).
double chordToBox(const Planet& planet, const glm::dvec3& p, const formats::LatLonBounds& box) {
  // The box is geodetic, as the DEMs' samples are placed (SampleGrid: geodeticToDirection): on
  // an ellipsoid a direction's latitude differs from the geodetic one (0.19° on Earth at 45°).
  const GeodeticPosition ll = planet.directionToGeodetic(p);
  const double lat = std::clamp(ll.latDegrees, box.southDegrees, box.northDegrees);
  const double width = box.eastDegrees - box.westDegrees;
  const double east = wrap360(ll.lonDegrees - box.westDegrees);  // degrees east of the west edge
  double lon = ll.lonDegrees;
  if (east > width) {
    // Outside the box's longitudes: the nearer of its two edges.
    lon = (east - width < 360.0 - east) ? box.eastDegrees : box.westDegrees;
  }
  return glm::length(p - directionOf(planet, lat, lon));
}

class ShapeBuilder {
 public:
  ShapeBuilder(const Lattice& lattice, const Planet& planet, int baseDepth, int maxDepth,
               std::vector<DeepRegion> regions, double reach)
      : lattice_(lattice),
        planet_(planet),
        reach_(reach),
        baseDepth_(baseDepth),
        maxDepth_(maxDepth),
        regions_(std::move(regions)),
        split_(static_cast<std::size_t>(maxDepth) + 1) {}

  /// Splits what the rule wants from the roots down, and what the closure needs, with explicit
  /// work lists (the closure can chain across a whole region: recursion would overflow).
  void run() {
    for (int face = 0; face < 6; ++face) {
      for (int tree = 0; tree < 2; ++tree) record(lattice_.root(face, tree));
    }
    while (!toVisit_.empty() || !toClose_.empty()) {
      while (!toClose_.empty()) {
        // Make the partner of this split node exist and split it: a point just across the
        // hypotenuse's midpoint lies in the partner, or in the unsplit ancestor of where the
        // partner would be, which is split first (the node stays on the list until then).
        const BinTriangle t = toClose_.back();
        const glm::dvec3 apex = lattice_.direction(t.face, t.apex);
        const glm::dvec3 mid = lattice_.direction(t.face, (t.left + t.right) / 2);
        const BinTriangle q = locate(glm::normalize(mid + 0.25 * (mid - apex)));
        if (q.level >= t.level) toClose_.pop_back();
        if (q.level <= t.level) splitNode(q);
      }
      if (toVisit_.empty()) break;
      const BinTriangle t = toVisit_.back();
      toVisit_.pop_back();
      if (t.level < maxDepth_ && wanted(t)) splitNode(t);
    }
  }

  std::vector<std::unordered_map<std::uint64_t, bool>>& split() { return split_; }

  /// The split rule (ForestShape::make).
  bool wanted(const BinTriangle& t) const {
    if (t.level < baseDepth_) return true;
    const glm::dvec3 l = lattice_.direction(t.face, t.left);
    const glm::dvec3 r = lattice_.direction(t.face, t.right);
    const glm::dvec3 m = lattice_.direction(t.face, (t.left + t.right) / 2);
    const double reach = reach_ * glm::length(l - r);
    return std::any_of(regions_.begin(), regions_.end(), [&](const DeepRegion& region) {
      return t.level < region.leafLevel && chordToBox(planet_, m, region.bounds) <= reach;
    });
  }

 private:
  std::uint64_t id(const BinTriangle& t) const noexcept { return nodeId(t, maxDepth_); }

  /// Adds node `t` (its parent is split), unsplit; the roots are also to be visited.
  void record(const BinTriangle& t) {
    if (t.level == 0) toVisit_.push_back(t);
    split_[static_cast<std::size_t>(t.level)].try_emplace(id(t), false);
  }

  /// The unsplit node containing direction `p` (descending the split ones).
  BinTriangle locate(const glm::dvec3& p) const {
    const FaceUv fuv = CubeMap::directionToFaceUv(p);
    const glm::dvec2 xy = fuv.uv * static_cast<double>(lattice_.sideCells());
    BinTriangle t = lattice_.root(cubeFaceIndex(fuv.face), xy.x >= xy.y ? 0 : 1);
    for (;;) {
      const auto& level = split_[static_cast<std::size_t>(t.level)];
      const auto it = level.find(id(t));
      if (it == level.end() || !it->second) return t;
      t = Lattice::children(t)[static_cast<std::size_t>(bintreeChildContaining(t, xy))];
    }
  }

  /// Splits `t` (unless it is split): its children are recorded and to be visited, its
  /// partner to be split.
  void splitNode(const BinTriangle& t) {
    bool& isSplit = split_[static_cast<std::size_t>(t.level)].at(id(t));
    if (isSplit) return;
    isSplit = true;
    for (const BinTriangle& kid : Lattice::children(t)) {
      record(kid);
      toVisit_.push_back(kid);
    }
    toClose_.push_back(t);
  }

  const Lattice& lattice_;
  const Planet& planet_;
  double reach_;
  int baseDepth_;
  int maxDepth_;
  std::vector<DeepRegion> regions_;
  std::vector<std::unordered_map<std::uint64_t, bool>> split_;  // per level: id → split
  std::vector<BinTriangle> toVisit_;  ///< nodes the rule has not looked at yet
  std::vector<BinTriangle> toClose_;  ///< split nodes whose partner may not be split yet
};

}  // namespace

ForestShape ForestShape::make(const Lattice& lattice, const Planet& planet, int baseDepth,
                              std::vector<DeepRegion> regions, double reach) {
  int maxDepth = baseDepth;
  for (const DeepRegion& r : regions) maxDepth = std::max(maxDepth, r.leafLevel);
  ShapeBuilder builder(lattice, planet, baseDepth, maxDepth, std::move(regions), reach);
  builder.run();
  ForestShape shape;
  shape.baseDepth_ = baseDepth;
  for (auto& level : builder.split()) {
    std::vector<std::pair<std::uint64_t, bool>> sorted(level.begin(), level.end());
    std::sort(sorted.begin(), sorted.end());
    Level out;
    for (const auto& [node, split] : sorted) {
      out.nodes.push_back(node);
      out.split.push_back(split);
      if (split && !builder.wanted(triangleOfNode(lattice, node, maxDepth))) {
        ++shape.closureSplits_;
      }
    }
    shape.levels_.push_back(std::move(out));
  }
  return shape;
}

bool ForestShape::exists(int level, std::uint64_t id) const noexcept {
  if (level < 0 || level > depth()) return false;
  const auto& nodes = nodesOfLevel(level);
  return std::binary_search(nodes.begin(), nodes.end(), id);
}

bool ForestShape::isSplit(int level, std::uint64_t id) const noexcept {
  if (level < 0 || level > depth()) return false;
  const auto& nodes = nodesOfLevel(level);
  const auto it = std::lower_bound(nodes.begin(), nodes.end(), id);
  return it != nodes.end() && *it == id &&
         splitOfLevel(level)[static_cast<std::size_t>(it - nodes.begin())];
}

std::uint64_t ForestShape::nodeCount() const noexcept {
  std::uint64_t n = 0;
  for (const Level& l : levels_) n += l.nodes.size();
  return n;
}

std::uint64_t ForestShape::leafCount() const noexcept {
  std::uint64_t n = 0;
  for (const Level& l : levels_) {
    n += static_cast<std::uint64_t>(std::count(l.split.begin(), l.split.end(), false));
  }
  return n;
}

}  // namespace pbdam::builder
