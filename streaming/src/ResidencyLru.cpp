// ResidencyLru: slot bookkeeping and LRU eviction under a byte budget (ResidencyLru.h).
#include "pbdam/streaming/ResidencyLru.h"

#include <cassert>
#include <iterator>
#include <limits>

namespace pbdam::streaming {

ResidencyLru::ResidencyLru(std::uint64_t budgetBytes,
                           std::array<std::uint64_t, 2> slotBytes) noexcept
    : budgetBytes_(budgetBytes), slotBytes_(slotBytes) {
  assert(slotBytes[0] > 0 && slotBytes[1] > 0);
}

std::uint32_t ResidencyLru::capacity(ResidentKind kind) const noexcept {
  const std::uint64_t n = budgetBytes_ / slotBytes(kind);
  return n > std::numeric_limits<std::uint32_t>::max() ? std::numeric_limits<std::uint32_t>::max()
                                                       : static_cast<std::uint32_t>(n);
}

std::optional<std::uint32_t> ResidencyLru::find(ResidentKey key) const {
  const auto it = entries_.find(key.packed);
  if (it == entries_.end()) return std::nullopt;
  return it->second.slot;
}

void ResidencyLru::touch(ResidentKey key, std::uint64_t epoch) {
  const auto it = entries_.find(key.packed);
  assert(it != entries_.end());
  it->second.epoch = epoch;
  order_.splice(order_.begin(), order_, it->second.order);
}

std::optional<std::uint32_t> ResidencyLru::insert(ResidentKey key, std::uint64_t epoch,
                                                  std::vector<ResidentKey>& evicted) {
  assert(entries_.find(key.packed) == entries_.end());
  const ResidentKind kind = key.kind();
  const std::uint64_t need = slotBytes(kind);
  if (need > budgetBytes_) return std::nullopt;
  // Check first that evicting every evictable entry (earlier epoch, not pinned) would make
  // room, so that a failed insert evicts nothing. Without pins the scan stops at the first
  // entry of `epoch` (the rest is more recent); pinned entries may sit anywhere.
  std::uint64_t evictable = 0;
  for (auto it = order_.rbegin();
       it != order_.rend() && residentBytes_ - evictable + need > budgetBytes_; ++it) {
    const Entry& e = entries_.find(*it)->second;
    if (e.pins > 0) continue;
    if (e.epoch >= epoch) {
      if (pinnedBytes_ == 0) break;
      continue;
    }
    evictable += slotBytes(ResidentKey{*it}.kind());
  }
  if (residentBytes_ - evictable + need > budgetBytes_) return std::nullopt;
  auto victim = order_.end();
  while (residentBytes_ + need > budgetBytes_) {
    --victim;
    const auto found = entries_.find(*victim);
    if (found->second.pins > 0 || found->second.epoch >= epoch) continue;
    evicted.push_back(ResidentKey{*victim});
    victim = std::next(victim);  // release() erases the node; step back from its successor
    release(found);
  }
  Entry entry;
  entry.slot = takeSlot(kind);
  entry.epoch = epoch;
  order_.push_front(key.packed);
  entry.order = order_.begin();
  entries_.emplace(key.packed, entry);
  residentBytes_ += need;
  ++counts_[static_cast<std::size_t>(kind)];
  return entry.slot;
}

void ResidencyLru::erase(ResidentKey key) {
  const auto it = entries_.find(key.packed);
  if (it != entries_.end()) release(it);
}

void ResidencyLru::pin(ResidentKey key) {
  const auto it = entries_.find(key.packed);
  assert(it != entries_.end());
  if (it->second.pins++ == 0) pinnedBytes_ += slotBytes(key.kind());
}

void ResidencyLru::unpin(ResidentKey key) {
  const auto it = entries_.find(key.packed);
  assert(it != entries_.end() && it->second.pins > 0);
  if (--it->second.pins == 0) pinnedBytes_ -= slotBytes(key.kind());
}

std::uint32_t ResidencyLru::takeSlot(ResidentKind kind) {
  const auto k = static_cast<std::size_t>(kind);
  if (!freeSlots_[k].empty()) {
    const std::uint32_t slot = *freeSlots_[k].begin();
    freeSlots_[k].erase(freeSlots_[k].begin());
    return slot;
  }
  return nextSlot_[k]++;
}

void ResidencyLru::release(std::unordered_map<std::uint64_t, Entry>::iterator it) {
  const ResidentKind kind = ResidentKey{it->first}.kind();
  const auto k = static_cast<std::size_t>(kind);
  order_.erase(it->second.order);
  freeSlots_[k].insert(it->second.slot);
  // Keep the free set below the high-water mark small: trailing free slots shrink it.
  while (nextSlot_[k] > 0 && !freeSlots_[k].empty() &&
         *freeSlots_[k].rbegin() == nextSlot_[k] - 1) {
    freeSlots_[k].erase(std::prev(freeSlots_[k].end()));
    --nextSlot_[k];
  }
  residentBytes_ -= slotBytes(kind);
  if (it->second.pins > 0) pinnedBytes_ -= slotBytes(kind);
  --counts_[k];
  entries_.erase(it);
}

}  // namespace pbdam::streaming
