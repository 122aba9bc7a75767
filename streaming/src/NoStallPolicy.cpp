// The finest fully resident level-capped cut, and the preload that guarantees one exists
// (NoStallPolicy.h; docs/architecture.md "Modes").
#include "pbdam/streaming/NoStallPolicy.h"

#include <algorithm>

#include "pbdam/streaming/PageLocks.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {

HeldPages::HeldPages(HeldPages&& other) noexcept
    : ranges_(std::move(other.ranges_)), bytes_(std::exchange(other.bytes_, 0)) {
  other.ranges_.clear();
}

HeldPages& HeldPages::operator=(HeldPages&& other) noexcept {
  if (this != &other) {
    release();
    ranges_ = std::move(other.ranges_);
    other.ranges_.clear();
    bytes_ = std::exchange(other.bytes_, 0);
  }
  return *this;
}

HeldPages::~HeldPages() { release(); }

bool HeldPages::hold(const MappedFile& file, std::uint64_t offset, std::uint64_t bytes) {
  if (bytes == 0) return true;
  const std::byte* begin = file.bytes().data() + offset;
  if (!PageLocks::instance().lock(begin, bytes)) return false;
  ranges_.emplace_back(begin, bytes);
  bytes_ += bytes;
  return true;
}

void HeldPages::releaseResidentAround(const MappedFile& file, std::uint64_t offset,
                                      std::uint64_t bytes) const {
  const std::byte* base = file.bytes().data();
  const std::uint64_t page = MappedFile::pageSize();
  // The held ranges inside this file, widened to whole pages, in order.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> skip;
  for (const auto& [begin, size] : ranges_) {
    if (begin < base || begin >= base + file.size()) continue;
    const auto at = static_cast<std::uint64_t>(begin - base);
    skip.emplace_back(at / page * page, (at + size + page - 1) / page * page);
  }
  std::sort(skip.begin(), skip.end());
  std::uint64_t from = offset;
  const std::uint64_t end = offset + bytes;
  for (const auto& [lo, hi] : skip) {
    if (hi <= from || lo >= end) continue;
    if (lo > from) (void)file.releaseResident(from, lo - from);
    from = std::max(from, hi);
  }
  if (from < end) (void)file.releaseResident(from, end - from);
}

void HeldPages::release() noexcept {
  for (const auto& [begin, bytes] : ranges_) PageLocks::instance().unlock(begin, bytes);
  ranges_.clear();
  bytes_ = 0;
}

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
  // The byte ranges a cut will read (what the caller holds decoded reads nothing), found
  // resident, are locked at once: the kernel could otherwise take a page between this check and
  // the frame's decode — or between it and a later mlock, which would then read the page back
  // from disk on the render thread. A refinement at a lower cap starts its locks over.
  HeldPages held;
  // What the GPU cache holds (`cached`) is at hand whatever the page cache says; but a cut
  // larger than the cache is drawn in passes that evict some of it before its draw, whose decode
  // then reads the file: its pages too are locked where they are resident.
  const auto atHand = [&held, this](bool cached, const MappedFile& file, std::uint64_t offset,
                                    std::uint64_t bytes) {
    if (!rangeResident(file, offset, bytes)) return cached;
    // Best effort: a range mlock refuses (no memory to lock) is at hand, unlocked.
    if (holdPages_) (void)held.hold(file, offset, bytes);
    return true;
  };
  for (;;) {
    options.maxLevel = level;
    Cut cut = refine(view, camera, options);
    int worst = cut.unresidentRecordLevel < 0 ? level + 1 : cut.unresidentRecordLevel;
    held = HeldPages{};  // unlocks the previous cap's ranges
    for (const CutPatch& p : cut.patches) {
      const NodeRecord n = view.node(p.node);
      const bool cached = cached_.patch && cached_.patch(p.node);
      if (!atHand(cached, dataset_->faceFile(p.node.face), n.blobOffset, n.blobsBytes())) {
        worst = std::min(worst, p.level);
      }
    }
    for (const TileKey& t : cut.tiles) {
      const TextureRecord r = view.textureNode(t);
      const bool cached = cached_.tile && cached_.tile(t);
      if (!atHand(cached, dataset_->faceFile(t.face), r.blobOffset, r.blobsBytes())) {
        // Tile level t is drawn with patches of levels 2t and 2t+1.
        const auto tileLevel = static_cast<int>(textureLevelOfHeap(t.heap));
        worst = std::min(worst, 2 * tileLevel);
      }
    }
    if (worst > level) return NoStallCut{std::move(cut), level, std::move(held)};
    level = std::min(level, worst) - 1;
    if (level < 0) return {Cut{}, -1, {}};
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

std::vector<Error> NoStallPolicy::preloadCoarseLevels(HeldPages* keep) const {
  const DatasetView& view = dataset_->view();
  std::vector<Error> unreadable;
  const auto touch = [&unreadable, keep](const MappedFile& file, std::uint64_t offset,
                                         std::uint64_t bytes, bool lock = true) {
    if (bytes == 0) return;
    (void)file.willNeed(offset, bytes);
    // Guarded reads: an unreadable page is skipped and reported, not a SIGBUS.
    if (auto r = file.touch(offset, bytes); !r) {
      unreadable.push_back(std::move(r).error());
    } else if (keep && lock) {
      (void)keep->hold(file, offset, bytes);
    }
  };
  for (int f = 0; f < 6; ++f) {
    const MappedFile& file = dataset_->faceFile(f);
    const FaceHeader& h = view.face(f).header();
    if (view.face(f).nodeTablePaged()) {
      // A paged node table is read back chunk by chunk as refinement needs it (it may be far
      // larger than memory): the header and the texture table only.
      touch(file, 0, h.nodeTableOffset);
      touch(file, h.textureTableOffset, h.blobsOffset - h.textureTableOffset);
      // The chunks of the coarsest rows (the roots and their first descendants): no-stall
      // refinement always reads them.
      for (const std::uint64_t first : {std::uint64_t{0}, h.tree1FirstNode}) {
        const std::uint64_t rows = std::min(kNodeTableChunkRows, h.nodeCount - first);
        touch(file, view.face(f).nodeRecordOffset(first), rows * kNodeRecordBytes);
      }
    } else {
      // Tables held whole were copied out at open: refinement never reads these pages, so
      // they are read (a paging run's first frames use them) but not locked.
      touch(file, 0, h.blobsOffset, false);
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
    touch(file, root.blobOffset, root.blobsBytes());
    // The tables stay mapped: refinement reads them every frame, and mapped pages the render
    // thread keeps referencing are the last the kernel reclaims. Only the blobs leave the RSS.
    if (keep) {
      keep->releaseResidentAround(file, h.blobsOffset, file.size() - h.blobsOffset);
    } else {
      (void)file.releaseResident(h.blobsOffset, file.size() - h.blobsOffset);
    }
  }
  return unreadable;
}

}  // namespace pbdam::streaming
