// ResidencyLru: the bookkeeping of the GPU-resident patch and texture cache (docs/architecture.md
// "Streaming") — which patches and tiles occupy which pool slot, one least-recently-used order over
// both kinds, and a byte budget counted in slot bytes. Residency policy, not Vulkan: gpu/GpuCache
// owns the pools the slot numbers index. Thread-safety: none; GpuCache guards it with its lock when
// several render threads share it.
#pragma once

#include <array>
#include <cstdint>
#include <list>
#include <optional>
#include <set>
#include <unordered_map>
#include <vector>

#include "pbdam/runtime/DatasetView.h"

namespace pbdam::streaming {

/// What a cache entry holds.
enum class ResidentKind : std::uint8_t {
  Patch = 0,  ///< a patch's vertices and indices (one vertex-pool + index-pool slot)
  Tile = 1,   ///< a texture tile (one texture-array layer)
};

/// A patch or a tile as one integer: packKey() of its NodeKey or TileKey (DatasetView.h), whose
/// top bit tells the kinds apart.
struct ResidentKey final {
  std::uint64_t packed = 0;  ///< runtime::packKey() of the key

  /// The key of patch `key`.
  static ResidentKey patch(const runtime::NodeKey& key) noexcept { return {runtime::packKey(key)}; }
  /// The key of tile `key`.
  static ResidentKey tile(const runtime::TileKey& key) noexcept { return {runtime::packKey(key)}; }
  /// Patch or Tile, from the packed key's top bit.
  ResidentKind kind() const noexcept {
    return (packed >> 63) != 0 ? ResidentKind::Tile : ResidentKind::Patch;
  }
  /// Equal packed keys.
  friend bool operator==(const ResidentKey&, const ResidentKey&) = default;
};

/// One LRU over patches and tiles together. Every entry costs its kind's slot bytes; the sum
/// over resident entries (residentBytes) never exceeds the budget. Entries are stamped with the
/// epoch (the pass number) that last used them; insert() evicts least-recently-used entries of
/// earlier epochs only, so nothing the current pass draws is ever evicted. Entries can also be
/// pinned (counted): a pinned entry is never evicted whatever its epoch — that is how the
/// passes of several renderers in flight at once keep each other's entries resident.
///
/// Slots are numbered per kind from 0; a new entry takes the lowest free slot, so the highest
/// slot in use stays below budget / slot bytes of its kind and pools can grow on demand.
class ResidencyLru final {
 public:
  /// `slotBytes[kind]` must be > 0.
  ResidencyLru(std::uint64_t budgetBytes, std::array<std::uint64_t, 2> slotBytes) noexcept;

  /// The budget it was made with.
  std::uint64_t budgetBytes() const noexcept { return budgetBytes_; }
  /// Slot bytes of the resident entries (at most the budget).
  std::uint64_t residentBytes() const noexcept { return residentBytes_; }
  /// What an entry of `kind` costs.
  std::uint64_t slotBytes(ResidentKind kind) const noexcept {
    return slotBytes_[static_cast<std::size_t>(kind)];
  }
  /// The most entries of `kind` the budget allows (budget / slot bytes).
  std::uint32_t capacity(ResidentKind kind) const noexcept;
  /// Entries resident now, of both kinds.
  std::size_t size() const noexcept { return entries_.size(); }
  /// Entries of `kind` resident now.
  std::uint32_t count(ResidentKind kind) const noexcept {
    return counts_[static_cast<std::size_t>(kind)];
  }

  /// The slot of a resident entry, or nullopt.
  std::optional<std::uint32_t> find(ResidentKey key) const;

  /// Marks a resident entry as used by `epoch` (most recently used). `key` must be resident.
  void touch(ResidentKey key, std::uint64_t epoch);

  /// Makes `key` (not resident) resident for `epoch`: evicts least-recently-used entries of
  /// earlier epochs until its slot bytes fit in the budget (appending them to `evicted`), then
  /// returns its slot. Returns nullopt, evicting nothing, when it cannot fit without evicting an
  /// entry of `epoch` itself.
  std::optional<std::uint32_t> insert(ResidentKey key, std::uint64_t epoch,
                                      std::vector<ResidentKey>& evicted);

  /// Removes `key` if resident (an upload that failed), pinned or not; its slot becomes free.
  void erase(ResidentKey key);

  /// Pins a resident entry once more (pins are counted); pinned entries are never evicted.
  void pin(ResidentKey key);
  /// Takes back one pin of a resident, pinned entry.
  void unpin(ResidentKey key);
  /// Slot bytes of the entries pinned now.
  std::uint64_t pinnedBytes() const noexcept { return pinnedBytes_; }

 private:
  struct Entry {
    std::uint32_t slot = 0;
    std::uint64_t epoch = 0;
    std::uint32_t pins = 0;
    std::list<std::uint64_t>::iterator order;  ///< position in order_
  };
  std::uint32_t takeSlot(ResidentKind kind);
  void release(std::unordered_map<std::uint64_t, Entry>::iterator it);

  std::uint64_t budgetBytes_;
  std::array<std::uint64_t, 2> slotBytes_;
  std::uint64_t residentBytes_ = 0;
  std::uint64_t pinnedBytes_ = 0;
  std::array<std::uint32_t, 2> counts_{};
  std::unordered_map<std::uint64_t, Entry> entries_;
  std::list<std::uint64_t> order_;                    ///< most recently used first
  std::array<std::set<std::uint32_t>, 2> freeSlots_;  ///< freed slots below nextSlot_
  std::array<std::uint32_t, 2> nextSlot_{};           ///< slots ever handed out, per kind
};

}  // namespace pbdam::streaming
