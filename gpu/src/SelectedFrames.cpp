// TerrainRenderer::renderSelected: frames drawn from the draw list made on the device
// (DeviceDrawList.h; docs/architecture.md "Selection by predicate"): the whole dataset made
// resident once by drawing it, then per frame the selection passes, draw_list.comp and one
// vkCmdDrawIndexedIndirectCount in one submission, waited for (the list's buffers are one set).
#include <array>
#include <chrono>
#include <mutex>
#include <string>
#include <unordered_set>
#include <vector>

#include "DrawRecorder.h"
#include "GpuCacheState.h"
#include "TerrainRendererImpl.h"
#include "pbdam/gpu/GpuSelector.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::gpu {

using Clock = std::chrono::steady_clock;

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
  auto list = DeviceDrawList::create(*context, *dataset, selector, residency, readableRecords,
                                     shared->exaggeration);
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

Result<void> TerrainRenderer::Impl::recordSelectedFrame(FrameSlot& slot, GpuSelector& selector,
                                                        const Camera& camera,
                                                        const SelectionOptions& selection,
                                                        const FrameSettings& settings) {
  const PatchPush push = patchPush(camera, settings, *atmosphere);
  const std::array<float, 4> clear = clearColour(settings);
  VkQueryPool timestamps = queries.get();
  const std::uint32_t q = slot.firstQuery;
  const OffscreenTarget& target = slot.target;
  Result<void> inner;
  Result<void> recorded = recordCommands(
      slot.commands[FrameSlot::kDrawCommands], "selected terrain frame", [&](VkCommandBuffer cmd) {
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdResetQueryPool(cmd, timestamps, q, kQueriesPerSlot);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q);
        }
        inner = selector.recordSelection(cmd, camera, selection);
        if (inner) inner = deviceList->record(cmd, camera, selection.refinement);
        if (!inner) return;
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 3);
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 1);
        }
        atmosphere->recordSkyView(cmd, push);
        const float exposure = toneMapExposure(push, settings);
        const bool radiance = exposure > 0.0f;
        target.recordBeginRendering(cmd, clear, OffscreenTarget::kFarDepth, false, radiance);
        const PatchPipeline& pipeline = shared->pipeline;
        VkDescriptorSet page = shared->tiles.descriptorSet(0);
        const std::array<VkDescriptorSet, 5> sets = {deviceRecordsSet, page, page,
                                                     slot.overlay->set(), atmosphere->set()};
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.layout(), 0,
                                static_cast<std::uint32_t>(sets.size()), sets.data(), 0, nullptr);
        vkCmdPushConstants(cmd, pipeline.layout(),
                           VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                           sizeof push, &push);
        if (push.camera[3] > 0.0f) {  // the sky first: the patches cover it
          recordSky(cmd, radiance ? radiancePipelines->sky.get() : pipeline.skyPipeline());
        }
        vkCmdBindPipeline(
            cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
            radiance ? radiancePipelines->indirect.get() : pipeline.indirectPipeline());
        VkBuffer vertexBuffer = shared->patches.vertexBuffer(0);
        const VkDeviceSize zero = 0;
        vkCmdBindVertexBuffers(cmd, 0, 1, &vertexBuffer, &zero);
        vkCmdBindIndexBuffer(cmd, shared->patches.indexBuffer(0), 0, VK_INDEX_TYPE_UINT16);
        vkCmdDrawIndexedIndirectCount(cmd, deviceList->commands().buffer(), 0,
                                      deviceList->count().buffer(), 0, deviceList->capacity(),
                                      sizeof(VkDrawIndexedIndirectCommand));
        vkCmdEndRendering(cmd);
        if (radiance) target.recordToneMap(cmd, exposure);
        if (timestamps != VK_NULL_HANDLE) {
          vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, timestamps, q + 2);
        }
        target.recordReadback(cmd);
        if (radiance && settings.readRadiance) target.recordRadianceReadback(cmd);
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
  if (!m.pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "renderSelected() with frames in flight: collect() them first");
  }
  if (settings.present) {
    return makeError(ErrorCode::InvalidArgument,
                     "renderSelected() draws offscreen: FrameSettings::present is for submit()");
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
  // One frame at a time: the draw list's buffers are the device's, one set of them.
  auto taken = m.freeSlot();
  if (!taken) return std::move(taken).error();
  FrameSlot& slot = **taken;
  if (Result<void> r =
          slot.overlay->prepare(settings.overlay, m.dataset->planet(), camera.position());
      !r) {
    return std::move(r).error();
  }
  if (Result<void> r = m.recordSelectedFrame(slot, selector, camera, selection, settings); !r) {
    return std::move(r).error();
  }
  const std::array<VkCommandBuffer, 1> frame = {slot.commands[FrameSlot::kDrawCommands]};
  if (Result<void> r = m.submitSlot(slot, frame, nullptr, "selected terrain frame", true); !r) {
    return std::move(r).error();
  }
  FrameStats stats;
  m.readTimestamps(slot, true, stats);
  // The selection and draw-list passes stand where render()'s uploads do.
  auto totals = m.deviceList->totals();
  if (!totals) return std::move(totals).error();
  stats.patches = totals->draws;
  stats.triangles = totals->triangles;
  stats.hits = totals->draws;
  Result<RgbaImage> image = slot.target.readPixels();
  if (!image) return std::move(image).error();
  std::vector<float> radiance;
  if (settings.readRadiance &&
      m.toneMapExposure(patchPush(camera, settings, *m.atmosphere), settings) > 0.0f) {
    Result<std::vector<float>> linear = slot.target.readRadiance();
    if (!linear) return std::move(linear).error();
    radiance = std::move(*linear);
  }
  {
    const std::lock_guard<std::mutex> lock(m.shared->mutex);
    stats.residentBytes = m.shared->lru->residentBytes();
    stats.peakResidentBytes = stats.residentBytes;
    stats.poolBytes = m.shared->patches.allocatedBytes() + m.shared->tiles.allocatedBytes();
  }
  stats.frameMs = std::chrono::duration<double, std::milli>(Clock::now() - frameStart).count();
  return RenderedFrame{std::move(*image), stats, std::move(radiance)};
}

Result<std::vector<PatchDrawRecord>> TerrainRenderer::lastSelectedRecords() const {
  if (!impl_->deviceList) {
    return makeError(ErrorCode::InvalidArgument, "no draw list made on the device");
  }
  return impl_->deviceList->readRecords();
}

}  // namespace pbdam::gpu
