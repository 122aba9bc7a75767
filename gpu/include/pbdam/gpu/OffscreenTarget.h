// OffscreenTarget: a headless render target — an RGBA8 colour image and a D32_SFLOAT depth
// image (reversed-Z: cleared to 0, nearer is greater) drawn with dynamic rendering — and the
// readback of the colour image into host memory through a staging buffer. A target made with a
// tone map also holds a radiance image (RGBA16F): a frame drawn into it is turned into display
// colour by recordToneMap(), and its linear radiance can be read back too (EXR).
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/RgbaImage.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace pbdam::gpu {

class VulkanContext;
class ToneMapPass;

/// Where a frame is also shown (pbdam fly): an acquired swapchain image (Swapchain.h), the
/// semaphores of its acquisition and presentation, and an optional panel copied over it (the
/// heads-up display; not part of the frame's read-back pixels).
struct PresentTarget final {
  VkImage image = VK_NULL_HANDLE;  ///< the acquired swapchain image
  VkExtent2D extent{};             ///< its size in pixels
  /// Binary semaphores: waited for before the copy; signalled when the image is written.
  /// @{
  VkSemaphore acquired = VK_NULL_HANDLE;
  VkSemaphore rendered = VK_NULL_HANDLE;
  /// @}
  /// Tightly packed pixels in the swapchain image's format, copied to `overlayOffset` (clipped
  /// to the image); VK_NULL_HANDLE: none. The buffer must stay unchanged until the frame that
  /// reads it has been collected.
  VkBuffer overlay = VK_NULL_HANDLE;
  VkOffset2D overlayOffset{};  ///< where the panel's top-left pixel goes in the image
  VkExtent2D overlayExtent{};  ///< the panel's size in pixels
};

/// Colour + depth attachments of a fixed size plus a host-visible staging buffer for readback.
/// Move-only; a moved-from target is empty. Must be destroyed before its VulkanContext, and
/// not while a submitted command buffer that uses it is still executing.
///
/// Use: record recordBeginRendering(), draw, recordEndRenderingAndReadback() into one command
/// buffer, submit and wait, then readPixels(); or call render(), which does all of that.
/// Thread-safety: none; one thread records and reads back at a time.
class OffscreenTarget final {
 public:
  /// The colour attachment's format (what readPixels() returns).
  static constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
  /// The depth attachment's format.
  static constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
  /// The radiance image's format (frames that keep radiance for a later tone map).
  static constexpr VkFormat kRadianceFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  /// The reversed-Z depth clear value: the far plane.
  static constexpr float kFarDepth = 0.0f;

  /// Creates the images and the staging buffer; with `toneMap` (which must outlive the target)
  /// also the radiance image, its staging buffer and the tone map's descriptor set. Errors:
  /// InvalidArgument for a zero or too-large size, DeviceError for Vulkan failures.
  static formats::Result<OffscreenTarget> create(const VulkanContext& context, uint32_t widthPixels,
                                                 uint32_t heightPixels,
                                                 const ToneMapPass* toneMap = nullptr);

  OffscreenTarget() noexcept = default;
  /// Takes over another target, leaving it empty.
  /// @{
  OffscreenTarget(OffscreenTarget&&) noexcept = default;
  OffscreenTarget& operator=(OffscreenTarget&&) noexcept = default;
  /// @}
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;
  ~OffscreenTarget() = default;

  /// The attachments' size.
  /// @{
  uint32_t widthPixels() const noexcept { return color_.desc().widthPixels; }
  uint32_t heightPixels() const noexcept { return color_.desc().heightPixels; }
  VkExtent2D extent() const noexcept { return color_.extent(); }
  /// @}
  /// The colour attachment (kColorFormat).
  const GpuImage& colorImage() const noexcept { return color_; }
  /// The depth attachment (kDepthFormat, reversed Z).
  const GpuImage& depthImage() const noexcept { return depth_; }
  /// Whether it holds a radiance image (made with a tone map).
  bool keepsRadiance() const noexcept { return static_cast<bool>(radiance_); }

  /// Records: both images to attachment layouts (previous contents discarded), begin dynamic
  /// rendering clearing colour to `clearRgba` (linear 0..1) and depth to `clearDepth`, and a
  /// viewport and scissor covering the whole target (y down, depth range 0..1). With
  /// `keepDepth` the depth image is stored at the end of the pass, so that a later
  /// recordResumeRendering() continues with it; otherwise it is discarded.
  /// With `radiance` (keepsRadiance() only) the pass draws into the radiance image instead.
  void recordBeginRendering(VkCommandBuffer cmd, const std::array<float, 4>& clearRgba,
                            float clearDepth = kFarDepth, bool keepDepth = false,
                            bool radiance = false) const;

  /// Records: begin dynamic rendering again on the contents a previous pass left (colour, and
  /// depth if that pass was begun or resumed with `keepDepth`), after a barrier ordering it
  /// after that pass; viewport and scissor as recordBeginRendering. The previous pass must
  /// have ended (vkCmdEndRendering), in this command buffer or an earlier submission.
  void recordResumeRendering(VkCommandBuffer cmd, bool keepDepth, bool radiance = false) const;

  /// Records, after the last pass into the radiance image has ended: the radiance turned into
  /// display colour in the colour image (radiance × `exposure` through the tone curve,
  /// tone.glsl), which is then as a pass drawn into it would have left it (readback, present).
  void recordToneMap(VkCommandBuffer cmd, float exposure) const;

  /// Records, after recordToneMap(): the radiance image's copy into its staging buffer, made
  /// visible to host reads (readRadiance()).
  void recordRadianceReadback(VkCommandBuffer cmd) const;

  /// The radiance image's pixels as linear RGB floats (width · height · 3, rows top-down).
  /// Valid once the work recorded by recordRadianceReadback has completed.
  formats::Result<std::vector<float>> readRadiance() const;

  /// Records: end rendering, the colour image to TRANSFER_SRC, its copy into the staging
  /// buffer, and a barrier that makes the copy visible to host reads.
  void recordEndRenderingAndReadback(VkCommandBuffer cmd) const;

  /// Records the readback part of recordEndRenderingAndReadback, for a pass that the caller
  /// has already ended with vkCmdEndRendering.
  void recordReadback(VkCommandBuffer cmd) const;

  /// Records, after the pass has ended (and after recordReadback when `afterReadback`): the
  /// colour image copied into `present`'s image (a swapchain image, any previous contents
  /// discarded) by a blit, scaled where the sizes differ; then `present`'s overlay copied over
  /// it, and the image left in PRESENT_SRC_KHR. The submission must wait for `present.acquired`
  /// at the blit stage (VK_PIPELINE_STAGE_2_BLIT_BIT).
  void recordPresent(VkCommandBuffer cmd, const struct PresentTarget& present,
                     bool afterReadback) const;

  /// The staging buffer's pixels. Valid once the work recorded by recordEndRenderingAndReadback
  /// has completed (its fence signalled).
  formats::Result<RgbaImage> readPixels() const;

  /// Convenience: records begin, `draw(cmd)`, end + readback; submits with
  /// context.submitAndWait() and returns the pixels.
  formats::Result<RgbaImage> render(VulkanContext& context, const std::array<float, 4>& clearRgba,
                                    const std::function<void(VkCommandBuffer)>& draw) const;

 private:
  void beginRendering(VkCommandBuffer cmd, VkAttachmentLoadOp loadOp,
                      const std::array<float, 4>& clearRgba, float clearDepth, bool keepDepth,
                      bool radiance) const;
  formats::Result<void> createRadiance(const VulkanContext& context, const ToneMapPass& toneMap);

  GpuImage color_;
  GpuImage depth_;
  GpuBuffer staging_;
  // With a tone map: the radiance image, its staging buffer, the tone map and its set.
  GpuImage radiance_;
  GpuBuffer radianceStaging_;
  const ToneMapPass* toneMap_ = nullptr;
  UniqueDescriptorPool toneMapPool_;
  VkDescriptorSet toneMapSet_ = VK_NULL_HANDLE;
};

}  // namespace pbdam::gpu
