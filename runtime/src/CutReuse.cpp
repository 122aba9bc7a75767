// Frame-to-frame cut reuse (CutReuse.h).
#include "pbdam/runtime/CutReuse.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <glm/geometric.hpp>
#include <limits>
#include <queue>
#include <unordered_map>
#include <unordered_set>
#include <vector>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

constexpr int kBuckets = 64;  ///< distance buckets of the cull keys: node at ≤ 2^b metres

/// A slack made safe against the rounding of the decision it bounds: the decisions compare
/// doubles computed from the same inputs, so a relative 1e-9 of the magnitudes involved (and a
/// micrometre) covers every difference between this bound and the comparison itself.
double safeSlack(double slack, double magnitude) noexcept {
  return slack - 1e-9 * magnitude - 1e-6;
}

struct Entry final {
  double key = 0.0;
  std::uint64_t node = 0;
  std::uint64_t stamp = 0;
  bool operator>(const Entry& o) const noexcept { return key > o.key; }
};
using Queue = std::priority_queue<Entry, std::vector<Entry>, std::greater<>>;

}  // namespace

class IncrementalRefiner::Tree final {
 public:
  Tree(const DatasetView& dataset, double marginDegrees, const Camera& camera,
       const RefinementOptions& options)
      : dataset_(dataset),
        marginDegrees_(marginDegrees),
        options_(options),
        bounds_(exaggerationBounds(dataset, options.exaggeration)),
        viewport_(camera.viewport()),
        maxLevel_(options.maxLevel < 0 ? dataset.depth()
                                       : std::min(options.maxLevel, dataset.depth())),
        camera_(camera),
        wide_(camera.withFrustumMargin(marginDegrees)) {
    for (std::uint8_t face = 0; face < 6; ++face) {
      for (std::uint8_t tree = 0; tree < 2; ++tree) {
        evaluate(NodeKey{face, tree, 0}, dataset.face(face).treeFirstNode(tree), 0);
      }
    }
  }

  bool matches(const Camera& camera, const RefinementOptions& o) const noexcept {
    const Viewport& v = camera.viewport();
    return o.tolerancePixels == options_.tolerancePixels && o.maxLevel == options_.maxLevel &&
           o.morphRange == options_.morphRange && o.exaggeration == options_.exaggeration &&
           o.frustumCulling && v.width == viewport_.width && v.height == viewport_.height &&
           v.fovYDegrees == viewport_.fovYDegrees && camera.nearMeters() == camera_.nearMeters();
  }

  /// Moves to `camera`: re-evaluates the nodes that may have changed.
  void moveTo(const Camera& camera) {
    decisions_ = 0;
    culled_ = 0;
    const double trace = glm::dot(camera.right(), camera_.right()) +
                         glm::dot(camera.up(), camera_.up()) +
                         glm::dot(camera.forward(), camera_.forward());
    const double moved = glm::length(camera.position() - camera_.position());
    // ‖R − I‖ = 2 sin(φ/2) = √(3 − tr R) for the rotation R from the last axes to these.
    const double turned = std::sqrt(std::max(0.0, 3.0 - trace));
    const bool same = camera.position() == camera_.position() &&
                      camera.right() == camera_.right() && camera.up() == camera_.up() &&
                      camera.forward() == camera_.forward();
    camera_ = camera;
    wide_ = camera.withFrustumMargin(marginDegrees_);
    if (same) return;
    // Rounded up a little: the sums must not fall below the true movement.
    path_ += moved * (1.0 + 1e-12) + 1e-12;
    turn_ += turned * (1.0 + 1e-9) + 1e-12;
    std::vector<std::pair<int, std::uint64_t>> due;
    const auto take = [&](Queue& q, double limit) {
      while (!q.empty() && q.top().key <= limit) {
        const Entry e = q.top();
        q.pop();
        const auto it = nodes_.find(e.node);
        if (it != nodes_.end() && it->second.stamp == e.stamp) {
          due.emplace_back(it->second.level, e.node);
        }
      }
    };
    take(distance_, path_);
    for (int b = 0; b < kBuckets; ++b) {
      take(cull_[static_cast<std::size_t>(b)], path_ + std::ldexp(turn_, b));
    }
    // Parents first: a merge or a cull removes descendants that were due too.
    std::sort(due.begin(), due.end());
    due.erase(std::unique(due.begin(), due.end()), due.end());
    const std::uint64_t frameStart = stamps_;
    for (const auto& [level, packed] : due) {
      const auto it = nodes_.find(packed);
      if (it == nodes_.end() || it->second.stamp > frameStart) continue;
      evaluate(it->second.key, it->second.row, level);
    }
  }

  /// The unsplit nodes inside the camera's own frustum, in depth-first order of the trees.
  Cut cut() const {
    struct Drawn final {
      std::uint64_t order;
      const NodeState* node;
    };
    std::vector<Drawn> drawn;
    for (const auto& [packed, n] : nodes_) {
      if (n.kind != Kind::Drawn || !camera_.sphereInFrustum(n.centre, n.radius)) continue;
      const std::uint64_t path = n.key.heap + 1 - (std::uint64_t{1} << n.level);
      const std::uint64_t order = (std::uint64_t{n.key.face} << 61) |
                                  (std::uint64_t{n.key.tree} << 60) | (path << (59 - n.level));
      drawn.push_back({order, &n});
    }
    std::sort(drawn.begin(), drawn.end(),
              [](const Drawn& a, const Drawn& b) { return a.order < b.order; });
    Cut cut;
    std::unordered_set<std::uint64_t> seen;  // packKey() of the tiles listed
    for (const Drawn& d : drawn) {
      const NodeState& n = *d.node;
      CutPatch patch;
      patch.node = n.key;
      patch.level = n.level;
      patch.tile = n.tile;
      patch.screenErrorPixels =
          static_cast<float>(camera_.screenError(n.error, n.centre, n.radius));
      // The morph factors are per-frame work over the cut: the parent's and grandparent's
      // screen errors, from their states in the tree (split, so present).
      constexpr double kNone = std::numeric_limits<double>::infinity();
      std::array<double, 2> up{kNone, kNone};
      NodeKey ancestor = n.key;
      for (std::size_t k = 0; k < 2 && ancestor.heap > 0; ++k) {
        ancestor.heap = (ancestor.heap - 1) / 2;
        const auto it = nodes_.find(packKey(ancestor));
        if (it == nodes_.end()) break;
        up[k] = camera_.screenError(it->second.error, it->second.centre, it->second.radius);
      }
      setPatchMorph(dataset_, options_, up[0], up[1], patch);
      addCutPatch(cut, patch, n.triangles, n.vertices, seen);
    }
    cut.nodesVisited = decisions_;
    cut.nodesCulled = culled_;
    return cut;
  }

  std::uint64_t decisions() const noexcept { return decisions_; }
  bool worn() const noexcept { return path_ > 1e9 || turn_ > 1e9; }
  std::uint64_t size() const noexcept { return nodes_.size(); }
  double validityRadius() const noexcept {
    return distance_.empty() ? std::numeric_limits<double>::infinity()
                             : std::max(0.0, distance_.top().key - path_);
  }

 private:
  enum class Kind : std::uint8_t { Culled, Split, Drawn };
  struct NodeState final {
    NodeKey key;
    std::uint64_t row = 0;
    int level = 0;
    Kind kind = Kind::Drawn;
    bool canSplit = false;
    glm::dvec3 centre{0.0};
    double radius = 0.0;
    double error = 0.0;  ///< refinementBounds' errorMeters
    std::uint32_t triangles = 0;
    std::uint32_t vertices = 0;
    TileKey tile;
    std::uint64_t stamp = 0;  ///< of its latest evaluation; queue entries of older ones are stale
  };

  /// Evaluates a node's cull and split decisions at the current camera, creating it if new, and
  /// queues it for when they may change.
  void evaluate(const NodeKey& key, std::uint64_t row, int level) {
    const std::uint64_t packed = packKey(key);
    auto [it, created] = nodes_.try_emplace(packed);
    NodeState& n = it->second;
    if (created) {
      const NodeRecord record = dataset_.face(key.face).nodeAt(row);
      n.key = key;
      n.row = row;
      n.level = level;
      const RefinementBounds b = refinementBounds(dataset_, record, level, bounds_);
      n.centre = b.centre;
      n.radius = b.radiusMeters;
      n.error = b.errorMeters;
      n.canSplit = level < maxLevel_ && !record.leaf();
      n.triangles = record.triangleCount;
      n.vertices = record.vertexCount;
      n.tile = dataset_.tileOf(key);
      n.kind = Kind::Culled;  // nothing below it yet
    }
    ++decisions_;
    n.stamp = ++stamps_;
    const double distance = glm::length(n.centre - camera_.position());
    // Culled when outside both the widened frustum and the camera's own (near the camera a
    // sphere can be outside a widened side plane and still meet the narrower frustum).
    if (!wide_.sphereInFrustum(n.centre, n.radius) &&
        !camera_.sphereInFrustum(n.centre, n.radius)) {
      ++culled_;
      removeChildren(n);
      n.kind = Kind::Culled;
      // It stays culled while it stays wholly outside one of the camera's own planes.
      double clearance = -std::numeric_limits<double>::infinity();
      for (const glm::dvec4& p : camera_.frustumPlanes()) {
        clearance = std::max(clearance, -(glm::dot(glm::dvec3(p), n.centre) + p.w) - n.radius);
      }
      queueCull(n, safeSlack(clearance, distance + n.radius), distance);
      return;
    }
    // Inside the widened frustum: due again when it may leave it (then it and its subtree go).
    double inside = std::numeric_limits<double>::infinity();
    for (const glm::dvec4& p : wide_.frustumPlanes()) {
      inside = std::min(inside, glm::dot(glm::dvec3(p), n.centre) + p.w + n.radius);
    }
    queueCull(n, safeSlack(inside, distance + n.radius), distance);
    bool split = false;
    if (n.canSplit) {
      split = camera_.screenError(n.error, n.centre, n.radius) > options_.tolerancePixels;
      // The screen error crosses the tolerance where ‖c − p‖ = r + e·k/τ.
      const double threshold =
          n.radius + n.error * camera_.pixelsPerRadian() / options_.tolerancePixels;
      const double slack = safeSlack(std::abs(distance - threshold), distance + threshold);
      distance_.push({path_ + std::max(slack, 0.0), packed, n.stamp});
    }
    if (split) {
      if (n.kind != Kind::Split) {
        n.kind = Kind::Split;
        const std::uint64_t first = dataset_.face(key.face).firstChildOf(row);
        evaluate(NodeKey{key.face, key.tree, 2 * key.heap + 1}, first, level + 1);
        evaluate(NodeKey{key.face, key.tree, 2 * key.heap + 2}, first + 1, level + 1);
      }
    } else {
      removeChildren(n);
      n.kind = Kind::Drawn;
    }
  }

  void queueCull(const NodeState& n, double slack, double distance) {
    const int bucket = std::clamp(static_cast<int>(std::ceil(std::log2(std::max(distance, 1.0)))),
                                  0, kBuckets - 1);
    cull_[static_cast<std::size_t>(bucket)].push(
        {path_ + std::ldexp(turn_, bucket) + std::max(slack, 0.0), packKey(n.key), n.stamp});
  }

  void removeChildren(const NodeState& n) {
    if (n.kind != Kind::Split) return;
    for (std::uint64_t c = 1; c <= 2; ++c) {
      const NodeKey child{n.key.face, n.key.tree, 2 * n.key.heap + c};
      const auto it = nodes_.find(packKey(child));
      if (it == nodes_.end()) continue;
      removeChildren(it->second);
      nodes_.erase(it);
    }
  }

  const DatasetView& dataset_;
  double marginDegrees_;
  RefinementOptions options_;
  ExaggerationBounds bounds_;
  Viewport viewport_;
  int maxLevel_;
  Camera camera_;
  Camera wide_;
  std::unordered_map<std::uint64_t, NodeState> nodes_;
  Queue distance_;
  std::array<Queue, kBuckets> cull_;
  double path_ = 0.0;  ///< the camera's path length so far (L)
  double turn_ = 0.0;  ///< the sum of its rotations' chords ‖R_k − I‖ so far (Θ)
  std::uint64_t stamps_ = 0;
  std::uint64_t decisions_ = 0;
  std::uint64_t culled_ = 0;
};

IncrementalRefiner::IncrementalRefiner(const DatasetView& dataset, double marginDegrees)
    : dataset_(&dataset), marginDegrees_(marginDegrees) {}

IncrementalRefiner::~IncrementalRefiner() = default;

Cut IncrementalRefiner::update(const Camera& camera, const RefinementOptions& options) {
  stats_ = {};
  if (!options.frustumCulling) {
    // The whole planet's cut (watertight tests): nothing for a camera's movement to save.
    tree_.reset();
    Cut cut = refine(*dataset_, camera, options);
    stats_.decisions = cut.nodesVisited;
    stats_.rebuilt = true;
    return cut;
  }
  // A tree whose path sums have grown past 10⁹ m starts afresh, so that their rounding stays
  // far below the slacks' safety margin.
  if (!tree_ || !tree_->matches(camera, options) || tree_->worn()) {
    tree_ = std::make_unique<Tree>(*dataset_, marginDegrees_, camera, options);
    stats_.rebuilt = true;
  } else {
    tree_->moveTo(camera);
  }
  stats_.decisions = tree_->decisions();
  stats_.validityRadiusMeters = tree_->validityRadius();
  stats_.treeNodes = tree_->size();
  return tree_->cut();
}

}  // namespace pbdam::runtime
