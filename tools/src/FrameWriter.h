// FrameWriter: `pbdam render --path` encodes and writes its frames on worker threads, so the
// render thread goes on with the next frame while earlier ones are compressed (PNG level 1 costs
// about as much as drawing a 720p frame on lavapipe). At most `maxOutstanding` frames are being
// written at once: write() waits for the oldest beyond that. Thread-safety: one thread calls it;
// each write runs writeFrameImage or writeFrameRadiance (FrameImage.h) on its own copy of the
// pixels.
#pragma once

#include <cstddef>
#include <deque>
#include <filesystem>
#include <future>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/RgbaImage.h"

namespace pbdam::tools {

class FrameWriter final {
 public:
  /// `maxOutstanding` ≥ 1 frames written at once (0 counts as 1).
  explicit FrameWriter(std::size_t maxOutstanding);
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;
  /// Waits for every write still running (their errors are dropped: call finish() first).
  ~FrameWriter();

  /// Starts writing `image` to `path` (or, for an EXR path, the frame's linear `radiance` when
  /// it has one: writeFrameRadiance with `exposure`). When maxOutstanding writes are running,
  /// first waits for the oldest and returns its error, if it failed (this frame is then not
  /// started).
  formats::Result<void> write(std::filesystem::path path, gpu::RgbaImage image,
                              std::vector<float> radiance = {}, float exposure = 0.0f);
  /// Waits for every write; the first error in the order the frames were given.
  formats::Result<void> finish();

 private:
  formats::Result<void> waitOldest();

  std::size_t maxOutstanding_;
  std::deque<std::future<formats::Result<void>>> running_;
};

}  // namespace pbdam::tools
