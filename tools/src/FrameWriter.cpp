// Frames written on worker threads (FrameWriter.h).
#include "FrameWriter.h"

#include <algorithm>
#include <utility>

#include "FrameImage.h"

using namespace pbdam::formats;

namespace pbdam::tools {

FrameWriter::FrameWriter(std::size_t maxOutstanding)
    : maxOutstanding_(std::max<std::size_t>(1, maxOutstanding)) {}

FrameWriter::~FrameWriter() {
  for (auto& write : running_) write.wait();
}

Result<void> FrameWriter::waitOldest() {
  Result<void> result = running_.front().get();
  running_.pop_front();
  return result;
}

Result<void> FrameWriter::write(std::filesystem::path path, gpu::RgbaImage image,
                                std::vector<float> radiance, float exposure) {
  while (running_.size() >= maxOutstanding_) {
    if (Result<void> r = waitOldest(); !r) return r;
  }
  running_.push_back(std::async(std::launch::async, [path = std::move(path),
                                                     image = std::move(image),
                                                     radiance = std::move(radiance), exposure] {
    if (!radiance.empty() && isExrPath(path)) {
      return writeFrameRadiance(path, image.widthPixels, image.heightPixels, radiance, exposure);
    }
    return writeFrameImage(path, image);
  }));
  return {};
}

Result<void> FrameWriter::finish() {
  Result<void> first;
  while (!running_.empty()) {
    Result<void> r = waitOldest();
    if (!r && first) first = std::move(r);
  }
  return first;
}

}  // namespace pbdam::tools
