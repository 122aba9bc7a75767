// TerrainRenderer: exact-mode frames of a P-BDAM cut (TerrainRenderer.h; paper 004 §4.2, §4.4).
//
// A frame is planned as one or more passes over consecutive ranges of the cut (one pass unless
// the cut's slot bytes exceed the budget). Per pass: patches and tiles found in the LRU are
// touched first (hits), then misses take slots (evicting entries of earlier passes), are
// decoded in parallel into the staging buffer, and one submission copies them into the pools
// and draws the pass's patches in cut order, one indexed draw each. The submission holds two of
// the renderer's own (reusable) command buffers, uploads then the render pass, so that
// redrawLast() can submit a one-pass frame's render pass again without recording anything.
#include "pbdam/gpu/TerrainRenderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>
#include <limits>
#include <mutex>
#include <span>
#include <string>
#include <unordered_set>
#include <vector>

#include "GpuCacheState.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/ResidencyLru.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

using Clock = std::chrono::steady_clock;

/// Staging offsets are aligned for buffer-to-image copies (4 bytes and the 8-byte BC1 block).
constexpr std::uint64_t kStagingAlignment = 16;

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

std::uint64_t alignUp(std::uint64_t value, std::uint64_t alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

bool drawable(const NodeRecord& record) {
  return record.triangleCount > 0 && record.vertexCount > 0 && record.blobBytes > 0;
}

/// One miss to decode and upload.
struct UploadJob {
  ResidentKey key;
  std::uint32_t slot = 0;
  std::size_t patchIndex = 0;  ///< patches: index in the cut
  TileKey tile;                ///< tiles
  std::uint64_t stagingOffset = 0;
  std::uint64_t bytes = 0;        ///< bytes copied: vertices + indices, or texels
  std::uint64_t vertexBytes = 0;  ///< patches: the vertex part (indices follow)
};

std::string blobContext(const FaceView& face, std::uint64_t offset) {
  return face.context() + "@" + std::to_string(offset);
}

Result<void> decodePatchInto(const DatasetView& dataset, const NodeKey& key,
                             const NodeRecord& record, std::span<std::byte> out) {
  thread_local PatchMesh mesh;
  const FaceView& face = dataset.face(key.face);
  const std::string context = blobContext(face, record.blobOffset);
  if (Result<void> r = decodePatch(face.patchBlob(record), mesh, context); !r) {
    return std::move(r).error();
  }
  if (mesh.vertices.size() != record.vertexCount || mesh.triangleCount() != record.triangleCount) {
    return makeError(ErrorCode::CorruptData,
                     context + ": patch has " + std::to_string(mesh.vertices.size()) +
                         " vertices and " + std::to_string(mesh.triangleCount()) +
                         " triangles, its node record says " + std::to_string(record.vertexCount) +
                         " and " + std::to_string(record.triangleCount));
  }
  const double step = dataset.manifest().heightStepMeters;
  std::byte* dst = out.data();
  for (const PatchVertex& v : mesh.vertices) {
    const PatchGpuVertex gpu{v.b1, v.b2, vertexHeightMeters(v.heightSteps, step)};
    std::memcpy(dst, &gpu, sizeof gpu);
    dst += sizeof gpu;
  }
  std::memcpy(dst, mesh.indices.data(), mesh.indices.size() * sizeof(std::uint16_t));
  return {};
}

Result<void> decodeTileInto(const DatasetView& dataset, const TileKey& key, TexelFormat upload,
                            std::span<std::byte> out) {
  const FaceView& face = dataset.face(key.face);
  const TextureRecord record = dataset.textureNode(key);
  const std::string context = blobContext(face, record.blobOffset);
  Result<TextureTileImage> tile = decodeTextureTile(face.textureBlob(record), context);
  if (!tile) return std::move(tile).error();
  const Manifest& m = dataset.manifest();
  if (tile->sizeTexels != m.textureTileTexels || tile->borderTexels != m.textureBorderTexels ||
      tile->format != datasetTexelFormat(dataset)) {
    return makeError(ErrorCode::CorruptData,
                     context + ": tile of " + std::to_string(tile->sizeTexels) +
                         " texels (border " + std::to_string(tile->borderTexels) +
                         ") does not match manifest.json (" + std::to_string(m.textureTileTexels) +
                         ", border " + std::to_string(m.textureBorderTexels) + ", " +
                         m.textureFormat + ")");
  }
  if (tile->format != upload) {
    tile = expandToRgba8(*tile);
    if (!tile) return makeError(ErrorCode::CorruptData, context + ": " + tile.error().message);
  }
  if (tile->data.size() != out.size()) {
    return makeError(ErrorCode::Internal, context + ": tile data size differs from its slot");
  }
  std::memcpy(out.data(), tile->data.data(), out.size());
  return {};
}

VkImageMemoryBarrier2 layerBarrier(VkImage image, std::uint32_t layer,
                                   VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                                   VkImageLayout oldLayout, VkImageLayout newLayout) {
  VkImageMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.oldLayout = oldLayout;
  b.newLayout = newLayout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, layer, 1};
  return b;
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

  OffscreenTarget target;
  GpuBuffer staging;
  GpuBuffer records;
  UniqueDescriptorPool recordsPool;
  VkDescriptorSet recordsSet = VK_NULL_HANDLE;
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
  /// The stats of the last render() call when it succeeded (commands[kDrawCommands] then holds
  /// its last pass); unset before the first frame and after a failed one.
  std::optional<FrameStats> lastFrame;
  /// The entries the last pass drew and their slots: redrawLast() pins them again, and refuses
  /// if another renderer of a shared cache has evicted one since.
  std::vector<std::pair<ResidentKey, std::uint32_t>> lastPassEntries;

  /// Timestamp queries: 0 and 3 around the uploads, 1 and 2 around the render pass.
  static constexpr std::uint32_t kTimestampQueries = 4;

  Result<void> ensureStaging(std::uint64_t bytes);
  Result<void> ensureRecords(std::size_t count);
  /// Submits `buffers` (already recorded) in one batch and waits for them.
  Result<void> submitAndWait(std::span<const VkCommandBuffer> buffers, const char* what);
  /// Reads the draw timestamps (1, 2) and, with `withUploads`, the upload timestamps (0, 3)
  /// of the last pass into `stats`.
  void readTimestamps(bool withUploads, FrameStats& stats) const;

  Result<void> drawPass(const Cut& cut, const std::vector<NodeRecord>& nodes, std::size_t begin,
                        std::size_t end, bool first, bool last, const Camera& camera,
                        const PatchPush& push, const std::array<float, 4>& clear,
                        FrameStats& stats);
  void recordUploads(VkCommandBuffer cmd, const std::vector<UploadJob>& jobs) const;
};

Result<void> TerrainRenderer::Impl::ensureStaging(std::uint64_t bytes) {
  if (bytes == 0 || (staging && staging.sizeBytes() >= bytes)) return {};
  const std::uint64_t size =
      std::max<std::uint64_t>(bytes, staging ? 2 * staging.sizeBytes() : std::uint64_t{4} << 20);
  staging = GpuBuffer();
  auto buffer = createBuffer(*context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                             MemoryUse::HostUpload, "terrain upload staging");
  if (!buffer) return std::move(buffer).error();
  staging = std::move(*buffer);
  return {};
}

Result<void> TerrainRenderer::Impl::ensureRecords(std::size_t count) {
  const std::uint64_t bytes =
      std::uint64_t{sizeof(PatchDrawRecord)} * std::max<std::size_t>(1, count);
  if (records && records.sizeBytes() >= bytes) return {};
  const std::uint64_t size = std::max<std::uint64_t>(
      bytes, records ? 2 * records.sizeBytes() : sizeof(PatchDrawRecord) * std::uint64_t{1024});
  records = GpuBuffer();
  auto buffer = createBuffer(*context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             MemoryUse::HostUpload, "patch draw records");
  if (!buffer) return std::move(buffer).error();
  records = std::move(*buffer);
  VkDescriptorBufferInfo info{};
  info.buffer = records.buffer();
  info.offset = 0;
  info.range = VK_WHOLE_SIZE;
  VkWriteDescriptorSet write{};
  write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
  write.dstSet = recordsSet;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.pBufferInfo = &info;
  vkUpdateDescriptorSets(context->device(), 1, &write, 0, nullptr);
  return {};
}

Result<void> TerrainRenderer::Impl::submitAndWait(std::span<const VkCommandBuffer> buffers,
                                                  const char* what) {
  const VkDevice device = context->device();
  const VkFence submitFence = fence.get();
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
  if (VkResult r = vkWaitForFences(device, 1, &submitFence, VK_TRUE, kSubmitTimeoutNanoseconds);
      r != VK_SUCCESS) {
    // The work may still be running: wait it out so that re-recording the buffers is legal.
    (void)context->waitIdle();
    return vulkanError(r, std::string("vkWaitForFences (") + what + ")");
  }
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

void TerrainRenderer::Impl::recordUploads(VkCommandBuffer cmd,
                                          const std::vector<UploadJob>& jobs) const {
  // Before: earlier submissions read the pool regions being overwritten (write-after-read),
  // and tile layers go to TRANSFER_DST (their old contents are discarded).
  VkMemoryBarrier2 before{};
  before.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  before.srcStageMask =
      VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT;
  before.dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  before.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  VkMemoryBarrier2 after{};
  after.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  after.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  after.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  after.dstStageMask =
      VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT;
  after.dstAccessMask = VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT;
  std::vector<VkImageMemoryBarrier2> toTransfer;
  std::vector<VkImageMemoryBarrier2> toSampled;
  for (const UploadJob& job : jobs) {
    if (job.key.kind() != ResidentKind::Tile) continue;
    const PoolLocation at = shared->tiles.locate(job.slot);
    const VkImage image = shared->tiles.image(at.chunk);
    toTransfer.push_back(layerBarrier(image, at.local, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                      VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
                                      VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL));
    toSampled.push_back(layerBarrier(
        image, at.local, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
        VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL));
  }
  VkDependencyInfo dependency{};
  dependency.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dependency.memoryBarrierCount = 1;
  dependency.pMemoryBarriers = &before;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(toTransfer.size());
  dependency.pImageMemoryBarriers = toTransfer.data();
  vkCmdPipelineBarrier2(cmd, &dependency);

  const PatchPool& patches = shared->patches;
  const TilePool& tiles = shared->tiles;
  const std::uint32_t size = tiles.sizeTexels();
  for (const UploadJob& job : jobs) {
    if (job.key.kind() == ResidentKind::Patch) {
      const PoolLocation at = patches.locate(job.slot);
      const VkBufferCopy vertices{
          job.stagingOffset, VkDeviceSize{sizeof(PatchGpuVertex)} * patches.firstVertex(at.local),
          job.vertexBytes};
      vkCmdCopyBuffer(cmd, staging.buffer(), patches.vertexBuffer(at.chunk), 1, &vertices);
      const VkBufferCopy indices{job.stagingOffset + job.vertexBytes,
                                 VkDeviceSize{2} * patches.firstIndex(at.local),
                                 job.bytes - job.vertexBytes};
      vkCmdCopyBuffer(cmd, staging.buffer(), patches.indexBuffer(at.chunk), 1, &indices);
    } else {
      const PoolLocation at = tiles.locate(job.slot);
      VkBufferImageCopy region{};
      region.bufferOffset = job.stagingOffset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, at.local, 1};
      region.imageExtent = {size, size, 1};
      vkCmdCopyBufferToImage(cmd, staging.buffer(), tiles.image(at.chunk),
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    }
  }

  dependency.pMemoryBarriers = &after;
  dependency.imageMemoryBarrierCount = static_cast<uint32_t>(toSampled.size());
  dependency.pImageMemoryBarriers = toSampled.data();
  vkCmdPipelineBarrier2(cmd, &dependency);
}

Result<void> TerrainRenderer::Impl::drawPass(const Cut& cut, const std::vector<NodeRecord>& nodes,
                                             std::size_t begin, std::size_t end, bool first,
                                             bool last, const Camera& camera, const PatchPush& push,
                                             const std::array<float, 4>& clear, FrameStats& stats) {
  const DatasetView& data = *dataset;
  GpuCache::State& c = *shared;

  // The pass's entries: its patches, then its distinct tiles in first-use order.
  std::vector<UploadJob> entries;
  entries.reserve(2 * (end - begin));
  std::unordered_set<std::uint64_t> seenTiles;
  for (std::size_t i = begin; i < end; ++i) {
    if (!drawable(nodes[i])) continue;
    UploadJob entry;
    entry.key = ResidentKey::patch(cut.patches[i].node);
    entry.patchIndex = i;
    entries.push_back(entry);
  }
  for (std::size_t i = begin; i < end; ++i) {
    const ResidentKey tile = ResidentKey::tile(cut.patches[i].tile);
    if (!drawable(nodes[i]) || !seenTiles.insert(tile.packed).second) continue;
    UploadJob entry;
    entry.key = tile;
    entry.tile = cut.patches[i].tile;
    entries.push_back(entry);
  }

  // Under the cache lock from here through the uploads: nothing another renderer does can
  // evict what this pass pins, and nobody sees an entry before its upload has completed.
  std::unique_lock<std::mutex> lock(c.mutex);
  std::vector<UploadJob> jobs;
  std::vector<ResidentKey> hits;
  std::uint64_t passEpoch = 0;
  for (;;) {
    // Hits first (touched and pinned), so that making room for the misses never evicts them.
    passEpoch = ++c.epoch;
    jobs.clear();
    hits.clear();
    std::uint64_t missBytes = 0;
    for (const UploadJob& entry : entries) {
      if (c.lru->find(entry.key)) {
        c.lru->touch(entry.key, passEpoch);
        c.lru->pin(entry.key);
        hits.push_back(entry.key);
      } else {
        jobs.push_back(entry);
        missBytes += c.lru->slotBytes(entry.key.kind());
      }
    }
    // Every unpinned entry is of an earlier pass, hence evictable: the misses fit if the
    // unpinned bytes and the free bytes together cover them.
    if (missBytes <= c.lru->budgetBytes() - c.lru->pinnedBytes()) break;
    for (const ResidentKey key : hits) c.lru->unpin(key);
    if (c.lru->pinnedBytes() == 0) {
      return makeError(ErrorCode::Internal, "GPU cache: a planned pass does not fit its budget");
    }
    // Other renderers' passes in flight pin the rest: wait for one of them to finish.
    ++c.waits;
    c.unpinned.wait(lock);
  }
  stats.hits += hits.size();

  std::size_t inserted = 0;
  // Takes back this pass's pins (and, with `dropMisses`, its entries whose upload failed);
  // the cache lock must be held.
  const auto releasePass = [&](bool dropMisses) {
    for (std::size_t j = 0; j < inserted; ++j) {
      if (dropMisses) {
        c.lru->erase(jobs[j].key);
      } else {
        c.lru->unpin(jobs[j].key);
      }
    }
    for (const ResidentKey key : hits) c.lru->unpin(key);
    c.unpinned.notify_all();
  };
  std::vector<ResidentKey> evicted;
  for (UploadJob& job : jobs) {
    evicted.clear();
    const std::optional<std::uint32_t> slot = c.lru->insert(job.key, passEpoch, evicted);
    if (!slot) {
      releasePass(true);
      return makeError(ErrorCode::Internal, "GPU cache: a planned pass does not fit its budget");
    }
    c.lru->pin(job.key);
    ++inserted;
    stats.evictions += evicted.size();
    job.slot = *slot;
  }
  stats.peakResidentBytes = std::max(stats.peakResidentBytes, c.lru->residentBytes());

  // Patch and tile slots of the whole pass; pools grow to cover them.
  std::vector<std::uint32_t> patchSlots(end - begin, 0), tileSlots(end - begin, 0);
  std::uint32_t patchSlotCount = 0, tileSlotCount = 0;
  lastPassEntries.clear();
  for (std::size_t i = begin; i < end; ++i) {
    if (!drawable(nodes[i])) continue;
    patchSlots[i - begin] = *c.lru->find(ResidentKey::patch(cut.patches[i].node));
    tileSlots[i - begin] = *c.lru->find(ResidentKey::tile(cut.patches[i].tile));
    patchSlotCount = std::max(patchSlotCount, patchSlots[i - begin] + 1);
    tileSlotCount = std::max(tileSlotCount, tileSlots[i - begin] + 1);
  }
  for (const UploadJob& entry : entries) {
    lastPassEntries.emplace_back(entry.key, *c.lru->find(entry.key));
  }
  if (Result<void> r = c.patches.ensureSlots(*context, patchSlotCount); !r) {
    releasePass(true);
    return r;
  }
  if (Result<void> r = c.tiles.ensureSlots(*context, tileSlotCount); !r) {
    releasePass(true);
    return r;
  }

  // Staging layout, then decoding straight into it on TBB workers.
  std::uint64_t stagingBytes = 0;
  for (UploadJob& job : jobs) {
    job.stagingOffset = alignUp(stagingBytes, kStagingAlignment);
    if (job.key.kind() == ResidentKind::Patch) {
      const NodeRecord& n = nodes[job.patchIndex];
      job.vertexBytes = std::uint64_t{sizeof(PatchGpuVertex)} * n.vertexCount;
      job.bytes = job.vertexBytes + std::uint64_t{6} * n.triangleCount;
    } else {
      job.bytes = c.texture.slotBytes;
    }
    stagingBytes = job.stagingOffset + job.bytes;
  }
  if (Result<void> r = ensureStaging(stagingBytes); !r) {
    releasePass(true);
    return r;
  }
  const auto decodeStart = Clock::now();
  std::vector<Error> errors(jobs.size());
  std::vector<char> failed(jobs.size(), 0);
  const std::span<std::byte> stagingBytesSpan = staging.mappedBytes();
  const TexelFormat texels = c.texture.texels;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, jobs.size()),
      [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t j = range.begin(); j != range.end(); ++j) {
          const UploadJob& job = jobs[j];
          const std::span<std::byte> out = stagingBytesSpan.subspan(job.stagingOffset, job.bytes);
          Result<void> r = job.key.kind() == ResidentKind::Patch
                               ? decodePatchInto(data, cut.patches[job.patchIndex].node,
                                                 nodes[job.patchIndex], out)
                               : decodeTileInto(data, job.tile, texels, out);
          if (!r) {
            errors[j] = std::move(r).error();
            failed[j] = 1;
          }
        }
      });
  stats.decodeMs += millisecondsSince(decodeStart);
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    if (failed[j] != 0) {
      releasePass(true);
      return std::move(errors[j]);
    }
  }

  // Per-draw records, with each patch's tile layer.
  const std::span<std::byte> recordBytes = records.mappedBytes();
  for (std::size_t i = begin; i < end; ++i) {
    if (!drawable(nodes[i])) continue;
    PatchDrawInput input;
    input.node = cut.patches[i].node;
    input.record = nodes[i];
    input.textureLayer = c.tiles.locate(tileSlots[i - begin]).local;
    const PatchDrawRecord record = makePatchDrawRecord(data, input, camera.position());
    std::memcpy(recordBytes.data() + i * sizeof(PatchDrawRecord), &record, sizeof record);
  }
  if (Result<void> r = staging ? staging.flushHostWrites() : Result<void>(); !r) {
    releasePass(true);
    return r;
  }
  if (Result<void> r = records.flushHostWrites(); !r) {
    releasePass(true);
    return r;
  }

  // Timestamps: 0 and 3 around the uploads, 1 and 2 around the render pass. The draw buffer
  // resets its own two queries, so that redrawLast() can submit it alone.
  const bool timestamps = queries.get() != VK_NULL_HANDLE;
  Result<void> recorded =
      recordCommands(commands[kUploadCommands], "terrain uploads", [&](VkCommandBuffer cmd) {
        if (timestamps) {
          vkCmdResetQueryPool(cmd, queries.get(), 0, 1);
          vkCmdResetQueryPool(cmd, queries.get(), 3, 1);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries.get(), 0);
        }
        if (!jobs.empty()) recordUploads(cmd, jobs);
        if (timestamps) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries.get(), 3);
        }
      });
  if (recorded) {
    recorded = recordCommands(commands[kDrawCommands], "terrain frame", [&](VkCommandBuffer cmd) {
      if (timestamps) {
        vkCmdResetQueryPool(cmd, queries.get(), 1, 2);
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries.get(), 1);
      }
      if (first) {
        target.recordBeginRendering(cmd, clear, OffscreenTarget::kFarDepth, !last);
      } else {
        target.recordResumeRendering(cmd, !last);
      }
      const PatchPipeline& pipeline = c.pipeline;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.pipeline());
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 0, 1,
                              &recordsSet, 0, nullptr);
      vkCmdPushConstants(cmd, pipeline.layout(),
                         VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                         &push);
      std::uint32_t boundChunk = std::numeric_limits<std::uint32_t>::max();
      std::uint32_t boundPage = std::numeric_limits<std::uint32_t>::max();
      for (std::size_t i = begin; i < end; ++i) {
        if (!drawable(nodes[i])) continue;
        const PoolLocation patch = c.patches.locate(patchSlots[i - begin]);
        const PoolLocation tile = c.tiles.locate(tileSlots[i - begin]);
        if (patch.chunk != boundChunk) {
          const VkBuffer vertexBuffer = c.patches.vertexBuffer(patch.chunk);
          const VkDeviceSize zero = 0;
          vkCmdBindVertexBuffers(cmd, 0, 1, &vertexBuffer, &zero);
          vkCmdBindIndexBuffer(cmd, c.patches.indexBuffer(patch.chunk), 0, VK_INDEX_TYPE_UINT16);
          boundChunk = patch.chunk;
        }
        if (tile.chunk != boundPage) {
          const VkDescriptorSet set = c.tiles.descriptorSet(tile.chunk);
          vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 1, 1,
                                  &set, 0, nullptr);
          boundPage = tile.chunk;
        }
        const auto recordIndex = static_cast<std::uint32_t>(i);
        vkCmdPushConstants(cmd, pipeline.layout(),
                           VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                           kRecordIndexOffset, sizeof recordIndex, &recordIndex);
        vkCmdDrawIndexed(cmd, 3 * nodes[i].triangleCount, 1, c.patches.firstIndex(patch.local),
                         static_cast<std::int32_t>(c.patches.firstVertex(patch.local)), 0);
      }
      vkCmdEndRendering(cmd);
      if (timestamps) {
        vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries.get(), 2);
      }
      if (last) target.recordReadback(cmd);
    });
  }
  if (!recorded) {
    releasePass(true);
    return recorded;
  }

  if (privateCache) {
    // Nobody else uses the cache: uploads and draw go in one submission.
    if (recorded = submitAndWait(commands, "terrain frame"); !recorded) {
      releasePass(true);
      return recorded;
    }
    releasePass(false);
  } else {
    // Uploads under the lock; once they have completed the entries are usable by every
    // renderer of the cache, and the draw runs outside the lock with its entries pinned.
    const std::array<VkCommandBuffer, 1> uploads = {commands[kUploadCommands]};
    if (recorded = submitAndWait(uploads, "terrain uploads"); !recorded) {
      releasePass(true);
      return recorded;
    }
    lock.unlock();
    const std::array<VkCommandBuffer, 1> draw = {commands[kDrawCommands]};
    recorded = submitAndWait(draw, "terrain frame");
    lock.lock();
    releasePass(false);
    if (!recorded) return recorded;
  }
  lock.unlock();
  readTimestamps(true, stats);
  stats.misses += jobs.size();
  for (const UploadJob& job : jobs) stats.bytesUploaded += job.bytes;
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

  VkDescriptorPoolSize size{};
  size.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  size.descriptorCount = 1;
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(context.device(), &poolInfo, nullptr, &rawPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (patch draw records)");
  }
  impl->recordsPool = UniqueDescriptorPool(context.device(), rawPool);
  const VkDescriptorSetLayout recordsLayout = impl->shared->pipeline.recordsSetLayout();
  VkDescriptorSetAllocateInfo allocate{};
  allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  allocate.descriptorPool = rawPool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &recordsLayout;
  if (VkResult r = vkAllocateDescriptorSets(context.device(), &allocate, &impl->recordsSet);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateDescriptorSets (patch draw records)");
  }
  if (Result<void> r = impl->ensureRecords(1024); !r) return std::move(r).error();

  VkCommandPoolCreateInfo commandPoolInfo{};
  commandPoolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  commandPoolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  commandPoolInfo.queueFamilyIndex = context.queueFamilyIndex();
  VkCommandPool rawCommandPool = VK_NULL_HANDLE;
  if (VkResult r =
          vkCreateCommandPool(context.device(), &commandPoolInfo, nullptr, &rawCommandPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateCommandPool (terrain frames)");
  }
  impl->commandPool = UniqueCommandPool(context.device(), rawCommandPool);
  VkCommandBufferAllocateInfo commandsInfo{};
  commandsInfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  commandsInfo.commandPool = rawCommandPool;
  commandsInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  commandsInfo.commandBufferCount = static_cast<std::uint32_t>(impl->commands.size());
  if (VkResult r = vkAllocateCommandBuffers(context.device(), &commandsInfo, impl->commands.data());
      r != VK_SUCCESS) {
    return vulkanError(r, "vkAllocateCommandBuffers (terrain frames)");
  }
  VkFenceCreateInfo fenceInfo{};
  fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  VkFence rawFence = VK_NULL_HANDLE;
  if (VkResult r = vkCreateFence(context.device(), &fenceInfo, nullptr, &rawFence);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateFence (terrain frames)");
  }
  impl->fence = UniqueFence(context.device(), rawFence);

  // GPU timestamps for the upload/draw split, where the queue has them.
  std::uint32_t familyCount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(context.physicalDevice(), &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  vkGetPhysicalDeviceQueueFamilyProperties(context.physicalDevice(), &familyCount, families.data());
  const std::uint32_t validBits = families[context.queueFamilyIndex()].timestampValidBits;
  if (validBits > 0) {
    VkQueryPoolCreateInfo queryInfo{};
    queryInfo.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
    queryInfo.queryType = VK_QUERY_TYPE_TIMESTAMP;
    queryInfo.queryCount = Impl::kTimestampQueries;
    VkQueryPool rawQueries = VK_NULL_HANDLE;
    if (VkResult r = vkCreateQueryPool(context.device(), &queryInfo, nullptr, &rawQueries);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateQueryPool (frame timestamps)");
    }
    impl->queries = UniqueQueryPool(context.device(), rawQueries);
    impl->timestampMask = validBits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << validBits) - 1;
    impl->timestampPeriodNs = context.caps().timestampPeriodNanoseconds;
  }
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

Result<RenderedFrame> TerrainRenderer::render(const Cut& cut, const Camera& camera,
                                              const FrameSettings& settings) {
  Impl& m = *impl_;
  const auto frameStart = Clock::now();
  m.lastFrame.reset();
  if (camera.viewport().width != m.options.widthPixels ||
      camera.viewport().height != m.options.heightPixels) {
    return makeError(ErrorCode::InvalidArgument,
                     "camera viewport " + std::to_string(camera.viewport().width) + "x" +
                         std::to_string(camera.viewport().height) +
                         " differs from the renderer's " + std::to_string(m.options.widthPixels) +
                         "x" + std::to_string(m.options.heightPixels));
  }
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

  // Passes: the longest prefixes of the cut whose slot bytes fit the budget.
  std::vector<std::size_t> passEnds;
  {
    const std::uint64_t budget = c.lru->budgetBytes();
    std::uint64_t bytes = 0;
    std::unordered_set<std::uint64_t> passTiles;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (!drawable(nodes[i])) continue;
      const std::uint64_t tile = ResidentKey::tile(cut.patches[i].tile).packed;
      std::uint64_t need = c.patchSlot + (passTiles.count(tile) != 0 ? 0 : c.texture.slotBytes);
      if (bytes > 0 && bytes + need > budget) {
        passEnds.push_back(i);
        bytes = 0;
        passTiles.clear();
        need = c.patchSlot + c.texture.slotBytes;
      }
      bytes += need;
      passTiles.insert(tile);
    }
    passEnds.push_back(nodes.size());
  }
  stats.passes = static_cast<std::uint32_t>(passEnds.size());
  stats.budgetExceeded = passEnds.size() > 1;
  if (stats.budgetExceeded && m.options.warnWhenBudgetExceeded && !m.warned) {
    m.warned = true;
    std::fprintf(stderr,
                 "pbdam: warning: a frame's cut (%zu patches, %zu tiles) does not fit the GPU "
                 "cache budget of %s; drawing it in %zu passes (same image, slower); raise the "
                 "budget (--gpu-cache-mb) to avoid this\n",
                 cut.patches.size(), cut.tiles.size(), mebibytes(c.lru->budgetBytes()).c_str(),
                 passEnds.size());
  }
  if (Result<void> r = m.ensureRecords(cut.patches.size()); !r) return std::move(r).error();

  PatchPush push{};
  const glm::mat4 viewProjection = camera.projection() * camera.viewRotation();
  std::memcpy(push.viewProjection, glm::value_ptr(viewProjection), sizeof push.viewProjection);
  const glm::dvec3 sun = glm::normalize(settings.sunDirectionEcef ? *settings.sunDirectionEcef
                                                                  : defaultSunDirection(camera));
  push.sunAmbient[0] = static_cast<float>(sun.x);
  push.sunAmbient[1] = static_cast<float>(sun.y);
  push.sunAmbient[2] = static_cast<float>(sun.z);
  push.sunAmbient[3] = std::clamp(settings.ambient, 0.0f, 1.0f);
  const std::array<float, 4> clear = {static_cast<float>(settings.clearRgb[0]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[1]) / 255.0f,
                                      static_cast<float>(settings.clearRgb[2]) / 255.0f, 1.0f};

  std::size_t begin = 0;
  for (std::size_t p = 0; p < passEnds.size(); ++p) {
    if (Result<void> r = m.drawPass(cut, nodes, begin, passEnds[p], p == 0,
                                    p + 1 == passEnds.size(), camera, push, clear, stats);
        !r) {
      return std::move(r).error();
    }
    begin = passEnds[p];
  }
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

Result<void> TerrainRenderer::resize(std::uint32_t widthPixels, std::uint32_t heightPixels) {
  Impl& m = *impl_;
  if (widthPixels == m.options.widthPixels && heightPixels == m.options.heightPixels) return {};
  // No submission of this renderer is in flight (render() waits for its own), so the old
  // target can go now; the recorded draw that redrawLast() would reuse refers to it.
  auto target = OffscreenTarget::create(*m.context, widthPixels, heightPixels);
  if (!target) return std::move(target).error();
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
