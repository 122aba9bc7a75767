// StagingUploader (internal to pbdam_gpu): the host-visible staging buffer a renderer decodes its
// misses into (DecodeScheduler) and the copies from it into the GPU cache's pools
// (docs/architecture.md "Streaming"). A buffer too small for a pass is replaced by a larger one;
// the old one is retired to the renderer's DeferredDestruction with the last submission that may
// read it. Thread-safety: none (the render thread).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>

#include "DeferredDestruction.h"
#include "GpuPools.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/streaming/DecodeScheduler.h"

namespace pbdam::gpu {

class VulkanContext;

class StagingUploader final {
 public:
  StagingUploader() = default;

  /// Makes the buffer hold at least `bytes` (a no-op for 0 or when it does): a new buffer of
  /// max(bytes, twice the old size, 4 MiB); the old one goes to `garbage` until submission
  /// `lastUse` has completed.
  formats::Result<void> ensure(const VulkanContext& context, std::uint64_t bytes,
                               DeferredDestruction& garbage, std::uint64_t lastUse);

  /// The mapped bytes to decode into (empty before the first ensure() with bytes > 0).
  std::span<std::byte> mappedBytes() const noexcept { return staging_.mappedBytes(); }
  /// Makes host writes visible to the device (non-coherent memory).
  formats::Result<void> flush() const;

  /// Records the copies of `jobs` (laid out in the staging buffer; `slots[j]` is job j's pool
  /// slot) into `patches` and `tiles`, with the barriers around them: earlier draws' reads of
  /// the overwritten regions before, vertex/index/sampled reads after.
  void record(VkCommandBuffer cmd, std::span<const streaming::DecodeJob> jobs,
              std::span<const std::uint32_t> slots, const PatchPool& patches,
              const TilePool& tiles) const;

 private:
  GpuBuffer staging_;
};

}  // namespace pbdam::gpu
