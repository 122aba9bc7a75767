// The finest fully resident level-capped cut, and the preload that guarantees one exists
// (NoStallPolicy.h; docs/architecture.md "Modes").
#include "pbdam/streaming/NoStallPolicy.h"

#include <algorithm>

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {

bool NoStallPolicy::rangeResident(const MappedFile& file, std::uint64_t offset,
                                  std::uint64_t bytes) {
  if (bytes == 0) return true;
  const auto r = file.residentPages(offset, bytes);
  return r && r->first == r->second;
}

NoStallCut NoStallPolicy::cut(const Camera& camera, RefinementOptions options) const {
  const DatasetView& view = dataset_->view();
  int level = options.maxLevel < 0 ? view.depth() : std::min(options.maxLevel, view.depth());
  // Node records too must be at hand: a paged node table's chunk that would be read from disk
  // caps the level like a patch that is not resident (its children stay out of the cut).
  options.residentRecordsOnly = true;
  for (;;) {
    options.maxLevel = level;
    Cut cut = refine(view, camera, options);
    int worst = cut.unresidentRecordLevel < 0 ? level + 1 : cut.unresidentRecordLevel;
    for (const CutPatch& p : cut.patches) {
      const NodeRecord n = view.node(p.node);
      if (!rangeResident(dataset_->faceFile(p.node.face), n.blobOffset, n.blobsBytes())) {
        worst = std::min(worst, p.level);
      }
    }
    for (const TileKey& t : cut.tiles) {
      const TextureRecord r = view.textureNode(t);
      if (!rangeResident(dataset_->faceFile(t.face), r.blobOffset, r.blobBytes)) {
        // Tile level t is drawn with patches of levels 2t and 2t+1.
        const auto tileLevel = static_cast<int>(textureLevelOfHeap(t.heap));
        worst = std::min(worst, 2 * tileLevel);
      }
    }
    if (worst > level) return {std::move(cut), level};
    level = std::min(level, worst) - 1;
    if (level < 0) return {Cut{}, -1};
  }
}

NoStallCut NoStallPolicy::cutAfter(const Camera& camera, RefinementOptions options, int previousCap,
                                   int maxRise) const {
  if (previousCap < 0) return cut(camera, options);
  const int depth = dataset_->view().depth();
  const int top = options.maxLevel < 0 ? depth : std::min(options.maxLevel, depth);
  RefinementOptions limited = options;
  limited.maxLevel = std::min(top, previousCap + maxRise);
  NoStallCut step = cut(camera, limited);
  if (step.levelCap > previousCap || step.levelCap == limited.maxLevel) return step;
  NoStallCut finest = cut(camera, options);
  return finest.levelCap > step.levelCap ? std::move(finest) : std::move(step);
}

std::vector<Error> NoStallPolicy::preloadCoarseLevels() const {
  const DatasetView& view = dataset_->view();
  std::vector<Error> unreadable;
  const auto touch = [&unreadable](const MappedFile& file, std::uint64_t offset,
                                   std::uint64_t bytes) {
    if (bytes == 0) return;
    (void)file.willNeed(offset, bytes);
    // Guarded reads: an unreadable page is skipped and reported, not a SIGBUS.
    if (auto r = file.touch(offset, bytes); !r) unreadable.push_back(std::move(r).error());
  };
  for (int f = 0; f < 6; ++f) {
    const MappedFile& file = dataset_->faceFile(f);
    const FaceHeader& h = view.face(f).header();
    if (view.face(f).nodeTablePaged()) {
      // A paged node table is read back chunk by chunk as refinement needs it (it may be far
      // larger than memory): the header and the texture table only.
      touch(file, 0, h.nodeTableOffset);
      touch(file, h.textureTableOffset, h.blobsOffset - h.textureTableOffset);
    } else {
      touch(file, 0, h.blobsOffset);
    }
    for (std::uint8_t tree = 0; tree < 2; ++tree) {
      for (std::uint64_t heap = 0; heap < 7; ++heap) {
        const auto row = view.face(f).findNode(tree, heap);
        if (!row) continue;  // above a shallow leaf
        const NodeRecord n = view.face(f).nodeAt(*row);
        touch(file, n.blobOffset, n.blobsBytes());
      }
    }
    const TextureRecord root = view.textureNode(TileKey{static_cast<std::uint8_t>(f), 0});
    touch(file, root.blobOffset, root.blobBytes);
    // The tables stay mapped: refinement reads them every frame, and mapped pages the render
    // thread keeps referencing are the last the kernel reclaims. Only the blobs leave the RSS.
    (void)file.releaseResident(h.blobsOffset, file.size() - h.blobsOffset);
  }
  return unreadable;
}

}  // namespace pbdam::streaming
