// Swapchain: the images a window shows, made from the VulkanContext's surface (pbdam fly). A
// frame is drawn offscreen as always (TerrainRenderer) and copied into an acquired image by the
// frame's own submission (PresentTarget), so that what a window shows is the image `pbdam render`
// reads back for the same camera.
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

namespace pbdam::gpu {

class VulkanContext;

/// How presented images reach the screen: FIFO waits for the display's refresh (never tears, the
/// default); mailbox replaces a waiting image with a newer one; immediate shows at once (may
/// tear). The last two are for measuring the frame loop without the refresh's cap.
enum class PresentMode { Fifo, Mailbox, Immediate };

/// "fifo", "mailbox" or "immediate"; nullopt for anything else.
std::optional<PresentMode> parsePresentMode(std::string_view text);
/// "fifo", "mailbox" or "immediate": what parsePresentMode reads.
const char* toString(PresentMode mode) noexcept;

/// One acquired image: where a frame is copied to (TerrainRenderer's PresentTarget) and what to
/// hand back to present().
struct AcquiredImage final {
  VkImage image = VK_NULL_HANDLE;         ///< the swapchain's image
  VkExtent2D extent{};                    ///< its size in pixels
  VkFormat format = VK_FORMAT_UNDEFINED;  ///< its format
  std::uint32_t index = 0;                ///< its index in the swapchain
  /// Signalled when the image may be written (the semaphore acquire() was given).
  VkSemaphore acquired = VK_NULL_HANDLE;
  /// To be signalled by the submission that writes the image; present() waits for it.
  VkSemaphore rendered = VK_NULL_HANDLE;
};

/// The swapchain of the context's surface. Move-only. Recreate it when acquire() or present()
/// says it is out of date and when the window's size changes. Must be destroyed before the
/// context. Thread-safety: none; the window's thread uses it.
class Swapchain final {
 public:
  /// Creates a swapchain of about `width` x `height` (the surface may dictate its own size) with
  /// `mode` where the surface offers it, else FIFO (mode() says which). Images are RGBA8 or
  /// BGRA8 UNORM, written by transfer (blit). Errors: InvalidArgument for a context without a
  /// surface or a zero size; DeviceError when the surface offers no usable format or usage.
  static formats::Result<Swapchain> create(VulkanContext& context, std::uint32_t width,
                                           std::uint32_t height, PresentMode mode);

  Swapchain() noexcept = default;
  /// Takes over another swapchain, leaving it empty.
  /// @{
  Swapchain(Swapchain&&) noexcept = default;
  Swapchain& operator=(Swapchain&&) noexcept = default;
  /// @}
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;
  ~Swapchain() = default;

  /// Waits for the device to be idle and makes a new swapchain of about `width` x `height`
  /// from the old one (the mode kept).
  formats::Result<void> recreate(std::uint32_t width, std::uint32_t height);

  /// Acquires the next image, to be signalled through `acquired` (a binary semaphore the caller
  /// does not reuse until the submission that waited for it has completed). nullopt: out of
  /// date (recreate, then acquire again). Waits at most `timeoutNanoseconds`.
  formats::Result<std::optional<AcquiredImage>> acquire(
      VkSemaphore acquired, std::uint64_t timeoutNanoseconds = 5'000'000'000ull);

  /// Presents an image whose frame was submitted to signal its `rendered` semaphore. False
  /// when the swapchain is out of date or suboptimal (recreate before the next acquire).
  formats::Result<bool> present(const AcquiredImage& image);

  /// The images' size in pixels (the surface's, near what was asked).
  VkExtent2D extent() const noexcept { return extent_; }
  /// The images' format.
  VkFormat format() const noexcept { return format_; }
  /// How images are presented.
  PresentMode mode() const noexcept { return mode_; }
  /// The swapchain's images.
  std::size_t imageCount() const noexcept { return images_.size(); }

 private:
  formats::Result<void> build(std::uint32_t width, std::uint32_t height);

  VulkanContext* context_ = nullptr;
  PresentMode mode_ = PresentMode::Fifo;
  PresentMode wanted_ = PresentMode::Fifo;
  VkExtent2D extent_{};
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  UniqueSwapchain swapchain_;
  std::vector<VkImage> images_;
  std::vector<UniqueSemaphore> rendered_;  // one per image
};

}  // namespace pbdam::gpu
