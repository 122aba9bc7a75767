// Frame-to-frame cut reuse (docs/architecture.md "Cut reuse", [Hybrid LEB] §4.3): the refinement
// keeps the previous frame's refinement tree and re-evaluates a node's split or cull decision
// only once the camera may have moved or turned far enough to change it.
//
// Each evaluated node gets a slack, computed when it is evaluated: for its split decision the
// distance between the camera and the sphere at which its screen error crosses the tolerance
// (‖c − p‖ = r + e·k/τ; the distance to a point moves by at most the camera's own movement);
// for its cull decision the distance by which its sphere clears the frustum plane that decides
// it, against which a camera that moved by δ and turned by a rotation R moves the plane by at
// most δ + ‖R − I‖·‖c − p‖. The camera's path length L and summed rotation chords Θ (Σ‖R_k − I‖
// ≥ ‖R − I‖ over the frames since) bound both, so a node is due again when L, or L + D·Θ for a
// node at distance at most D, passes a key fixed when it was evaluated. The nodes due are the
// only ones evaluated; while no key is reached, the whole cut is reused with no decision at all
// (the "sphere of validity" of [Hybrid LEB] is the smallest distance slack).
//
// The tree is refined against the camera's frustum widened by a margin (Camera::
// withFrustumMargin), so that a culled node stays culled while the view turns by less than the
// margin; the cut returned is the tree's unsplit nodes culled against the camera's own frustum,
// in depth-first order of the 12 trees. Because spheres nest, that is exactly the cut of the
// stateless refine() for the same camera and options (tests/runtime/TestCutReuse.cpp checks
// every frame of the Mars and Earth flights). Screen errors of the cut are recomputed each frame.
// Thread-safety: one thread at a time; the dataset must outlive it.
#pragma once

#include <cstdint>
#include <memory>

#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Refinement.h"

namespace pbdam::runtime {

/// What the last IncrementalRefiner::update() did.
struct CutReuseStats final {
  /// Split or cull decisions evaluated this frame (a stateless refinement evaluates one per
  /// node it visits: Cut::nodesVisited).
  std::uint64_t decisions = 0;
  /// Whether the tree was rebuilt from the roots (first frame, other options or viewport).
  bool rebuilt = false;
  /// The radius around this frame's camera within which no split decision can change (the
  /// smallest distance slack left), metres.
  double validityRadiusMeters = 0.0;
  /// Nodes held in the refinement tree (evaluated, culled or split).
  std::uint64_t treeNodes = 0;
};

/// Refinement that keeps its tree from frame to frame: each update() re-evaluates only the
/// decisions the camera's move can have changed, and returns the cut refine() would. Holds a
/// reference to the dataset, which must outlive it; used by one thread at a time.
class IncrementalRefiner final {
 public:
  /// `marginDegrees` widens the frustum the tree is culled against (≥ 0).
  IncrementalRefiner(const DatasetView& dataset, double marginDegrees = 10.0);
  ~IncrementalRefiner();
  IncrementalRefiner(const IncrementalRefiner&) = delete;
  IncrementalRefiner& operator=(const IncrementalRefiner&) = delete;

  /// The cut for `camera`: the same patches, tiles and counts as refine(dataset, camera,
  /// options) (nodesVisited and nodesCulled count this frame's decisions). Other options or
  /// another viewport than the last call's rebuild the tree; without frustum culling it is
  /// refine() itself.
  Cut update(const Camera& camera, const RefinementOptions& options);

  /// What the last update() did.
  const CutReuseStats& lastStats() const noexcept { return stats_; }

 private:
  class Tree;
  const DatasetView* dataset_;
  double marginDegrees_;
  std::unique_ptr<Tree> tree_;
  CutReuseStats stats_;
};

}  // namespace pbdam::runtime
