// The terrain object a host drives (gpu/Terrain.h), on lavapipe with the validation layer: its
// offscreen frames along a Mars flight are TerrainRenderer::render()'s of refine()'s cuts, with
// two frames in flight; drawn into a host's own pass (its command buffer, its submission signalling
// the terrain's timeline) a frame is the offscreen frame byte for byte, frame after frame through
// the slots; no-stall mode draws capped cuts that rise by at most one diamond level a frame with
// its prefetcher running; and bad options and misuse are refused with messages that name them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/Terrain.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/gpu/UniqueHandle.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using pbdam::gpu::test::cameraAt;
using pbdam::gpu::test::openDataset;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kWidth = 320;
constexpr std::uint32_t kHeight = 240;

std::vector<CameraPose> flightPoses(std::size_t frames) { return test::tharsisDescent(frames); }

TerrainOptions smallFrames() {
  TerrainOptions options;
  options.viewport = Viewport{kWidth, kHeight, 60.0};
  return options;
}

/// A host's own command buffer and fence: records `draw` inside the target's rendering (cleared
/// as the renderer clears), submits through the context signalling `frame`'s timeline value,
/// waits, and reads the pixels back.
class HostCommands {
 public:
  explicit HostCommands(VulkanContext& context) : context_(&context) {
    VkDevice device = context.device();
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = context.queueFamilyIndex();
    VkCommandPool pool = VK_NULL_HANDLE;
    EXPECT_EQ(vkCreateCommandPool(device, &poolInfo, nullptr, &pool), VK_SUCCESS);
    pool_ = UniqueCommandPool(device, pool);
    VkCommandBufferAllocateInfo allocate{};
    allocate.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    allocate.commandPool = pool;
    allocate.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    allocate.commandBufferCount = 1;
    EXPECT_EQ(vkAllocateCommandBuffers(device, &allocate, &cmd_), VK_SUCCESS);
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence = VK_NULL_HANDLE;
    EXPECT_EQ(vkCreateFence(device, &fenceInfo, nullptr, &fence), VK_SUCCESS);
    fence_ = UniqueFence(device, fence);
  }

  Result<RgbaImage> frame(Terrain& terrain, const OffscreenTarget& target, const HostPass& pass) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    EXPECT_EQ(vkBeginCommandBuffer(cmd_, &begin), VK_SUCCESS);
    target.recordBeginRendering(cmd_, {0.0f, 0.0f, 0.0f, 1.0f}, farDepth(pass.depth));
    auto drawn = terrain.drawInto(cmd_, pass);
    target.recordEndRenderingAndReadback(cmd_);
    EXPECT_EQ(vkEndCommandBuffer(cmd_), VK_SUCCESS);
    if (!drawn) return drawn.error();
    VkCommandBufferSubmitInfo buffer{};
    buffer.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO;
    buffer.commandBuffer = cmd_;
    VkSemaphoreSubmitInfo signal{};
    signal.sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO;
    signal.semaphore = drawn->semaphore;
    signal.value = drawn->signalValue;
    signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    VkSubmitInfo2 submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2;
    submit.commandBufferInfoCount = 1;
    submit.pCommandBufferInfos = &buffer;
    submit.signalSemaphoreInfoCount = 1;
    submit.pSignalSemaphoreInfos = &signal;
    VkFence fence = fence_.get();
    EXPECT_EQ(vkResetFences(context_->device(), 1, &fence), VK_SUCCESS);
    if (auto r = context_->submit(submit, fence, "host frame"); !r) return r.error();
    EXPECT_EQ(vkWaitForFences(context_->device(), 1, &fence, VK_TRUE, UINT64_MAX), VK_SUCCESS);
    return target.readPixels();
  }

 private:
  VulkanContext* context_;
  UniqueCommandPool pool_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  UniqueFence fence_;
};

class TerrainTest : public test::GpuTest {};

TEST_F(TerrainTest, OffscreenFramesAreTheRenderersFramesOfRefinedCuts) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  TerrainOptions options = smallFrames();
  options.framesInFlight = 2;
  auto terrain = Terrain::open(context(), dir, options);
  ASSERT_TRUE(terrain) << terrain.error().message;
  Terrain& t = **terrain;
  const DatasetView& view = t.view();
  TerrainRendererOptions rendererOptions;
  rendererOptions.widthPixels = kWidth;
  rendererOptions.heightPixels = kHeight;
  auto reference = TerrainRenderer::create(context(), view, rendererOptions);
  ASSERT_TRUE(reference) << reference.error().message;

  const std::vector<CameraPose> poses = flightPoses(6);
  std::vector<RgbaImage> expected;
  for (const CameraPose& pose : poses) {
    const Camera camera = cameraAt(view, pose, kWidth, kHeight);
    auto frame = reference->render(refine(view, camera, options.refinement), camera);
    ASSERT_TRUE(frame) << frame.error().message;
    expected.push_back(std::move(frame->image));
  }
  std::size_t collected = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Camera camera = cameraAt(view, poses[k], kWidth, kHeight);
    auto update = t.update(camera);
    ASSERT_TRUE(update) << update.error().message;
    EXPECT_EQ((*update)->levelCap, -1);
    EXPECT_GT((*update)->cut.patches.size(), 0u);
    EXPECT_EQ(t.origin(), camera.position());
    ASSERT_TRUE(t.submit());
    if (k >= 1) {
      auto frame = t.collect();
      ASSERT_TRUE(frame) << frame.error().message;
      EXPECT_EQ(frame->image.rgba, expected[collected].rgba) << "frame " << collected;
      ++collected;
    }
  }
  auto last = t.collect();
  ASSERT_TRUE(last) << last.error().message;
  EXPECT_EQ(last->image.rgba, expected.back().rgba);
}

TEST_F(TerrainTest, AFrameDrawnIntoTheHostsPassIsTheOffscreenFrame) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  TerrainOptions options = smallFrames();
  options.framesInFlight = 2;
  auto terrain = Terrain::open(context(), dir, options);
  ASSERT_TRUE(terrain) << terrain.error().message;
  Terrain& t = **terrain;
  auto target = OffscreenTarget::create(context(), kWidth, kHeight);
  ASSERT_TRUE(target) << target.error().message;
  HostCommands host(context());
  HostPass pass;  // the target's formats, dynamic rendering, reversed Z
  // More frames than slots: each reuses a slot whose earlier host frame has signalled.
  for (const CameraPose& pose : flightPoses(5)) {
    const Camera camera = cameraAt(t.view(), pose, kWidth, kHeight);
    ASSERT_TRUE(t.update(camera));
    ASSERT_TRUE(t.submit());
    auto offscreen = t.collect();
    ASSERT_TRUE(offscreen) << offscreen.error().message;
    auto hosted = host.frame(t, *target, pass);
    ASSERT_TRUE(hosted) << hosted.error().message;
    EXPECT_EQ(hosted->rgba, offscreen->image.rgba) << test::describe(pose);
  }
  // The other depth convention draws the terrain too (its depth is coarser far away, so only
  // that the frame is not the clear colour is asserted).
  pass.depth = DepthConvention::ZeroNearOneFar;
  auto hosted = host.frame(t, *target, pass);
  ASSERT_TRUE(hosted) << hosted.error().message;
  const std::size_t black = static_cast<std::size_t>(
      std::count(hosted->rgba.begin(), hosted->rgba.end(), std::uint8_t{0}));
  EXPECT_LT(black, hosted->rgba.size() / 2);
}

TEST_F(TerrainTest, NoStallCapsRiseByAtMostOneDiamondLevelAFrame) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  TerrainOptions options = smallFrames();
  options.mode = TerrainMode::NoStall;
  options.prefetch = true;
  auto terrain = Terrain::open(context(), dir, options);
  ASSERT_TRUE(terrain) << terrain.error().message;
  Terrain& t = **terrain;
  ASSERT_NE(t.prefetcher(), nullptr);
  EXPECT_TRUE(t.preloadSkipped().empty());
  int previous = -1;
  double time = 0.0;
  for (const CameraPose& pose : flightPoses(8)) {
    auto update = t.update(cameraAt(t.view(), pose, kWidth, kHeight), time);
    time += 0.1;
    ASSERT_TRUE(update) << update.error().message;
    const int cap = (*update)->levelCap;
    EXPECT_GE(cap, 0);
    if (previous >= 0) {
      EXPECT_LE(cap, previous + 2);
    }
    previous = cap;
    ASSERT_TRUE(t.submit());
    auto frame = t.collect();
    ASSERT_TRUE(frame) << frame.error().message;
    EXPECT_EQ(frame->stats.patches, (*update)->cut.patches.size());
  }
  t.stopPrefetcher();
}

TEST_F(TerrainTest, BadOptionsAndMisuseAreRefusedByName) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const auto refusal = [&](TerrainOptions options) {
    auto terrain = Terrain::open(context(), dir, std::move(options));
    EXPECT_FALSE(terrain);
    return terrain ? std::string() : terrain.error().message;
  };
  TerrainOptions bad = smallFrames();
  bad.refinement.tolerancePixels = 0.0;
  EXPECT_NE(refusal(bad).find("tolerance"), std::string::npos);
  bad = smallFrames();
  bad.framesInFlight = 0;
  EXPECT_NE(refusal(bad).find("frames in flight"), std::string::npos);
  bad = smallFrames();
  bad.prefetch = true;
  EXPECT_NE(refusal(bad).find("prefetch"), std::string::npos);
  bad = smallFrames();
  bad.mode = TerrainMode::Paging;
  bad.prefetch = true;
  bad.lookaheadSeconds = -1.0;
  EXPECT_NE(refusal(bad).find("look-ahead"), std::string::npos);
  EXPECT_FALSE(Terrain::open(context(), dir.parent_path() / "no-such-dataset", smallFrames()));

  // The smallest cache draws a cut offscreen in passes; a host's pass cannot be split.
  TerrainOptions tiny = smallFrames();
  tiny.gpuCacheBytes = TerrainRenderer::minimumCacheBytes(context(), openDataset(dir)->view());
  auto terrain = Terrain::open(context(), dir, tiny);
  ASSERT_TRUE(terrain) << terrain.error().message;
  Terrain& t = **terrain;
  auto early = t.submit();
  ASSERT_FALSE(early);
  EXPECT_NE(early.error().message.find("update()"), std::string::npos);
  auto wrongSize = t.update(cameraAt(t.view(), flightPoses(2)[0], kWidth + 1, kHeight));
  ASSERT_FALSE(wrongSize);
  EXPECT_NE(wrongSize.error().message.find("321 x 240"), std::string::npos);
  ASSERT_TRUE(t.update(cameraAt(t.view(), flightPoses(2)[0], kWidth, kHeight)));
  auto target = OffscreenTarget::create(context(), kWidth, kHeight);
  ASSERT_TRUE(target) << target.error().message;
  HostCommands host(context());
  auto split = host.frame(t, *target, HostPass{});
  ASSERT_FALSE(split);
  EXPECT_NE(split.error().message.find("in one pass"), std::string::npos) << split.error().message;
  ASSERT_TRUE(t.submit());  // offscreen, in passes
  auto frame = t.collect();
  ASSERT_TRUE(frame) << frame.error().message;
  EXPECT_GT(frame->stats.passes, 1u);
}

// A terrain's exaggeration is checked at open and fixed for its life (its GPU cache's patches
// were decoded under it): out of (0, 100] is refused by name, and so is another one later.
TEST_F(TerrainTest, ExaggerationIsCheckedAndFixedAtOpen) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  for (const double bad : {0.0, -1.0, 101.0, std::numeric_limits<double>::quiet_NaN()}) {
    TerrainOptions options = smallFrames();
    options.refinement.exaggeration = bad;
    auto terrain = Terrain::open(context(), dir, options);
    ASSERT_FALSE(terrain) << bad;
    EXPECT_EQ(terrain.error().code, formats::ErrorCode::InvalidArgument);
    EXPECT_NE(terrain.error().message.find("exaggeration"), std::string::npos);
  }
  TerrainOptions options = smallFrames();
  options.refinement.exaggeration = 2.0;
  auto terrain = Terrain::open(context(), dir, options);
  ASSERT_TRUE(terrain) << terrain.error().message;
  runtime::RefinementOptions refinement = options.refinement;
  refinement.tolerancePixels = 5.0;
  EXPECT_TRUE((*terrain)->setRefinement(refinement));
  refinement.exaggeration = 1.0;
  auto changed = (*terrain)->setRefinement(refinement);
  ASSERT_FALSE(changed);
  EXPECT_NE(changed.error().message.find("exaggeration"), std::string::npos);
}

}  // namespace
}  // namespace pbdam::gpu
