// One pass of a terrain frame (PassDrawer.h; [P-BDAM 2003] §4.2, §4.4).
#include "PassDrawer.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <mutex>
#include <unordered_set>

#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/streaming/ResidencyLru.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::gpu {

namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// The pass's cache entries: its drawable patches, then its distinct tiles in first-use order.
std::vector<DecodeJob> passEntries(const PassInput& in) {
  std::vector<DecodeJob> entries;
  entries.reserve(2 * (in.end - in.begin));
  for (std::size_t i = in.begin; i < in.end; ++i) {
    if (!drawable(in.nodes[i])) continue;
    DecodeJob entry;
    entry.key = ResidentKey::patch(in.cut.patches[i].node);
    entry.node = in.cut.patches[i].node;
    entries.push_back(entry);
  }
  std::unordered_set<std::uint64_t> seenTiles;
  const auto addTile = [&](const TileKey& key) {
    const ResidentKey tile = ResidentKey::tile(key);
    if (!seenTiles.insert(tile.packed).second) return;
    DecodeJob entry;
    entry.key = tile;
    entry.tile = key;
    entries.push_back(entry);
  };
  for (std::size_t i = in.begin; i < in.end; ++i) {
    if (!drawable(in.nodes[i])) continue;
    addTile(in.cut.patches[i].tile);
    if (in.cut.patches[i].blendsTile()) addTile(in.cut.patches[i].morphTile);
  }
  return entries;
}

}  // namespace

/// Passes: the longest prefixes of the cut whose slot bytes fit the budget; returns each
/// pass's end (one past its last patch).
std::vector<std::size_t> planPasses(const GpuCache::State& c, const Cut& cut,
                                    const std::vector<NodeRecord>& nodes) {
  std::vector<std::size_t> passEnds;
  const std::uint64_t budget = c.lru->budgetBytes();
  std::uint64_t bytes = 0;
  std::unordered_set<std::uint64_t> passTiles;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (!drawable(nodes[i])) continue;
    const std::uint64_t tile = ResidentKey::tile(cut.patches[i].tile).packed;
    const std::uint64_t morphTile = ResidentKey::tile(cut.patches[i].morphTile).packed;
    const auto tileBytes = [&] {
      std::uint64_t b = passTiles.count(tile) != 0 ? 0 : c.texture.slotBytes;
      if (morphTile != tile && passTiles.count(morphTile) == 0) b += c.texture.slotBytes;
      return b;
    };
    std::uint64_t need = c.patchSlot + tileBytes();
    if (bytes > 0 && bytes + need > budget) {
      passEnds.push_back(i);
      bytes = 0;
      passTiles.clear();
      need = c.patchSlot + tileBytes();
    }
    bytes += need;
    passTiles.insert(tile);
    passTiles.insert(morphTile);
  }
  passEnds.push_back(nodes.size());
  return passEnds;
}

Result<void> PassDrawer::draw(bool readback, const PresentTarget* present) {
  const std::vector<DecodeJob> entries = passEntries(in_);
  {
    // Under the cache lock from here through the uploads: nothing another renderer does can
    // evict what this pass pins, and nobody sees an entry before its upload has completed.
    // The lease hands the pass's pins (and failed uploads) back on every path, or to the
    // slot when the pass stays in flight.
    CacheLease lease(*m_.shared);
    if (Result<void> r = reserve(lease, entries); !r) return r;
    if (Result<void> r = stage(); !r) return r;
    if (Result<void> r = record(readback, present); !r) return r;
    if (Result<void> r = submit(lease, present); !r) return r;
  }
  if (!in_.placement.last) m_.readTimestamps(slot_, true, stats_);
  countUploads();
  return {};
}

Result<void> PassDrawer::drawIntoHost(VkCommandBuffer hostCmd, VkPipeline pipeline) {
  const std::vector<DecodeJob> entries = passEntries(in_);
  {
    CacheLease lease(*m_.shared);
    if (Result<void> r = reserve(lease, entries); !r) return r;
    if (Result<void> r = stage(); !r) return r;
    if (Result<void> r = recordUploads(); !r) return r;
    // With a private cache the uploads' barriers order them before the host's submission on
    // the same queue; with a shared one they complete before any renderer sees the entries.
    const std::array<VkCommandBuffer, 1> uploads = {slot_.commands[FrameSlot::kUploadCommands]};
    if (Result<void> r =
            m_.submitSlot(slot_, uploads, nullptr, "terrain uploads (host pass)", !m_.privateCache);
        !r) {
      return r;
    }
    lease.commitUploads();
    slot_.pins = lease.keepPins();
  }
  const DrawRecorder recorder(m_.shared->pipeline, m_.shared->patches, m_.shared->tiles,
                              slot_.recordsSet, slot_.overlay->set(), m_.atmosphere->set());
  const runtime::Viewport& viewport = in_.camera.viewport();
  recorder.recordDraws(hostCmd, pipeline, viewport.width, viewport.height, in_.push, work_.draws);
  countUploads();
  return {};
}

void PassDrawer::countUploads() {
  stats_.misses += work_.misses.size();
  for (const DecodeJob& job : work_.misses) stats_.bytesUploaded += job.bytes;
}

Result<void> PassDrawer::reserve(CacheLease& lease, const std::vector<DecodeJob>& entries) {
  std::vector<ResidentKey> keys;
  keys.reserve(entries.size());
  for (const DecodeJob& entry : entries) keys.push_back(entry.key);
  std::vector<std::size_t> missIndices;
  LeaseCounters counters;
  counters.peakResidentBytes = stats_.peakResidentBytes;
  if (Result<void> r = lease.reserve(keys, missIndices, work_.missSlots, counters,
                                     [this] { return m_.finishOldestLocked(); });
      !r) {
    return r;
  }
  stats_.hits += counters.hits;
  stats_.evictions += counters.evictions;
  stats_.peakResidentBytes = counters.peakResidentBytes;
  for (const std::size_t i : missIndices) work_.misses.push_back(entries[i]);

  // Patch and tile slots of the whole pass; pools grow to cover them.
  const ResidencyLru& lru = lease.lru();
  std::uint32_t patchSlotCount = 0, tileSlotCount = 0;
  for (std::size_t i = in_.begin; i < in_.end; ++i) {
    if (!drawable(in_.nodes[i])) continue;
    DrawItem item;
    item.patchSlot = *lru.find(ResidentKey::patch(in_.cut.patches[i].node));
    item.tileSlot = *lru.find(ResidentKey::tile(in_.cut.patches[i].tile));
    item.morphTileSlot = *lru.find(ResidentKey::tile(in_.cut.patches[i].morphTile));
    item.recordIndex = static_cast<std::uint32_t>(i);
    item.indexCount = 3 * in_.nodes[i].triangleCount;
    patchSlotCount = std::max(patchSlotCount, item.patchSlot + 1);
    tileSlotCount = std::max({tileSlotCount, item.tileSlot + 1, item.morphTileSlot + 1});
    work_.draws.push_back(item);
  }
  slot_.lastPassEntries.clear();
  for (const DecodeJob& entry : entries) {
    slot_.lastPassEntries.emplace_back(entry.key, *lru.find(entry.key));
  }
  if (Result<void> r = m_.shared->patches.ensureSlots(*m_.context, patchSlotCount); !r) return r;
  return m_.shared->tiles.ensureSlots(*m_.context, tileSlotCount);
}

Result<void> PassDrawer::stage() {
  // Staging layout, then decoding straight into it on TBB workers.
  const std::uint64_t stagingBytes = m_.decoder->layout(work_.misses);
  if (Result<void> r = slot_.uploader.ensure(*m_.context, stagingBytes, m_.garbage, m_.submitted);
      !r) {
    return r;
  }
  const auto decodeStart = Clock::now();
  Result<void> decoded = m_.decoder->decode(work_.misses, slot_.uploader.mappedBytes());
  stats_.decodeMs += millisecondsSince(decodeStart);
  if (!decoded) return decoded;

  // Per-draw records, with each patch's tile layer.
  const std::span<std::byte> recordBytes = slot_.records.mappedBytes();
  for (const DrawItem& item : work_.draws) {
    PatchDrawInput input;
    input.node = in_.cut.patches[item.recordIndex].node;
    input.record = in_.nodes[item.recordIndex];
    input.textureLayer = m_.shared->tiles.locate(item.tileSlot).local;
    const CutPatch& patch = in_.cut.patches[item.recordIndex];
    input.morph = patch.morph;
    if (patch.blendsTile()) {
      input.morphTile = patch.morphTile;
      input.morphTextureLayer = m_.shared->tiles.locate(item.morphTileSlot).local;
    }
    const PatchDrawRecord record =
        makePatchDrawRecord(*m_.dataset, input, in_.camera.position(), m_.shared->exaggeration);
    std::memcpy(recordBytes.data() + std::size_t{item.recordIndex} * sizeof(PatchDrawRecord),
                &record, sizeof record);
  }
  if (Result<void> r = slot_.uploader.flush(); !r) return r;
  return slot_.records.flushHostWrites();
}

Result<void> PassDrawer::recordUploads() {
  // Timestamps: 0 and 3 around the uploads, 1 and 2 around the render pass (record()).
  VkQueryPool timestamps = m_.queries.get();
  const std::uint32_t q = slot_.firstQuery;
  return recordCommands(
      slot_.commands[FrameSlot::kUploadCommands], "terrain uploads", [&](VkCommandBuffer cmd) {
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdResetQueryPool(cmd, timestamps, q, 1);
          vkCmdResetQueryPool(cmd, timestamps, q + 3, 1);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q);
        }
        if (!work_.misses.empty()) {
          slot_.uploader.record(cmd, work_.misses, work_.missSlots, m_.shared->patches,
                                m_.shared->tiles);
        }
        // With the atmosphere, the frame's sky-view table before its first pass draws.
        if (in_.placement.first) {
          PatchPush push{};
          std::memcpy(&push, in_.push.data(), std::min(in_.push.size(), sizeof push));
          m_.atmosphere->recordSkyView(cmd, push);
        }
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 3);
        }
      });
}

Result<void> PassDrawer::record(bool readback, const PresentTarget* present) {
  Result<void> recorded = recordUploads();
  if (!recorded) return recorded;
  // The draw buffer resets its own two queries, so that redrawLast() can submit it alone.
  VkQueryPool timestamps = m_.queries.get();
  const std::uint32_t q = slot_.firstQuery;
  const DrawRecorder recorder(m_.shared->pipeline, m_.shared->patches, m_.shared->tiles,
                              slot_.recordsSet, slot_.overlay->set(), m_.atmosphere->set(),
                              m_.radiancePipelines ? &*m_.radiancePipelines : nullptr);
  const bool radiance =
      in_.placement.last && readback && in_.placement.toneMapExposure > 0.0f && in_.readRadiance;
  recorded = recordCommands(
      slot_.commands[FrameSlot::kDrawCommands], "terrain frame", [&](VkCommandBuffer cmd) {
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdResetQueryPool(cmd, timestamps, q + 1, 2);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 1);
        }
        recorder.record(cmd, slot_.target, in_.placement, in_.push, work_.draws);
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 2);
        }
        if (in_.placement.last && readback) slot_.target.recordReadback(cmd);
        if (radiance) slot_.target.recordRadianceReadback(cmd);
      });
  if (!recorded || !in_.placement.last || present == nullptr) return recorded;
  return recordCommands(
      slot_.commands[FrameSlot::kPresentCommands], "terrain present",
      [&](VkCommandBuffer cmd) { slot_.target.recordPresent(cmd, *present, readback); });
}

Result<void> PassDrawer::submit(CacheLease& lease, const PresentTarget* present) {
  const bool wait = !in_.placement.last;
  // The window's copy goes with the frame's last pass.
  const PresentTarget* shown = in_.placement.last ? present : nullptr;
  const std::span<const VkCommandBuffer> all(slot_.commands.data(), shown ? 3 : 2);
  if (m_.privateCache) {
    // Nobody else uses the cache: uploads and draw go in one submission, and later frames
    // (on the same queue, after the uploads' barriers) may use its entries at once.
    if (Result<void> r = m_.submitSlot(slot_, all, shown, "terrain frame", wait); !r) {
      return r;
    }
    lease.commitUploads();
    if (!wait) slot_.pins = lease.keepPins();
    return {};
  }
  // Uploads under the lock; once they have completed the entries are usable by every
  // renderer of the cache, and the draw runs outside the lock with its entries pinned.
  const std::array<VkCommandBuffer, 1> uploads = {slot_.commands[FrameSlot::kUploadCommands]};
  if (Result<void> r = m_.submitSlot(slot_, uploads, nullptr, "terrain uploads", true); !r) {
    return r;
  }
  lease.commitUploads();
  lease.unlock();
  const std::span<const VkCommandBuffer> draw(slot_.commands.data() + FrameSlot::kDrawCommands,
                                              shown ? 2 : 1);
  Result<void> drawn = m_.submitSlot(slot_, draw, shown, "terrain frame", wait);
  lease.lock();
  if (drawn && !wait) slot_.pins = lease.keepPins();
  return drawn;
}

}  // namespace pbdam::gpu
