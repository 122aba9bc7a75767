// TerrainRenderer: exact-mode frames of a P-BDAM cut (TerrainRenderer.h; [P-BDAM 2003] §4.2, §4.4).
//
// A frame is planned as one or more passes over consecutive ranges of the cut (one pass unless
// the cut's slot bytes exceed the budget). Per pass: a CacheLease reserves the pass's entries in
// the cache (hits pinned, misses given slots, evicting entries of earlier passes), the
// DecodeScheduler (streaming/) decodes the misses in parallel into the StagingUploader's buffer,
// and one submission copies them into the pools and draws the pass's patches in cut order
// (DrawRecorder), one indexed draw each. The submission holds two of the renderer's own
// (reusable) command buffers, uploads then the render pass, so that redrawLast() can submit a
// one-pass frame's render pass again without recording anything. Buffers the renderer replaces
// go to its DeferredDestruction and are destroyed once the submissions that used them are done.
#include "pbdam/gpu/TerrainRenderer.h"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <unordered_set>
#include <vector>

#include "CacheLease.h"
#include "DeferredDestruction.h"
#include "DeviceDrawList.h"
#include "DrawRecorder.h"
#include "GpuCacheState.h"
#include "StagingUploader.h"
#include "SurfaceOverlayBinding.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/streaming/DecodeScheduler.h"
#include "pbdam/streaming/ResidencyLru.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

using namespace pbdam::streaming;

namespace pbdam::gpu {
namespace {

using Clock = std::chrono::steady_clock;

/// How long a submission may take before it is reported as a device error.
constexpr std::uint64_t kSubmitTimeoutNanoseconds = 60'000'000'000ull;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string mebibytes(std::uint64_t bytes) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return text;
}

/// Records `cmd` again (it was allocated from a pool that allows resetting single buffers, so
/// beginning resets it): reusable, not one-time-submit.
template <typename Record>
Result<void> recordCommands(VkCommandBuffer cmd, const char* what, const Record& record) {
  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  if (VkResult r = vkBeginCommandBuffer(cmd, &begin); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkBeginCommandBuffer (") + what + ")");
  }
  record(cmd);
  if (VkResult r = vkEndCommandBuffer(cmd); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkEndCommandBuffer (") + what + ")");
  }
  return {};
}

/// Points a records set (binding 0 of the patch pipeline's set 0) at `buffer`.
void bindRecords(VkDevice device, VkDescriptorSet set, VkBuffer buffer) {
  VkDescriptorBufferInfo info{};
  info.buffer = buffer;
  info.offset = 0;
  info.range = VK_WHOLE_SIZE;
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = set;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.pBufferInfo = &info;
  vkUpdateDescriptorSets(device, 1, &write, 0, nullptr);
}

/// One pass of a frame: the cut's range [begin, end) and how it sits in the frame.
struct PassInput {
  const Cut& cut;
  const std::vector<NodeRecord>& nodes;
  std::size_t begin = 0;
  std::size_t end = 0;
  const Camera& camera;
  std::span<const std::byte> push;  ///< the PatchPush bytes
  PassPlacement placement;
};

/// What a reserved pass uploads and draws.
struct PassWork {
  std::vector<DecodeJob> misses;
  std::vector<std::uint32_t> missSlots;  ///< pool slot of each miss
  std::vector<DrawItem> draws;           ///< the pass's drawable patches in cut order
};

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

struct TerrainRenderer::Impl {
  VulkanContext* context = nullptr;
  const DatasetView* dataset = nullptr;
  TerrainRendererOptions options;
  /// The cache this renderer draws from: its own (privateCache) or one shared with other
  /// renderers (GpuCache.h). `cache` keeps it alive; `shared` is its state.
  std::shared_ptr<GpuCache> cache;
  GpuCache::State* shared = nullptr;
  bool privateCache = true;
  std::optional<DecodeScheduler> decoder;

  OffscreenTarget target;
  StagingUploader uploader;
  GpuBuffer records;
  UniqueDescriptorPool recordsPool;
  VkDescriptorSet recordsSet = VK_NULL_HANDLE;
  std::optional<SurfaceOverlayBinding> overlay;
  UniqueQueryPool queries;
  std::uint64_t timestampMask = 0;
  double timestampPeriodNs = 1.0;
  bool warned = false;

  /// The renderer's command buffers, re-recorded per pass: [kUploadCommands] the timestamps
  /// and uploads, [kDrawCommands] the render pass (and the readback of a frame's last pass).
  /// They are not one-time-submit, so that redrawLast() can submit the draw again.
  static constexpr std::size_t kUploadCommands = 0;
  static constexpr std::size_t kDrawCommands = 1;
  UniqueCommandPool commandPool;
  std::array<VkCommandBuffer, 2> commands{};
  UniqueFence fence;
  /// Submissions on `fence` are numbered 1, 2, …: `submitted` is the latest made, `completed`
  /// the latest known to have signalled. `garbage` holds replaced objects until then.
  std::uint64_t submitted = 0;
  std::uint64_t completed = 0;
  DeferredDestruction garbage;
  /// The stats of the last render() call when it succeeded (commands[kDrawCommands] then holds
  /// its last pass); unset before the first frame and after a failed one.
  std::optional<FrameStats> lastFrame;
  /// The entries the last pass drew and their slots: redrawLast() pins them again, and refuses
  /// if another renderer of a shared cache has evicted one since.
  std::vector<std::pair<ResidentKey, std::uint32_t>> lastPassEntries;
  /// renderSelected()'s draw list made on the device, the selector it reads and the records
  /// set of its records. It records where every patch and tile is in the cache, so render()
  /// drops it when it evicts anything.
  std::optional<DeviceDrawList> deviceList;
  const GpuSelector* deviceListSelector = nullptr;
  VkDescriptorSet deviceRecordsSet = VK_NULL_HANDLE;

  /// Timestamp queries: 0 and 3 around the uploads, 1 and 2 around the render pass.
  static constexpr std::uint32_t kTimestampQueries = 4;

  Result<void> ensureRecords(std::size_t count);
  /// Submits `buffers` (already recorded) in one batch and waits for them; then destroys what
  /// was retired for them.
  Result<void> submitAndWait(std::span<const VkCommandBuffer> buffers, const char* what);
  /// Reads the draw timestamps (1, 2) and, with `withUploads`, the upload timestamps (0, 3)
  /// of the last pass into `stats`.
  void readTimestamps(bool withUploads, FrameStats& stats) const;
  /// Creates the records descriptor set, command pool and buffers, fence and timestamp queries.
  Result<void> createFrameObjects();

  Result<void> drawPass(const PassInput& in, FrameStats& stats);
  Result<void> reservePass(CacheLease& lease, const PassInput& in,
                           const std::vector<DecodeJob>& entries, PassWork& work,
                           FrameStats& stats);
  Result<void> stagePass(const PassInput& in, PassWork& work, FrameStats& stats);
  Result<void> recordPass(const PassInput& in, const PassWork& work);
  Result<void> submitPass(CacheLease& lease);
  /// The camera's viewport must be the renderer's size.
  Result<void> checkViewport(const Camera& camera) const;
  /// After every patch and tile has been made resident: the device draw list over `selector`'s
  /// nodes, and its records set.
  Result<void> makeDeviceList(const GpuSelector& selector, bool readableRecords);
  /// Records renderSelected()'s frame: selection, draw list, indirect draw, readback.
  Result<void> recordSelectedFrame(GpuSelector& selector, const Camera& camera,
                                   const SelectionOptions& selection,
                                   const FrameSettings& settings);
};

Result<void> TerrainRenderer::Impl::ensureRecords(std::size_t count) {
  const std::uint64_t bytes =
      std::uint64_t{sizeof(PatchDrawRecord)} * std::max<std::size_t>(1, count);
  if (records && records.sizeBytes() >= bytes) return {};
  const std::uint64_t size = std::max<std::uint64_t>(
      bytes, records ? 2 * records.sizeBytes() : sizeof(PatchDrawRecord) * std::uint64_t{1024});
  // The recorded draw of the previous frame reads the old buffer: it lives until that is done.
  garbage.retire(std::move(records), submitted);
  records = GpuBuffer();
  auto buffer = createBuffer(*context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             MemoryUse::HostUpload, "patch draw records");
  if (!buffer) return std::move(buffer).error();
  records = std::move(*buffer);
  bindRecords(context->device(), recordsSet, records.buffer());
  return {};
}

Result<void> TerrainRenderer::Impl::submitAndWait(std::span<const VkCommandBuffer> buffers,
                                                  const char* what) {
  VkDevice device = context->device();
  VkFence submitFence = fence.get();
  if (VkResult r = vkResetFences(device, 1, &submitFence); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkResetFences (") + what + ")");
  }
  std::array<VkCommandBufferSubmitInfo, 2> infos{};
  assert(buffers.size() <= infos.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i].sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
    infos[i].commandBuffer = buffers[i];
  }
  VkSubmitInfo2 submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  submit.commandBufferInfoCount = static_cast<std::uint32_t>(buffers.size());
  submit.pCommandBufferInfos = infos.data();
  // Through the context: its queue lock lets several renderers share it (pbdam serve).
  if (Result<void> r = context->submit(submit, submitFence, what); !r) return r;
  ++submitted;
  const auto done = [&] {
    completed = submitted;
    garbage.collect(completed);
  };
  if (VkResult r = vkWaitForFences(device, 1, &submitFence, VK_TRUE, kSubmitTimeoutNanoseconds);
      r != VK_SUCCESS) {
    // The work may still be running: wait it out so that re-recording the buffers is legal.
    if (context->waitIdle()) done();
    return vulkanError(r, std::string("vkWaitForFences (") + what + ")");
  }
  done();
  return {};
}

void TerrainRenderer::Impl::readTimestamps(bool withUploads, FrameStats& stats) const {
  if (!queries) return;
  std::array<std::uint64_t, kTimestampQueries> ticks{};
  const std::uint32_t first = withUploads ? 0 : 1;
  const std::uint32_t count = withUploads ? kTimestampQueries : 2;
  if (vkGetQueryPoolResults(context->device(), queries.get(), first, count,
                            sizeof(std::uint64_t) * count, ticks.data() + first,
                            sizeof(std::uint64_t),
                            VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) != VK_SUCCESS) {
    return;
  }
  const auto ms = [&](std::uint64_t a, std::uint64_t b) {
    return static_cast<double>((b - a) & timestampMask) * timestampPeriodNs * 1e-6;
  };
  if (withUploads) stats.uploadMs += ms(ticks[0], ticks[3]);
  stats.drawMs += ms(ticks[1], ticks[2]);
}

Result<void> TerrainRenderer::Impl::drawPass(const PassInput& in, FrameStats& stats) {
  const std::vector<DecodeJob> entries = passEntries(in);
  PassWork work;
  {
    // Under the cache lock from here through the uploads: nothing another renderer does can
    // evict what this pass pins, and nobody sees an entry before its upload has completed.
    // The lease hands the pass's pins (and failed uploads) back on every path.
    CacheLease lease(*shared);
    if (Result<void> r = reservePass(lease, in, entries, work, stats); !r) return r;
    if (Result<void> r = stagePass(in, work, stats); !r) return r;
    if (Result<void> r = recordPass(in, work); !r) return r;
    if (Result<void> r = submitPass(lease); !r) return r;
  }
  readTimestamps(true, stats);
  stats.misses += work.misses.size();
  for (const DecodeJob& job : work.misses) stats.bytesUploaded += job.bytes;
  return {};
}

Result<void> TerrainRenderer::Impl::reservePass(CacheLease& lease, const PassInput& in,
                                                const std::vector<DecodeJob>& entries,
                                                PassWork& work, FrameStats& stats) {
  std::vector<ResidentKey> keys;
  keys.reserve(entries.size());
  for (const DecodeJob& entry : entries) keys.push_back(entry.key);
  std::vector<std::size_t> missIndices;
  LeaseCounters counters;
  counters.peakResidentBytes = stats.peakResidentBytes;
  if (Result<void> r = lease.reserve(keys, missIndices, work.missSlots, counters); !r) return r;
  stats.hits += counters.hits;
  stats.evictions += counters.evictions;
  stats.peakResidentBytes = counters.peakResidentBytes;
  for (const std::size_t i : missIndices) work.misses.push_back(entries[i]);

  // Patch and tile slots of the whole pass; pools grow to cover them.
  const ResidencyLru& lru = lease.lru();
  std::uint32_t patchSlotCount = 0, tileSlotCount = 0;
  for (std::size_t i = in.begin; i < in.end; ++i) {
    if (!drawable(in.nodes[i])) continue;
    DrawItem item;
    item.patchSlot = *lru.find(ResidentKey::patch(in.cut.patches[i].node));
    item.tileSlot = *lru.find(ResidentKey::tile(in.cut.patches[i].tile));
    item.morphTileSlot = *lru.find(ResidentKey::tile(in.cut.patches[i].morphTile));
    item.recordIndex = static_cast<std::uint32_t>(i);
    item.indexCount = 3 * in.nodes[i].triangleCount;
    patchSlotCount = std::max(patchSlotCount, item.patchSlot + 1);
    tileSlotCount = std::max({tileSlotCount, item.tileSlot + 1, item.morphTileSlot + 1});
    work.draws.push_back(item);
  }
  lastPassEntries.clear();
  for (const DecodeJob& entry : entries) {
    lastPassEntries.emplace_back(entry.key, *lru.find(entry.key));
  }
  if (Result<void> r = shared->patches.ensureSlots(*context, patchSlotCount); !r) return r;
  return shared->tiles.ensureSlots(*context, tileSlotCount);
}

Result<void> TerrainRenderer::Impl::stagePass(const PassInput& in, PassWork& work,
                                              FrameStats& stats) {
  // Staging layout, then decoding straight into it on TBB workers.
  const std::uint64_t stagingBytes = decoder->layout(work.misses);
  if (Result<void> r = uploader.ensure(*context, stagingBytes, garbage, submitted); !r) return r;
  const auto decodeStart = Clock::now();
  Result<void> decoded = decoder->decode(work.misses, uploader.mappedBytes());
  stats.decodeMs += millisecondsSince(decodeStart);
  if (!decoded) return decoded;

  // Per-draw records, with each patch's tile layer.
  const std::span<std::byte> recordBytes = records.mappedBytes();
  for (const DrawItem& item : work.draws) {
    PatchDrawInput input;
    input.node = in.cut.patches[item.recordIndex].node;
    input.record = in.nodes[item.recordIndex];
    input.textureLayer = shared->tiles.locate(item.tileSlot).local;
    const CutPatch& patch = in.cut.patches[item.recordIndex];
    input.morph = patch.morph;
    if (patch.blendsTile()) {
      input.morphTile = patch.morphTile;
      input.morphTextureLayer = shared->tiles.locate(item.morphTileSlot).local;
    }
    const PatchDrawRecord record = makePatchDrawRecord(*dataset, input, in.camera.position());
    std::memcpy(recordBytes.data() + std::size_t{item.recordIndex} * sizeof(PatchDrawRecord),
                &record, sizeof record);
  }
  if (Result<void> r = uploader.flush(); !r) return r;
  return records.flushHostWrites();
}

Result<void> TerrainRenderer::Impl::recordPass(const PassInput& in, const PassWork& work) {
  // Timestamps: 0 and 3 around the uploads, 1 and 2 around the render pass. The draw buffer
  // resets its own two queries, so that redrawLast() can submit it alone.
  VkQueryPool timestamps = queries.get();
  Result<void> recorded =
      recordCommands(commands[kUploadCommands], "terrain uploads", [&](VkCommandBuffer cmd) {
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdResetQueryPool(cmd, timestamps, 0, 1);
          vkCmdResetQueryPool(cmd, timestamps, 3, 1);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 0);
        }
        if (!work.misses.empty()) {
          uploader.record(cmd, work.misses, work.missSlots, shared->patches, shared->tiles);
        }
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 3);
        }
      });
  if (!recorded) return recorded;
  const DrawRecorder recorder(shared->pipeline, shared->patches, shared->tiles, recordsSet,
                              overlay->set());
  return recordCommands(commands[kDrawCommands], "terrain frame", [&](VkCommandBuffer cmd) {
    if (timestamps != VK_NULL_HANDLE) {
      vkCmdResetQueryPool(cmd, timestamps, 1, 2);
      vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 1);
    }
    recorder.record(cmd, target, in.placement, in.push, work.draws);
    if (timestamps != VK_NULL_HANDLE) {
      vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 2);
    }
    if (in.placement.last) target.recordReadback(cmd);
  });
}

Result<void> TerrainRenderer::Impl::submitPass(CacheLease& lease) {
  if (privateCache) {
    // Nobody else uses the cache: uploads and draw go in one submission.
    if (Result<void> r = submitAndWait(commands, "terrain frame"); !r) return r;
    lease.commitUploads();
    return {};
  }
  // Uploads under the lock; once they have completed the entries are usable by every
  // renderer of the cache, and the draw runs outside the lock with its entries pinned.
  const std::array<VkCommandBuffer, 1> uploads = {commands[kUploadCommands]};
  if (Result<void> r = submitAndWait(uploads, "terrain uploads"); !r) return r;
  lease.commitUploads();
  lease.unlock();
  const std::array<VkCommandBuffer, 1> draw = {commands[kDrawCommands]};
  Result<void> drawn = submitAndWait(draw, "terrain frame");
  lease.lock();
  return drawn;
}

Result<void> TerrainRenderer::Impl::createFrameObjects() {
  VkDescriptorPoolSize size{};
  size.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  size.descriptorCount = 2;  // the host's records, and renderSelected()'s made on the device
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 2;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(context->device(), &poolInfo, nullptr, &rawPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (patch draw records)");
  }
  recordsPool = UniqueDescriptorPool(context->device(), rawPool);
  VkDescriptorSetLayout recordsLayout = shared->pipeline.recordsSetLayout();
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &recordsLayout;
  if (VkResult r = vkAllocateDescriptorSets(context->device(), &allocate, &recordsSet);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (patch draw records)");
  }
  if (Result<void> r = ensureRecords(1024); !r) return r;
  auto overlayBinding = SurfaceOverlayBinding::create(*context, shared->pipeline);
  if (!overlayBinding) return std::move(overlayBinding).error();
  overlay.emplace(std::move(*overlayBinding));

  VkCommandPoolCreateInfo commandPoolInfo{};
  commandPoolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  commandPoolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  commandPoolInfo.queueFamilyIndex = context->queueFamilyIndex();
  VkCommandPool rawCommandPool = VK_NULL_HANDLE;
  if (VkResult r =
          vkCreateCommandPool(context->device(), &commandPoolInfo, nullptr, &rawCommandPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateCommandPool (terrain frames)");
  }
  commandPool = UniqueCommandPool(context->device(), rawCommandPool);
  VkCommandBufferAllocateInfo commandsInfo{};
  commandsInfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  commandsInfo.commandPool = rawCommandPool;
  commandsInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  commandsInfo.commandBufferCount = static_cast<std::uint32_t>(commands.size());
  if (VkResult r = vkAllocateCommandBuffers(context->device(), &commandsInfo, commands.data());
      r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateCommandBuffers (terrain frames)");
  }
  VkFenceCreateInfo fenceInfo{};
  fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence rawFence = VK_NULL_HANDLE;
  if (VkResult r = vkCreateFence(context->device(), &fenceInfo, nullptr, &rawFence);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateFence (terrain frames)");
  }
  fence = UniqueFence(context->device(), rawFence);

  // GPU timestamps for the upload/draw split, where the queue has them.
  std::uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(context->physicalDevice(), &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(context->physicalDevice(), &familyCount,
                                           families.data());
  const std::uint32_t validBits = families[context->queueFamilyIndex()].timestampValidBits;
  if (validBits > 0) {
    VkQueryPoolCreateInfo queryInfo{};
    queryInfo.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
    queryInfo.queryCount = kTimestampQueries;
    VkQueryPool rawQueries = VK_NULL_HANDLE;
    if (VkResult r = vkCreateQueryPool(context->device(), &queryInfo, nullptr, &rawQueries);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateQueryPool (frame timestamps)");
    }
    queries = UniqueQueryPool(context->device(), rawQueries);
    timestampMask = validBits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << validBits) - 1;
    timestampPeriodNs = static_cast<double>(context->caps().timestampPeriodNanoseconds);
  }
  return {};
}

Result<TerrainRenderer> TerrainRenderer::create(VulkanContext& context, const DatasetView& dataset,
                                                const TerrainRendererOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->context = &context;
  impl->dataset = &dataset;
  impl->options = options;
  if (options.sharedCache) {
    GpuCache::State& state = options.sharedCache->state();
    if (state.context != &context || state.dataset != &dataset) {
      return makeError(ErrorCode::InvalidArgument,
                       "the shared GPU cache was made for another Vulkan context or dataset");
    }
    impl->cache = options.sharedCache;
    impl->privateCache = false;
  } else {
    GpuCacheOptions cacheOptions;
    cacheOptions.budgetBytes = options.gpuCacheBytes;
    cacheOptions.forceRgba8Textures = options.forceRgba8Textures;
    cacheOptions.chunkBytes = options.poolChunkBytes;
    auto cache = GpuCache::create(context, dataset, cacheOptions);
    if (!cache) return std::move(cache).error();
    impl->cache = std::move(*cache);
  }
  impl->shared = &impl->cache->state();
  // The renderer does not keep the cache options: the cache has them.
  impl->options.sharedCache.reset();

  auto target = OffscreenTarget::create(context, options.widthPixels, options.heightPixels);
  if (!target) return std::move(target).error();
  impl->target = std::move(*target);

  impl->decoder.emplace(dataset, impl->shared->texture.texels);
  if (Result<void> r = impl->createFrameObjects(); !r) return std::move(r).error();
  return TerrainRenderer(std::move(impl));
}

std::uint64_t TerrainRenderer::minimumCacheBytes(const VulkanContext& context,
                                                 const DatasetView& dataset,
                                                 bool forceRgba8Textures) {
  return GpuCache::minimumBytes(context, dataset, forceRgba8Textures);
}

glm::dvec3 TerrainRenderer::defaultSunDirection(const Camera& camera) {
  const glm::dvec3 above = glm::normalize(camera.position());
  return glm::normalize(above + 0.5 * camera.up() + 0.4 * camera.right() - 0.3 * camera.forward());
}

TerrainRenderer::TerrainRenderer(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
TerrainRenderer::TerrainRenderer(TerrainRenderer&&) noexcept = default;
TerrainRenderer& TerrainRenderer::operator=(TerrainRenderer&&) noexcept = default;
TerrainRenderer::~TerrainRenderer() = default;

std::uint64_t TerrainRenderer::residentBytes() const {
  const std::lock_guard<std::mutex> lock(impl_->shared->mutex);
  return impl_->shared->lru->residentBytes();
}

bool TerrainRenderer::usesBc1Textures() const noexcept { return impl_->cache->usesBc1Textures(); }

const std::shared_ptr<GpuCache>& TerrainRenderer::cache() const noexcept { return impl_->cache; }

namespace {

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

/// The push constants of a frame: view-projection, sun direction and ambient.
PatchPush patchPush(const Camera& camera, const FrameSettings& settings) {
  PatchPush push{};
  const glm::mat4 viewProjection = camera.projection() * camera.viewRotation();
  std::memcpy(push.viewProjection, glm::value_ptr(viewProjection), sizeof push.viewProjection);
  const glm::dvec3 sun =
      glm::normalize(settings.sunDirectionEcef ? *settings.sunDirectionEcef
                                               : TerrainRenderer::defaultSunDirection(camera));
  push.sunAmbient[0] = static_cast<float>(sun.x);
  push.sunAmbient[1] = static_cast<float>(sun.y);
  push.sunAmbient[2] = static_cast<float>(sun.z);
  push.sunAmbient[3] = std::clamp(settings.ambient, 0.0f, 1.0f);
  return push;
}

}  // namespace

Result<RenderedFrame> TerrainRenderer::render(const Cut& cut, const Camera& camera,
                                              const FrameSettings& settings) {
  Impl& m = *impl_;
  const auto frameStart = Clock::now();
  m.lastFrame.reset();
  if (Result<void> r = m.checkViewport(camera); !r) return std::move(r).error();
  FrameStats stats;
  stats.patches = cut.patches.size();
  stats.triangles = cut.triangles;
  stats.tiles = cut.tiles.size();
  GpuCache::State& c = *m.shared;
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    stats.peakResidentBytes = c.lru->residentBytes();
  }

  std::vector<NodeRecord> nodes(cut.patches.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) nodes[i] = m.dataset->node(cut.patches[i].node);
  const std::vector<std::size_t> passEnds = planPasses(c, cut, nodes);
  stats.passes = static_cast<std::uint32_t>(passEnds.size());
  stats.budgetExceeded = passEnds.size() > 1;
  if (stats.budgetExceeded && m.options.warnWhenBudgetExceeded && !m.warned) {
    m.warned = true;
    std::fprintf(stderr,
                 "pbdam: warning: a frame's cut (%zu patches, %zu tiles) does not fit the GPU "
                 "cache budget of %s; drawing it in %zu passes (same image, slower); raise the "
                 "budget (--gpu-cache-mib) to avoid this\n",
                 cut.patches.size(), cut.tiles.size(), mebibytes(c.lru->budgetBytes()).c_str(),
                 passEnds.size());
  }
  if (Result<void> r = m.ensureRecords(cut.patches.size()); !r) return std::move(r).error();
  if (Result<void> r = m.overlay->prepare(settings.overlay, m.dataset->planet(), camera.position());
      !r) {
    return std::move(r).error();
  }

  const PatchPush push = patchPush(camera, settings);
  const std::array<float, 4> clear = {static_cast<float>(settings.clearRgb[0]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[1]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[2]) / 255.0f, 1.0f};
  std::size_t begin = 0;
  for (std::size_t p = 0; p < passEnds.size(); ++p) {
    const PassInput pass{cut,
                         nodes,
                         begin,
                         passEnds[p],
                         camera,
                         std::as_bytes(std::span(&push, 1)),
                         {p == 0, p + 1 == passEnds.size(), clear}};
    if (Result<void> r = m.drawPass(pass, stats); !r) return std::move(r).error();
    begin = passEnds[p];
  }
  if (stats.evictions > 0) m.deviceList.reset();  // it knew where the evicted entries were
  Result<RgbaImage> image = m.target.readPixels();
  if (!image) return std::move(image).error();
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    stats.residentBytes = c.lru->residentBytes();
    stats.poolBytes = c.patches.allocatedBytes() + c.tiles.allocatedBytes();
  }
  stats.frameMs = millisecondsSince(frameStart);
  m.lastFrame = stats;
  return RenderedFrame{std::move(*image), stats};
}

Result<void> TerrainRenderer::Impl::checkViewport(const Camera& camera) const {
  if (camera.viewport().width == options.widthPixels &&
      camera.viewport().height == options.heightPixels) {
    return {};
  }
  return makeError(ErrorCode::InvalidArgument,
                   "camera viewport " + std::to_string(camera.viewport().width) + "x" +
                       std::to_string(camera.viewport().height) + " differs from the renderer's " +
                       std::to_string(options.widthPixels) + "x" +
                       std::to_string(options.heightPixels));
}

Result<void> TerrainRenderer::Impl::makeDeviceList(const GpuSelector& selector,
                                                   bool readableRecords) {
  const DiamondIndex& index = selector.index();
  std::vector<ResidentDraw> residency(index.nodes.size());
  {
    const std::lock_guard<std::mutex> lock(shared->mutex);
    const ResidencyLru& lru = *shared->lru;
    const auto tileLayer = [&](const TileKey& tile) -> Result<std::uint32_t> {
      const std::optional<std::uint32_t> slot = lru.find(ResidentKey::tile(tile));
      if (!slot) return makeError(ErrorCode::InvalidArgument, "a tile is not resident");
      const PoolLocation at = shared->tiles.locate(*slot);
      if (at.chunk != 0) {
        return makeError(ErrorCode::InvalidArgument,
                         "the tiles do not fit one texture page (raise the pool chunk bytes)");
      }
      return at.local;
    };
    for (std::size_t i = 0; i < index.nodes.size(); ++i) {
      const DiamondIndex::Node& place = index.nodes[i];
      const NodeRecord record = dataset->node(place.key);
      if (!drawable(record)) continue;
      const std::optional<std::uint32_t> slot = lru.find(ResidentKey::patch(place.key));
      if (!slot) return makeError(ErrorCode::InvalidArgument, "a patch is not resident");
      const PoolLocation at = shared->patches.locate(*slot);
      if (at.chunk != 0) {
        return makeError(ErrorCode::InvalidArgument,
                         "the patches do not fit one pool chunk (raise the pool chunk bytes)");
      }
      ResidentDraw& where = residency[i];
      where.indexCount = 3 * record.triangleCount;
      where.firstIndex = shared->patches.firstIndex(at.local);
      where.vertexOffset = shared->patches.firstVertex(at.local);
      const TileKey tile = dataset->tileOf(place.key);
      auto layer = tileLayer(tile);
      if (!layer) return std::move(layer).error();
      where.textureLayer = *layer;
      if (place.level > 0) {
        const TileKey parentTile = dataset->tileOf(index.nodes[place.parent].key);
        if (!(parentTile == tile)) {
          auto parentLayer = tileLayer(parentTile);
          if (!parentLayer) return std::move(parentLayer).error();
          where.parentTile = parentTile;
          where.parentTextureLayer = *parentLayer;
        }
      }
    }
  }
  auto list = DeviceDrawList::create(*context, *dataset, selector, residency, readableRecords);
  if (!list) return std::move(list).error();
  deviceList.emplace(std::move(*list));
  deviceListSelector = &selector;
  if (deviceRecordsSet == VK_NULL_HANDLE) {
    VkDescriptorSetLayout recordsLayout = shared->pipeline.recordsSetLayout();
    VkDescriptorSetAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    allocate.descriptorPool = recordsPool.get();
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &recordsLayout;
    if (VkResult r = vkAllocateDescriptorSets(context->device(), &allocate, &deviceRecordsSet);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkAllocateDescriptorSets (device draw records)");
    }
  }
  bindRecords(context->device(), deviceRecordsSet, deviceList->records().buffer());
  return {};
}

Result<void> TerrainRenderer::Impl::recordSelectedFrame(GpuSelector& selector, const Camera& camera,
                                                        const SelectionOptions& selection,
                                                        const FrameSettings& settings) {
  const PatchPush push = patchPush(camera, settings);
  const std::array<float, 4> clear = {static_cast<float>(settings.clearRgb[0]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[1]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[2]) / 255.0f, 1.0f};
  VkQueryPool timestamps = queries.get();
  Result<void> inner;
  Result<void> recorded =
      recordCommands(commands[kDrawCommands], "selected terrain frame", [&](VkCommandBuffer cmd) {
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdResetQueryPool(cmd, timestamps, 0, kTimestampQueries);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 0);
        }
        inner = selector.recordSelection(cmd, camera, selection);
        if (inner) inner = deviceList->record(cmd, camera, selection.refinement);
        if (!inner) return;
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 3);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 1);
        }
        target.recordBeginRendering(cmd, clear, OffscreenTarget::kFarDepth, false);
        const PatchPipeline& pipeline = shared->pipeline;
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.indirectPipeline());
        VkDescriptorSet page = shared->tiles.descriptorSet(0);
        const std::array<VkDescriptorSet, 4> sets = {deviceRecordsSet, page, page, overlay->set()};
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 0,
                                static_cast<std::uint32_t>(sets.size()), sets.data(), 0, nullptr);
        vkCmdPushConstants(cmd, pipeline.layout(),
                           VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                           sizeof push, &push);
        VkBuffer vertexBuffer = shared->patches.vertexBuffer(0);
        const VkDeviceSize zero = 0;
        vkCmdBindVertexBuffers(cmd, 0, 1, &vertexBuffer, &zero);
        vkCmdBindIndexBuffer(cmd, shared->patches.indexBuffer(0), 0, VK_INDEX_TYPE_UINT16);
        vkCmdDrawIndexedIndirectCount(cmd, deviceList->commands().buffer(), 0,
                                      deviceList->count().buffer(), 0, deviceList->capacity(),
                                      sizeof(VkDrawIndexedIndirectCommand));
        vkCmdEndRendering(cmd);
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, 2);
        }
        target.recordReadback(cmd);
      });
  if (!inner) return inner;
  return recorded;
}

Result<RenderedFrame> TerrainRenderer::renderSelected(GpuSelector& selector, const Camera& camera,
                                                      const SelectionOptions& selection,
                                                      const FrameSettings& settings,
                                                      bool readableRecords) {
  Impl& m = *impl_;
  const auto frameStart = Clock::now();
  m.lastFrame.reset();
  if (Result<void> r = m.checkViewport(camera); !r) return std::move(r).error();
  if (m.shared->pipeline.indirectPipeline() == VK_NULL_HANDLE) {
    return makeError(ErrorCode::InvalidArgument,
                     "draw lists made on the device need multi-draw indirect, indirect draw "
                     "counts and shader draw parameters; the Vulkan device lacks one of them");
  }
  if (!m.privateCache) {
    return makeError(ErrorCode::InvalidArgument,
                     "draw lists made on the device need the renderer's own GPU cache");
  }
  if (!m.deviceList || m.deviceListSelector != &selector) {
    // Everything the selection may draw, made resident by drawing it once.
    const DiamondIndex& index = selector.index();
    Cut all;
    std::unordered_set<std::uint64_t> seen;
    for (const DiamondIndex::Node& place : index.nodes) {
      const NodeRecord record = m.dataset->node(place.key);
      if (!drawable(record)) continue;
      CutPatch patch;
      patch.node = place.key;
      patch.level = place.level;
      patch.tile = m.dataset->tileOf(place.key);
      patch.morphTile =
          place.level > 0 ? m.dataset->tileOf(index.nodes[place.parent].key) : patch.tile;
      addCutPatch(all, patch, record.triangleCount, record.vertexCount, seen);
    }
    const std::uint64_t need =
        all.patches.size() * m.shared->patchSlot + all.tiles.size() * m.shared->texture.slotBytes;
    if (need > m.shared->lru->budgetBytes()) {
      return makeError(ErrorCode::InvalidArgument,
                       "draw lists made on the device need every patch and tile resident: " +
                           std::to_string(all.patches.size()) + " patches and " +
                           std::to_string(all.tiles.size()) + " tiles take " + mebibytes(need) +
                           ", more than the GPU cache budget of " +
                           mebibytes(m.shared->lru->budgetBytes()));
    }
    auto primed = render(all, camera, settings);
    m.lastFrame.reset();  // the draw buffer is about to hold another kind of frame
    if (!primed) return std::move(primed).error();
    if (Result<void> r = m.makeDeviceList(selector, readableRecords); !r) {
      m.deviceList.reset();
      return std::move(r).error();
    }
  }
  if (Result<void> r = m.overlay->prepare(settings.overlay, m.dataset->planet(), camera.position());
      !r) {
    return std::move(r).error();
  }
  if (Result<void> r = m.recordSelectedFrame(selector, camera, selection, settings); !r) {
    return std::move(r).error();
  }
  const std::array<VkCommandBuffer, 1> frame = {m.commands[Impl::kDrawCommands]};
  if (Result<void> r = m.submitAndWait(frame, "selected terrain frame"); !r) {
    return std::move(r).error();
  }
  FrameStats stats;
  m.readTimestamps(true, stats);
  // The selection and draw-list passes stand where render()'s uploads do.
  auto totals = m.deviceList->totals();
  if (!totals) return std::move(totals).error();
  stats.patches = totals->draws;
  stats.triangles = totals->triangles;
  stats.hits = totals->draws;
  Result<RgbaImage> image = m.target.readPixels();
  if (!image) return std::move(image).error();
  {
    const std::lock_guard<std::mutex> lock(m.shared->mutex);
    stats.residentBytes = m.shared->lru->residentBytes();
    stats.peakResidentBytes = stats.residentBytes;
    stats.poolBytes = m.shared->patches.allocatedBytes() + m.shared->tiles.allocatedBytes();
  }
  stats.frameMs = millisecondsSince(frameStart);
  return RenderedFrame{std::move(*image), stats};
}

Result<std::vector<PatchDrawRecord>> TerrainRenderer::lastSelectedRecords() const {
  if (!impl_->deviceList) {
    return makeError(ErrorCode::InvalidArgument, "no draw list made on the device");
  }
  return impl_->deviceList->readRecords();
}

Result<void> TerrainRenderer::resize(std::uint32_t widthPixels, std::uint32_t heightPixels) {
  Impl& m = *impl_;
  if (widthPixels == m.options.widthPixels && heightPixels == m.options.heightPixels) return {};
  // The recorded draw that redrawLast() would reuse refers to the old target: it is retired
  // until the renderer's submissions so far have completed.
  auto target = OffscreenTarget::create(*m.context, widthPixels, heightPixels);
  if (!target) return std::move(target).error();
  m.garbage.retire(std::move(m.target), m.submitted);
  m.garbage.collect(m.completed);
  m.target = std::move(*target);
  m.options.widthPixels = widthPixels;
  m.options.heightPixels = heightPixels;
  m.lastFrame.reset();
  return {};
}

std::uint32_t TerrainRenderer::widthPixels() const noexcept { return impl_->options.widthPixels; }
std::uint32_t TerrainRenderer::heightPixels() const noexcept { return impl_->options.heightPixels; }

Result<RenderedFrame> TerrainRenderer::redrawLast() {
  Impl& m = *impl_;
  GpuCache::State& c = *m.shared;
  const auto frameStart = Clock::now();
  if (!m.lastFrame) {
    return makeError(ErrorCode::InvalidArgument,
                     "redrawLast: there is no previous frame (render() was not called, or its "
                     "last call failed)");
  }
  const FrameStats& last = *m.lastFrame;
  if (last.passes > 1) {
    return makeError(ErrorCode::InvalidArgument,
                     "redrawLast: the previous frame was drawn in " + std::to_string(last.passes) +
                         " passes (its cut exceeds the GPU cache budget of " +
                         mebibytes(c.lru->budgetBytes()) +
                         "); only one-pass frames can be redrawn");
  }
  // The recorded draw reads the slots the frame used: they must still hold its entries.
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    for (std::size_t i = 0; i < m.lastPassEntries.size(); ++i) {
      const auto& [key, slot] = m.lastPassEntries[i];
      const std::optional<std::uint32_t> now = c.lru->find(key);
      if (!now || *now != slot) {
        for (std::size_t j = 0; j < i; ++j) c.lru->unpin(m.lastPassEntries[j].first);
        c.unpinned.notify_all();
        m.lastFrame.reset();
        return makeError(ErrorCode::InvalidArgument,
                         "redrawLast: another renderer of the shared GPU cache has evicted a "
                         "patch or tile of the previous frame since it was drawn");
      }
      c.lru->pin(key);
    }
  }
  const auto unpinLast = [&] {
    const std::lock_guard<std::mutex> lock(c.mutex);
    for (const auto& entry : m.lastPassEntries) c.lru->unpin(entry.first);
    c.unpinned.notify_all();
  };
  FrameStats stats;
  stats.patches = last.patches;
  stats.triangles = last.triangles;
  stats.tiles = last.tiles;
  stats.hits = last.hits + last.misses;
  const std::array<VkCommandBuffer, 1> draw = {m.commands[Impl::kDrawCommands]};
  Result<void> submitted = m.submitAndWait(draw, "terrain redraw");
  unpinLast();
  if (!submitted) {
    m.lastFrame.reset();
    return std::move(submitted).error();
  }
  m.readTimestamps(false, stats);
  if (stats.evictions > 0) m.deviceList.reset();  // it knew where the evicted entries were
  Result<RgbaImage> image = m.target.readPixels();
  if (!image) return std::move(image).error();
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    stats.residentBytes = c.lru->residentBytes();
    stats.poolBytes = c.patches.allocatedBytes() + c.tiles.allocatedBytes();
  }
  stats.peakResidentBytes = stats.residentBytes;
  stats.frameMs = millisecondsSince(frameStart);
  return RenderedFrame{std::move(*image), stats};
}

}  // namespace pbdam::gpu
