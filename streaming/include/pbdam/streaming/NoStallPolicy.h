// NoStallPolicy: the no-stall mode (docs/architecture.md "Modes") — the render thread never waits
// on disk; it draws the finest conforming cut whose patches and tiles are all in the page cache
// already, while a loader thread (Prefetcher) brings in what the camera needs. The cut is capped by
// one global level (a cap applies to both triangles of every diamond, so the capped cut stays
// conforming). A patch or tile the caller already holds decoded (its GPU cache: NoStallCached)
// needs no page. No Vulkan here. Thread-safety: const members only; any thread may call them
// (the NoStallCached queries must then be safe from that thread).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "pbdam/formats/Result.h"

#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::streaming {

/// Pages locked in memory (mlock) until the object goes: a no-stall cut's byte ranges, found
/// resident, held so that the kernel cannot evict them between the check and the frame's
/// decode (under a tight memory cap it otherwise does, and the render thread faults). Holds
/// nest: they are counted per page (PageLocks), so letting a frame's hold go leaves locked
/// the pages another hold has (the run-long hold on the coarse levels). Best effort: a range
/// the process may not lock (RLIMIT_MEMLOCK) is left unlocked. Move-only; one object is used
/// by one thread at a time, and objects on different threads may hold the same pages.
class HeldPages final {
 public:
  HeldPages() = default;
  /// Takes over `other`'s locks, leaving it holding nothing.
  /// @{
  HeldPages(HeldPages&& other) noexcept;
  HeldPages& operator=(HeldPages&& other) noexcept;
  /// @}
  HeldPages(const HeldPages&) = delete;
  HeldPages& operator=(const HeldPages&) = delete;
  ~HeldPages();
  /// Locks the pages overlapping [offset, offset + bytes) of `file`; false when mlock refused.
  bool hold(const MappedFile& file, std::uint64_t offset, std::uint64_t bytes);
  /// Bytes of the pages locked.
  std::uint64_t bytes() const noexcept { return bytes_; }
  /// Drops this process's page-table entries of [offset, offset + bytes) of `file`
  /// (MappedFile::releaseResident) except on the pages held here, which madvise cannot drop
  /// (it would stop at the first locked page).
  void releaseResidentAround(const MappedFile& file, std::uint64_t offset,
                             std::uint64_t bytes) const;

 private:
  void release() noexcept;
  std::vector<std::pair<const std::byte*, std::size_t>> ranges_;
  std::uint64_t bytes_ = 0;
};

/// A cut and the global level cap it was refined under.
struct NoStallCut final {
  runtime::Cut cut;  ///< what to draw
  /// The finest level drawn (refinement's maxLevel); the dataset's depth when nothing was
  /// capped; -1 (and an empty cut) when not even the roots are resident.
  int levelCap = -1;
  /// With NoStallPolicy's holdPages, the cut's patch and tile pages, locked: keep them until
  /// the frame drawn from the cut has decoded what it needed.
  HeldPages held;
};

/// What the caller holds decoded already, so that drawing it reads no page: the renderer's GPU
/// cache (gpu::GpuCache::holds). Without it, only the page cache counts, and a patch the kernel
/// evicted from the page cache caps the cut though the GPU cache still holds it (with no memory
/// budget nothing is locked: under other processes' memory pressure the roots went, and frames
/// were drawn empty). Empty functions hold nothing.
struct NoStallCached final {
  std::function<bool(const runtime::NodeKey&)> patch;  ///< whether a patch is held decoded
  std::function<bool(const runtime::TileKey&)> tile;   ///< whether a tile is held decoded
};

/// Chooses no-stall cuts over one mapped dataset, which must outlive it.
class NoStallPolicy final {
 public:
  /// With `holdPages` (under a memory budget) every cut comes with its pages locked
  /// (NoStallCut::held).
  /// `cached`: what needs no page (NoStallCached); a cached patch or tile is not locked either.
  explicit NoStallPolicy(const MappedDataset& dataset, bool holdPages = false,
                         NoStallCached cached = {}) noexcept
      : dataset_(&dataset), holdPages_(holdPages), cached_(std::move(cached)) {}

  /// Whether every page of [offset, offset + bytes) of `file` is in the page cache (mincore);
  /// an empty range is.
  static bool rangeResident(const MappedFile& file, std::uint64_t offset, std::uint64_t bytes);

  /// Brings every node table, the patches of levels 0-2 and the root tiles into the page cache;
  /// the tables stay mapped, the blobs leave the process's RSS again (a caller that drops page
  /// tables each frame should keep the tables' too): no-stall refinement must not fault on
  /// node records,
  /// and with the coarsest levels resident there is always a conforming cut to draw. Blocks on
  /// the reads: call it before the first frame. Ranges that cannot be read (a truncated file,
  /// a failing disk) are skipped; their errors, naming the file and offset, are returned (empty
  /// when everything was read).
  /// With `keep`, the blobs read (and a paged node table's chunks) are also locked in memory
  /// there for as long as the caller keeps it (HeldPages): under a memory budget, or under other
  /// processes' memory pressure, the kernel would otherwise evict the coarse levels the
  /// guarantee rests on, and a frame would have nothing to draw. Tables held whole are not
  /// locked: they were copied out at open.
  std::vector<formats::Error> preloadCoarseLevels(HeldPages* keep = nullptr) const;

  /// The finest level-capped cut for `camera` (refined with `options`; its maxLevel, when set,
  /// is the highest cap tried) whose patches and tiles are all cached or have their byte ranges
  /// resident. Faults in node records only.
  NoStallCut cut(const runtime::Camera& camera, runtime::RefinementOptions options) const;

  /// The cut of a frame whose previous frame was drawn under `previousCap` (-1: none). The cap
  /// rises by at most `maxRise` bintree levels a frame, so that a level whose data has just
  /// arrived is decoded over a few frames rather than in one. But when no cut within that rise
  /// is resident and a finer one is, it is the finer one: the loader fetches the camera's own
  /// cut, not the levels between, so waiting for those would wait for ever.
  NoStallCut cutAfter(const runtime::Camera& camera, runtime::RefinementOptions options,
                      int previousCap, int maxRise = 2) const;

 private:
  const MappedDataset* dataset_;
  bool holdPages_ = false;
  NoStallCached cached_;
};

}  // namespace pbdam::streaming
