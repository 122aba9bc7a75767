// Frames drawn into a host's pass (TerrainRenderer::drawInto; docs/embedding.md "Drawing into
// your own pass"). The frame takes a slot as an offscreen frame does and goes through the same
// reservation, decoding and upload (PassDrawer), but in one pass: a host's pass cannot be split
// and resumed. Its uploads are submitted by the renderer on the context's queue; its draws are
// recorded into the host's command buffer with a patch pipeline made for the host's attachments
// and depth convention, and the host's submission signals the renderer's timeline semaphore. The
// slot keeps the frame's pins until that value has been seen (TerrainRendererImpl.h).
#include <string>
#include <vector>

#include "GpuCacheState.h"
#include "PassDrawer.h"
#include "PatchPipeline.h"
#include "TerrainRendererImpl.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {

Result<void> TerrainRenderer::Impl::waitForHost(std::uint64_t value) const {
  VkSemaphore semaphore = hostTimeline.get();
  VkSemaphoreWaitInfo wait{};
  wait.sType = VK_STRUCTURE_TYPE_SEMAPHORE_WAIT_INFO;
  wait.semaphoreCount = 1;
  wait.pSemaphores = &semaphore;
  wait.pValues = &value;
  const VkResult r = vkWaitSemaphores(context->device(), &wait, kSubmitTimeoutNanoseconds);
  if (r == VK_TIMEOUT) {
    return makeError(ErrorCode::DeviceError,
                     "a frame drawn into the host's pass was not seen done within 60 s: submit its "
                     "command buffer signalling HostFrame::semaphore with HostFrame::signalValue "
                     "(value " +
                         std::to_string(value) + ")");
  }
  if (r != VK_SUCCESS) return vulkanError(r, "vkWaitSemaphores (host pass)");
  return {};
}

Result<HostFrame> TerrainRenderer::drawInto(VkCommandBuffer cmd, const HostPass& pass,
                                            const Cut& cut, const Camera& camera,
                                            const FrameSettings& settings) {
  Impl& m = *impl_;
  if (!m.pendingOrder.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "drawInto(): collect() the offscreen frames in flight first");
  }
  if (settings.present) {
    return makeError(ErrorCode::InvalidArgument,
                     "drawInto(): the host presents its own pass (FrameSettings::present unset)");
  }
  if (auto damage = m.dataset->damage()) return std::move(*damage);
  if (Result<void> r = m.checkViewport(camera); !r) return std::move(r).error();

  GpuCache::State& c = *m.shared;
  const std::vector<NodeRecord> nodes = m.cutNodes(cut);
  if (planPasses(c, cut, nodes).size() > 1) {
    return makeError(ErrorCode::InvalidArgument,
                     "drawInto(): the cut (" + std::to_string(cut.patches.size()) + " patches, " +
                         std::to_string(cut.tiles.size()) +
                         " tiles) does not fit the GPU cache budget of " +
                         mebibytes(c.lru->budgetBytes()) +
                         " in one pass, and a host's pass is drawn in one: raise the budget");
  }

  // The pipeline for this pass, made once; the timeline the host's submissions signal.
  VkPipeline pipeline = VK_NULL_HANDLE;
  for (const auto& [made, handle] : m.hostPipelines) {
    if (made == pass) pipeline = handle.get();
  }
  if (pipeline == VK_NULL_HANDLE) {
    auto created = c.pipeline.createForHostPass(*m.context, pass);
    if (!created) return std::move(created).error();
    pipeline = created->get();
    m.hostPipelines.emplace_back(pass, std::move(*created));
  }
  if (!m.hostTimeline) {
    VkSemaphoreTypeCreateInfo type{};
    type.sType = VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO;
    type.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
    VkSemaphoreCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    info.pNext = &type;
    VkSemaphore raw = VK_NULL_HANDLE;
    if (VkResult r = vkCreateSemaphore(m.context->device(), &info, nullptr, &raw);
        r != VK_SUCCESS) {
      return vulkanError(r, "vkCreateSemaphore (host pass timeline)");
    }
    m.hostTimeline = UniqueSemaphore(m.context->device(), raw);
  }

  auto taken = m.freeSlot();
  if (!taken) return std::move(taken).error();
  FrameSlot& slot = **taken;
  m.lastFrame.reset();
  HostFrame frame;
  frame.stats = m.frameOpening(cut);
  FrameStats& stats = frame.stats;
  if (Result<void> r = m.prepareSlot(slot, cut, camera, settings); !r) {
    return std::move(r).error();
  }
  const PatchPush push = patchPush(camera, settings, *m.atmosphere, pass.depth);
  const PassInput in{cut,
                     nodes,
                     0,
                     cut.patches.size(),
                     camera,
                     std::as_bytes(std::span(&push, 1)),
                     {true, true, clearColour(settings)}};
  if (Result<void> r = PassDrawer(m, slot, in, stats).drawIntoHost(cmd, pipeline); !r) {
    return std::move(r).error();
  }
  m.frameClosing(stats);
  slot.hostSignal = ++m.hostSignalled;
  m.hostOrder.push_back(m.nextSlot);
  m.nextSlot = (m.nextSlot + 1) % m.slots.size();
  frame.semaphore = m.hostTimeline.get();
  frame.signalValue = slot.hostSignal;
  return frame;
}

}  // namespace pbdam::gpu
