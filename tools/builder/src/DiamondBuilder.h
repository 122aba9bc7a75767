// The per-diamond work of one bintree level of the build (docs/builder.md "Saturation",
// "Checkpoints"; [P-BDAM 2003] §5): the diamond's two patches — regular at the leaves, else
// simplified from the block of its four children read from the carry of the level below —
// measured and encoded, their error and bounding sphere saturated over the diamond DAG, and
// the bytes that go to the level's nodes and carry part files. Private to the builder.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <vector>

#include "ForestPlan.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/Result.h"

namespace pbdam::builder {

/// `v` rounded up to the nearest float (so a stored error never understates the measured one).
float roundUpToFloat(double v);

/// What one diamond contributes to its level's part files.
struct DiamondBytes final {
  std::vector<std::byte> nodes;     ///< its two node entries (putNodeEntry)
  std::vector<std::byte> carry;     ///< its two carry records, when the level writes a carry
  std::size_t firstCarryBytes = 0;  ///< the second triangle's carry record starts here
  std::uint64_t rawBytes = 0;       ///< the two patches uncompressed (8 B a vertex, 6 a triangle)
};

/// What the diamonds of one level are built with.
struct DiamondLevel final {
  const SampleGrid& grid;
  const Lattice& lattice;
  const ForestPlan& plan;  ///< which nodes exist and which are leaves
  int depth = 0;           ///< the bintree depth (the deepest leaves' level)
  int level = 0;
  /// The carry of level + 1 (nothing at the leaf level).
  const CarryReader* below = nullptr;
  std::uint32_t minPatchTriangles = 0;
  double errorMargin = 0.25;
  double heightStepMeters = 0.0;
  bool writeCarry = false;  ///< the level writes a carry (every level but 0)
};

/// Builds the diamonds of one level. Thread-safe: build() runs concurrently on different
/// diamonds; the first failure is kept and stops nothing by itself (callers check failed()).
class DiamondBuilder final {
 public:
  explicit DiamondBuilder(const DiamondLevel& level) : level_(level) {}

  /// Builds `diamond` (a leaf without partner: its second node ForestPlan::kNoNode) into `out`.
  /// False on failure (then `out` is incomplete and failure() says why, for the first failure
  /// of any thread).
  bool build(const Diamond& diamond, DiamondBytes& out);

  bool failed() const noexcept { return failed_; }
  /// The first failure; only meaningful once failed() and no build() runs.
  const formats::Error& failure() const noexcept { return failure_; }
  std::uint64_t insertedPoints() const noexcept { return inserted_; }
  std::uint64_t halvesOverTarget() const noexcept { return overTarget_; }

 private:
  struct Node;
  struct Saturated;
  void noteFailure(formats::Error error);
  /// Measures and encodes `patch` of `t` into `node`, and gives `patch` its per-triangle sample
  /// errors for the carry: against the samples, or with `children` (the two patches that tile
  /// t) bounded through them where that keeps within `targetMeters`.
  bool makeNode(const runtime::BinTriangle& t, WorkPatch& patch, Node& node,
                const std::array<const WorkPatch*, 2>* children = nullptr,
                double targetMeters = 0.0);
  bool readChildren(const std::array<runtime::BinTriangle, 2>& tri,
                    std::array<Saturated, 4>& saturated,
                    std::array<std::array<WorkPatch, 2>, 2>& children);
  /// The diamond's `count` nodes (1: a leaf without partner), leaves or from the block.
  bool makeNodes(const std::array<runtime::BinTriangle, 2>& tri, std::size_t count, bool leaf,
                 std::array<Node, 2>& nodes, std::array<WorkPatch, 2>& made,
                 std::array<Saturated, 4>& childSaturated);
  Saturated saturate(const std::array<Node, 2>& nodes, std::size_t count, bool leaf,
                     const std::array<Saturated, 4>& childSaturated) const;
  void serialise(std::array<Node, 2>& nodes, std::size_t count, bool leaf,
                 const Saturated& saturated, const std::array<WorkPatch, 2>& made,
                 DiamondBytes& out) const;

  DiamondLevel level_;
  std::mutex failureMutex_;
  std::atomic<bool> failed_{false};
  formats::Error failure_;
  std::atomic<std::uint64_t> inserted_{0};
  std::atomic<std::uint64_t> overTarget_{0};
};

}  // namespace pbdam::builder
