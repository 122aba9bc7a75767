// RgbaImage: 8-bit RGBA pixels read back from the GPU, rows top to bottom (Vulkan framebuffer
// order), tightly packed. What frame export (PNG) and image tests consume.
#pragma once

#include <array>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pbdam::gpu {

/// A tightly packed RGBA8 image; pixel (x, y) starts at byte 4·(y·widthPixels + x), y = 0 is
/// the top row. A plain value.
struct RgbaImage final {
  uint32_t widthPixels = 0;   ///< pixels a row
  uint32_t heightPixels = 0;  ///< rows
  std::vector<uint8_t> rgba;  ///< 4·widthPixels·heightPixels bytes

  /// The RGBA bytes of pixel (x, y); x must be < widthPixels and y < heightPixels.
  std::array<uint8_t, 4> pixel(uint32_t x, uint32_t y) const noexcept {
    assert(x < widthPixels && y < heightPixels);
    const std::size_t i = 4 * (static_cast<std::size_t>(y) * widthPixels + x);
    return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
  }
};

}  // namespace pbdam::gpu
