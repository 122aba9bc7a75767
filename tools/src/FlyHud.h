// The heads-up display of `pbdam fly`: lines of text drawn by OpenImageIO (FreeType, DejaVu Sans
// Mono) onto an opaque dark panel, in the byte order of the window's images, which the frame's
// submission copies over the top-left corner of the shown image (gpu::PresentTarget). It is not
// part of the frame's pixels: screenshots and `pbdam render` never contain it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace pbdam::tools {

/// A panel's pixels: 4 bytes a pixel, rows top to bottom, tightly packed.
struct HudPixels final {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> bytes;
};

/// Draws `lines` at `fontPixels` onto a panel just large enough for them (at most `maxWidth`
/// pixels wide; longer lines are cut), in BGRA order when `bgra`, else RGBA. An empty list gives
/// an empty panel. Without the font file the text is drawn with OpenImageIO's default font.
HudPixels drawHud(const std::vector<std::string>& lines, bool bgra, std::uint32_t maxWidth,
                  int fontPixels = 14);

}  // namespace pbdam::tools
