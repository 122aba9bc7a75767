// TerrainRenderer: exact-mode frames of a P-BDAM cut (TerrainRenderer.h; [P-BDAM 2003] §4.2, §4.4).
//
// A frame is planned as one or more passes over consecutive ranges of the cut (one pass unless
// the cut's slot bytes exceed the budget). Per pass: a CacheLease reserves the pass's entries in
// the cache (hits pinned, misses given slots, evicting entries of earlier passes), the
// DecodeScheduler (streaming/) decodes the misses in parallel into the frame slot's staging
// buffer, and one submission copies them into the pools and draws the pass's patches in cut
// order (DrawRecorder), one indexed draw each. The submission holds two of the slot's own
// (reusable) command buffers, uploads then the render pass, so that redrawLast() can submit a
// one-pass frame's render pass again without recording anything. A frame's last pass is not
// waited for: its slot keeps the pass's pins until collect() (or a reservation that needs the
// room) sees its fence signal (TerrainRendererImpl.h: frames in flight). Buffers the renderer
// replaces go to its DeferredDestruction and are destroyed once the submissions that used them
// are done.
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
#include "DrawRecorder.h"
#include "GpuCacheState.h"
#include "PassDrawer.h"
#include "TerrainRendererImpl.h"
#include "pbdam/gpu/GpuCache.h"
#include "pbdam/gpu/GpuMemory.h"
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

using Clock = std::chrono::steady_clock;

namespace {

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

std::string mebibytes(std::uint64_t bytes) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return text;
}

Result<void> recordCommands(VkCommandBuffer cmd, const char* what,
                            const std::function<void(VkCommandBuffer)>& record) {
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

PatchPush patchPush(const Camera& camera, const FrameSettings& settings,
                    const AtmosphereBinding& atmosphere, DepthConvention depth) {
  PatchPush push{};
  // Reversed-Z: the float product the offscreen frames have always used (byte-identical).
  const glm::mat4 viewProjection =
      depth == DepthConvention::ReversedZ
          ? camera.projection() * camera.viewRotation()
          : glm::mat4(hostProjection(camera, depth)) * camera.viewRotation();
  std::memcpy(push.viewProjection, glm::value_ptr(viewProjection), sizeof push.viewProjection);
  const glm::dvec3 sun =
      glm::normalize(settings.sunDirectionEcef ? *settings.sunDirectionEcef
                                               : TerrainRenderer::defaultSunDirection(camera));
  push.sunAmbient[0] = static_cast<float>(sun.x);
  push.sunAmbient[1] = static_cast<float>(sun.y);
  push.sunAmbient[2] = static_cast<float>(sun.z);
  push.sunAmbient[3] = std::clamp(settings.ambient, 0.0f, 1.0f);
  push.sunDisc = settings.sunDirectionEcef && settings.sunAngularRadiusRadians > 0.0f
                     ? std::sin(std::min(settings.sunAngularRadiusRadians, 0.1f))
                     : 0.0f;
  push.normalMaps = settings.normalMaps ? 1.0f : 0.0f;
  if (atmosphere.present() && settings.atmosphereExposure > 0.0f) {
    const glm::dvec3 at = atmosphere.toAtmosphere(camera.position());
    push.camera[0] = static_cast<float>(at.x);
    push.camera[1] = static_cast<float>(at.y);
    push.camera[2] = static_cast<float>(at.z);
    push.camera[3] = settings.atmosphereExposure;
  }
  return push;
}

std::array<float, 4> clearColour(const FrameSettings& settings) {
  return {static_cast<float>(settings.clearRgb[0]) / 255.0f,
          static_cast<float>(settings.clearRgb[1]) / 255.0f,
          static_cast<float>(settings.clearRgb[2]) / 255.0f, 1.0f};
}

TerrainRenderer::Impl::~Impl() {
  // A shared cache outlives the renderer: its frames in flight must finish and hand their pins
  // back; and nothing the device may still read is destroyed before.
  for (FrameSlot& slot : slots) (void)finish(slot, false);
}

Result<void> TerrainRenderer::Impl::ensureRecords(FrameSlot& slot, std::size_t count) {
  const std::uint64_t bytes =
      std::uint64_t{sizeof(PatchDrawRecord)} * std::max<std::size_t>(1, count);
  if (slot.records && slot.records.sizeBytes() >= bytes) return {};
  const std::uint64_t size =
      std::max<std::uint64_t>(bytes, slot.records ? 2 * slot.records.sizeBytes()
                                                  : sizeof(PatchDrawRecord) * std::uint64_t{1024});
  // The recorded draw of the slot's previous frame reads the old buffer: it lives until that
  // is done (redrawLast() is refused from now on: the slot's frame is being replaced).
  garbage.retire(std::move(slot.records), submitted);
  slot.records = GpuBuffer();
  auto buffer = createBuffer(*context, size, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             MemoryUse::HostUpload, "patch draw records");
  if (!buffer) return std::move(buffer).error();
  slot.records = std::move(*buffer);
  bindRecords(context->device(), slot.recordsSet, slot.records.buffer());
  return {};
}

Result<void> TerrainRenderer::Impl::submitSlot(FrameSlot& slot,
                                               std::span<const VkCommandBuffer> buffers,
                                               const PresentTarget* present, const char* what,
                                               bool wait) {
  assert(!slot.running);
  VkFence submitFence = slot.fence.get();
  if (VkResult r = vkResetFences(context->device(), 1, &submitFence); r != VK_SUCCESS) {
    return vulkanError(r, std::string("vkResetFences (") + what + ")");
  }
  std::array<VkCommandBufferSubmitInfo, 3> infos{};
  assert(buffers.size() <= infos.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i].sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
    infos[i].commandBuffer = buffers[i];
  }
  VkSubmitInfo2 submit{};
  submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
  submit.commandBufferInfoCount = static_cast<std::uint32_t>(buffers.size());
  submit.pCommandBufferInfos = infos.data();
  VkSemaphoreSubmitInfo acquired{};
  VkSemaphoreSubmitInfo rendered{};
  if (present != nullptr) {
    acquired.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
    acquired.semaphore = present->acquired;
    acquired.stageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
    rendered.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
    rendered.semaphore = present->rendered;
    rendered.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    submit.waitSemaphoreInfoCount = 1;
    submit.pWaitSemaphoreInfos = &acquired;
    submit.signalSemaphoreInfoCount = 1;
    submit.pSignalSemaphoreInfos = &rendered;
  }
  // Through the context: its queue lock lets several renderers share it (pbdam serve).
  if (Result<void> r = context->submit(submit, submitFence, what); !r) return r;
  slot.submission = ++submitted;
  slot.running = true;
  if (!wait) return {};
  assert(slot.pins.empty());  // a pass waited for holds its pins in its lease
  return finish(slot, false);
}

Result<void> TerrainRenderer::Impl::finish(FrameSlot& slot, bool cacheLocked) {
  if (!slot.running && slot.hostSignal == 0) return {};
  Result<void> result;
  VkFence submitFence = slot.fence.get();
  if (VkResult r = slot.running ? vkWaitForFences(context->device(), 1, &submitFence, VK_TRUE,
                                                  kSubmitTimeoutNanoseconds)
                                : VK_SUCCESS;
      r != VK_SUCCESS) {
    // The work may still be running: wait it out so that re-recording the buffers and reusing
    // the slots it read is legal.
    (void)context->waitIdle();
    result = vulkanError(r, "vkWaitForFences (terrain frame)");
  }
  if (slot.hostSignal != 0) {
    if (Result<void> r = waitForHost(slot.hostSignal); !r && result) result = std::move(r);
    std::erase(hostOrder, static_cast<std::size_t>(&slot - slots.data()));
    slot.hostSignal = 0;
  }
  slot.running = false;
  if (!slot.pins.empty()) {
    std::unique_lock<std::mutex> lock(shared->mutex, std::defer_lock);
    if (!cacheLocked) lock.lock();
    for (const ResidentKey key : slot.pins) shared->lru->unpin(key);
    slot.pins.clear();
    shared->unpinned.notify_all();
  }
  // A host-pass frame's draws read what its uploads' submission kept alive.
  std::uint64_t oldestRunning = submitted + 1;
  for (const FrameSlot& s : slots) {
    if (s.running || s.hostSignal != 0) oldestRunning = std::min(oldestRunning, s.submission);
  }
  completed = oldestRunning - 1;
  garbage.collect(completed);
  return result;
}

bool TerrainRenderer::Impl::finishOldestLocked() {
  for (const std::size_t index : pendingOrder) {
    FrameSlot& slot = slots[index];
    if (!slot.running) continue;
    // An error stays with the slot's frame: collect() reports the device's state then.
    (void)finish(slot, true);
    return true;
  }
  if (!hostOrder.empty()) {
    // The host has submitted its earlier frames by the time it draws the next one.
    (void)finish(slots[hostOrder.front()], true);
    return true;
  }
  return false;
}

void TerrainRenderer::Impl::readTimestamps(const FrameSlot& slot, bool withUploads,
                                           FrameStats& stats) const {
  if (!queries) return;
  std::array<std::uint64_t, kQueriesPerSlot> ticks{};
  const std::uint32_t first = withUploads ? 0 : 1;
  const std::uint32_t count = withUploads ? kQueriesPerSlot : 2;
  if (vkGetQueryPoolResults(context->device(), queries.get(), slot.firstQuery + first, count,
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

Result<void> TerrainRenderer::Impl::createFrameObjects(std::uint32_t count) {
  VkDescriptorPoolSize size{};
  size.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  size.descriptorCount = count + 1;  // each slot's records, and renderSelected()'s
  VkDescriptorPoolCreateInfo poolInfo{};
  poolInfo.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  poolInfo.maxSets = count + 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool rawPool = VK_NULL_HANDLE;
  if (VkResult r = vkCreateDescriptorPool(context->device(), &poolInfo, nullptr, &rawPool);
      r != VK_SUCCESS) {
    return vulkanError(r, "vkCreateDescriptorPool (patch draw records)");
  }
  recordsPool = UniqueDescriptorPool(context->device(), rawPool);

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
    queryInfo.queryCount = kQueriesPerSlot * count;
    VkQueryPool rawQueries = VK_NULL_HANDLE;
    if (VkResult r = vkCreateQueryPool(context->device(), &queryInfo, nullptr, &rawQueries);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateQueryPool (frame timestamps)");
    }
    queries = UniqueQueryPool(context->device(), rawQueries);
    timestampMask = validBits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << validBits) - 1;
    timestampPeriodNs = static_cast<double>(context->caps().timestampPeriodNanoseconds);
  }

  slots.resize(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    FrameSlot& slot = slots[i];
    slot.firstQuery = kQueriesPerSlot * i;
    VkDescriptorSetLayout recordsLayout = shared->pipeline.recordsSetLayout();
    VkDescriptorSetAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    allocate.descriptorPool = rawPool;
    allocate.descriptorSetCount = 1;
    allocate.pSetLayouts = &recordsLayout;
    if (VkResult r = vkAllocateDescriptorSets(context->device(), &allocate, &slot.recordsSet);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkAllocateDescriptorSets (patch draw records)");
    }
    if (Result<void> r = ensureRecords(slot, 1024); !r) return r;
    auto overlayBinding = SurfaceOverlayBinding::create(*context, shared->pipeline);
    if (!overlayBinding) return std::move(overlayBinding).error();
    slot.overlay.emplace(std::move(*overlayBinding));
    auto target = OffscreenTarget::create(*context, options.widthPixels, options.heightPixels,
                                          toneMap ? &*toneMap : nullptr);
    if (!target) return std::move(target).error();
    slot.target = std::move(*target);

    VkCommandBufferAllocateInfo commandsInfo{};
    commandsInfo.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    commandsInfo.commandPool = rawCommandPool;
    commandsInfo.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    commandsInfo.commandBufferCount = static_cast<std::uint32_t>(slot.commands.size());
    if (VkResult r =
            vkAllocateCommandBuffers(context->device(), &commandsInfo, slot.commands.data());
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
    slot.fence = UniqueFence(context->device(), rawFence);
  }
  return {};
}

Result<TerrainRenderer> TerrainRenderer::create(VulkanContext& context, const DatasetView& dataset,
                                                const TerrainRendererOptions& options) {
  if (options.framesInFlight < 1 || options.framesInFlight > kMaxFramesInFlight) {
    return makeError(ErrorCode::InvalidArgument, "frames in flight must be 1 to " +
                                                     std::to_string(kMaxFramesInFlight) + ", not " +
                                                     std::to_string(options.framesInFlight));
  }
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
    if (state.exaggeration != options.exaggeration) {
      return makeError(ErrorCode::InvalidArgument,
                       "the shared GPU cache holds patches of another vertical exaggeration");
    }
    impl->cache = options.sharedCache;
    impl->privateCache = false;
  } else {
    GpuCacheOptions cacheOptions;
    cacheOptions.budgetBytes = options.gpuCacheBytes;
    cacheOptions.forceRgba8Textures = options.forceRgba8Textures;
    cacheOptions.chunkBytes = options.poolChunkBytes;
    cacheOptions.exaggeration = options.exaggeration;
    auto cache = GpuCache::create(context, dataset, cacheOptions);
    if (!cache) return std::move(cache).error();
    impl->cache = std::move(*cache);
  }
  impl->shared = &impl->cache->state();
  // The renderer does not keep the cache options: the cache has them.
  impl->options.sharedCache.reset();

  // The size first: a bad one is an InvalidArgument naming it, before anything is allocated.
  auto probe = OffscreenTarget::create(context, options.widthPixels, options.heightPixels);
  if (!probe) return std::move(probe).error();
  impl->decoder.emplace(dataset, impl->shared->texture.texels, impl->shared->exaggeration);
  auto atmosphere = AtmosphereBinding::create(context, impl->shared->pipeline, options.atmosphere,
                                              dataset.planet());
  if (!atmosphere) return std::move(atmosphere).error();
  impl->atmosphere.emplace(std::move(*atmosphere));
  if (options.atmosphere) {
    auto toneMap = ToneMapPass::create(context, OffscreenTarget::kColorFormat);
    if (!toneMap) return std::move(toneMap).error();
    impl->toneMap.emplace(std::move(*toneMap));
    auto radiance = impl->shared->pipeline.createRadiancePipelines(
        context, OffscreenTarget::kRadianceFormat, OffscreenTarget::kDepthFormat);
    if (!radiance) return std::move(radiance).error();
    impl->radiancePipelines.emplace(std::move(*radiance));
  }
  if (Result<void> r = impl->createFrameObjects(options.framesInFlight); !r) {
    return std::move(r).error();
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

std::uint32_t TerrainRenderer::framesInFlight() const noexcept {
  return static_cast<std::uint32_t>(impl_->slots.size());
}

std::size_t TerrainRenderer::framesPending() const noexcept { return impl_->pendingOrder.size(); }

Result<FrameSlot*> TerrainRenderer::Impl::freeSlot() {
  FrameSlot& slot = slots[nextSlot];
  if (slot.pending) {
    return makeError(ErrorCode::InvalidArgument,
                     "all " + std::to_string(slots.size()) +
                         " frames in flight are pending: collect() one before submitting more");
  }
  if (Result<void> r = finish(slot, false); !r) return std::move(r).error();
  return &slot;
}

Result<void> TerrainRenderer::submit(const Cut& cut, const Camera& camera,
                                     const FrameSettings& settings) {
  Impl& m = *impl_;
  const bool readback = settings.readback;
  const PresentTarget* present = settings.present ? &*settings.present : nullptr;
  // A paged node table that no longer reads back as it did (DatasetView::damage) may have
  // given the cut empty leaves: no frame is drawn from it.
  if (auto damage = m.dataset->damage()) return std::move(*damage);
  const auto frameStart = Clock::now();
  auto taken = m.freeSlot();
  if (!taken) return std::move(taken).error();
  FrameSlot& slot = **taken;
  m.lastFrame.reset();
  if (Result<void> r = m.checkViewport(camera); !r) return r;
  FrameStats stats = m.frameOpening(cut);
  GpuCache::State& c = *m.shared;
  const std::vector<NodeRecord> nodes = m.cutNodes(cut);
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
  if (Result<void> r = m.prepareSlot(slot, cut, camera, settings); !r) return r;

  const PatchPush push = patchPush(camera, settings, *m.atmosphere);
  const std::array<float, 4> clear = clearColour(settings);
  std::size_t begin = 0;
  for (std::size_t p = 0; p < passEnds.size(); ++p) {
    const PassInput pass{
        cut,
        nodes,
        begin,
        passEnds[p],
        camera,
        std::as_bytes(std::span(&push, 1)),
        {p == 0, p + 1 == passEnds.size(), clear, m.toneMapExposure(push, settings)},
        settings.readRadiance};
    if (Result<void> r = PassDrawer(m, slot, pass, stats).draw(readback, present); !r) return r;
    begin = passEnds[p];
  }
  m.frameClosing(stats);
  slot.pending = true;
  slot.readback = readback;
  slot.readRadiance = readback && settings.readRadiance && m.toneMapExposure(push, settings) > 0.0f;
  slot.stats = stats;
  slot.start = frameStart;
  m.pendingOrder.push_back(m.nextSlot);
  m.nextSlot = (m.nextSlot + 1) % m.slots.size();
  return {};
}

FrameStats TerrainRenderer::Impl::frameOpening(const Cut& cut) const {
  FrameStats stats;
  stats.patches = cut.patches.size();
  stats.triangles = cut.triangles;
  stats.tiles = cut.tiles.size();
  const std::lock_guard<std::mutex> lock(shared->mutex);
  stats.peakResidentBytes = shared->lru->residentBytes();
  return stats;
}

std::vector<NodeRecord> TerrainRenderer::Impl::cutNodes(const Cut& cut) const {
  std::vector<NodeRecord> nodes(cut.patches.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) nodes[i] = dataset->node(cut.patches[i].node);
  return nodes;
}

Result<void> TerrainRenderer::Impl::prepareSlot(FrameSlot& slot, const Cut& cut,
                                                const Camera& camera,
                                                const FrameSettings& settings) {
  if (Result<void> r = ensureRecords(slot, cut.patches.size()); !r) return r;
  return slot.overlay->prepare(settings.overlay, dataset->planet(), camera.position());
}

void TerrainRenderer::Impl::frameClosing(FrameStats& stats) {
  if (stats.evictions > 0) deviceList.reset();  // it knew where the evicted entries were
  // What the frame left resident (later frames submitted before it is collected change it).
  const std::lock_guard<std::mutex> lock(shared->mutex);
  stats.residentBytes = shared->lru->residentBytes();
  stats.poolBytes = shared->patches.allocatedBytes() + shared->tiles.allocatedBytes();
}

Result<RenderedFrame> TerrainRenderer::Impl::collectOldest() {
  if (pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument, "collect(): no frame in flight");
  }
  const std::size_t index = pendingOrder.front();
  pendingOrder.pop_front();
  FrameSlot& slot = slots[index];
  slot.pending = false;
  if (Result<void> r = finish(slot, false); !r) return std::move(r).error();
  FrameStats stats = slot.stats;
  readTimestamps(slot, true, stats);
  RgbaImage image;
  std::vector<float> radiance;
  if (slot.readback) {
    Result<RgbaImage> pixels = slot.target.readPixels();
    if (!pixels) return std::move(pixels).error();
    image = std::move(*pixels);
  }
  if (slot.readRadiance) {
    Result<std::vector<float>> linear = slot.target.readRadiance();
    if (!linear) return std::move(linear).error();
    radiance = std::move(*linear);
  }
  stats.frameMs = millisecondsSince(slot.start);
  if (auto damage = dataset->damage()) return std::move(*damage);
  // The latest frame, read back and drawn from its slot's commands: redrawLast() may repeat it.
  if (pendingOrder.empty() && slot.readback && (index + 1) % slots.size() == nextSlot) {
    lastFrame = stats;
    lastFrameSlot = index;
  }
  return RenderedFrame{std::move(image), stats, std::move(radiance)};
}

Result<RenderedFrame> TerrainRenderer::collect() { return impl_->collectOldest(); }

Result<RenderedFrame> TerrainRenderer::render(const Cut& cut, const Camera& camera,
                                              const FrameSettings& settings) {
  if (!impl_->pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "render() with frames in flight: collect() them first");
  }
  FrameSettings readBack = settings;
  readBack.readback = true;
  if (Result<void> r = submit(cut, camera, readBack); !r) return std::move(r).error();
  return impl_->collectOldest();
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

Result<void> TerrainRenderer::resize(std::uint32_t widthPixels, std::uint32_t heightPixels) {
  Impl& m = *impl_;
  if (widthPixels == m.options.widthPixels && heightPixels == m.options.heightPixels) return {};
  if (!m.pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "resize() with frames in flight: collect() them first");
  }
  // The recorded draws that redrawLast() would reuse refer to the old targets: they are
  // retired until the renderer's submissions so far have completed.
  std::vector<OffscreenTarget> targets;
  for (std::size_t i = 0; i < m.slots.size(); ++i) {
    auto target = OffscreenTarget::create(*m.context, widthPixels, heightPixels,
                                          m.toneMap ? &*m.toneMap : nullptr);
    if (!target) return std::move(target).error();
    targets.push_back(std::move(*target));
  }
  for (std::size_t i = 0; i < m.slots.size(); ++i) {
    m.garbage.retire(std::move(m.slots[i].target), m.submitted);
    m.slots[i].target = std::move(targets[i]);
  }
  m.garbage.collect(m.completed);
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
  if (!m.lastFrame || !m.pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "redrawLast: there is no previous frame (render() was not called, its last "
                     "call failed, or frames are in flight)");
  }
  const FrameStats& last = *m.lastFrame;
  if (last.passes > 1) {
    return makeError(ErrorCode::InvalidArgument,
                     "redrawLast: the previous frame was drawn in " + std::to_string(last.passes) +
                         " passes (its cut exceeds the GPU cache budget of " +
                         mebibytes(c.lru->budgetBytes()) +
                         "); only one-pass frames can be redrawn");
  }
  FrameSlot& slot = m.slots[m.lastFrameSlot];
  // The recorded draw reads the slots the frame used: they must still hold its entries.
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    for (std::size_t i = 0; i < slot.lastPassEntries.size(); ++i) {
      const auto& [key, cacheSlot] = slot.lastPassEntries[i];
      const std::optional<std::uint32_t> now = c.lru->find(key);
      if (!now || *now != cacheSlot) {
        for (std::size_t j = 0; j < i; ++j) c.lru->unpin(slot.lastPassEntries[j].first);
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
    for (const auto& entry : slot.lastPassEntries) c.lru->unpin(entry.first);
    c.unpinned.notify_all();
  };
  FrameStats stats;
  stats.patches = last.patches;
  stats.triangles = last.triangles;
  stats.tiles = last.tiles;
  stats.hits = last.hits + last.misses;
  const std::array<VkCommandBuffer, 1> draw = {slot.commands[FrameSlot::kDrawCommands]};
  Result<void> submitted = m.submitSlot(slot, draw, nullptr, "terrain redraw", true);
  unpinLast();
  if (!submitted) {
    m.lastFrame.reset();
    return std::move(submitted).error();
  }
  m.readTimestamps(slot, false, stats);
  Result<RgbaImage> image = slot.target.readPixels();
  if (!image) return std::move(image).error();
  {
    const std::lock_guard<std::mutex> lock(c.mutex);
    stats.residentBytes = c.lru->residentBytes();
    stats.poolBytes = c.patches.allocatedBytes() + c.tiles.allocatedBytes();
  }
  stats.peakResidentBytes = stats.residentBytes;
  stats.frameMs = millisecondsSince(frameStart);
  return RenderedFrame{std::move(*image), stats, {}};
}

}  // namespace pbdam::gpu
