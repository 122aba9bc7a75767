#include "FlyHud.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <utility>

namespace pbdam::tools {
namespace {

constexpr const char* kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf";

}  // namespace

HudPixels drawHud(const std::vector<std::string>& lines, bool bgra, std::uint32_t maxWidth,
                  int fontPixels) {
  HudPixels panel;
  if (lines.empty() || maxWidth == 0) return panel;
  const std::string font = std::filesystem::exists(kFont) ? kFont : "";
  const int lineHeight = fontPixels + fontPixels / 4 + 1;
  const int margin = fontPixels / 2 + 2;
  int widest = 0;
  for (const std::string& line : lines) {
    const OIIO::ROI size = OIIO::ImageBufAlgo::text_size(line, fontPixels, font);
    if (size.defined()) widest = std::max(widest, size.width());
  }
  const int width = std::min(static_cast<int>(maxWidth), widest + 2 * margin);
  const int height = static_cast<int>(lines.size()) * lineHeight + 2 * margin - fontPixels / 4;
  OIIO::ImageBuf buffer(OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8));
  const std::array<float, 4> background = {0.04f, 0.05f, 0.07f, 1.0f};
  const std::array<float, 4> ink = {0.92f, 0.95f, 0.90f, 1.0f};
  OIIO::ImageBufAlgo::fill(buffer, background);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const int baseline = margin + fontPixels + static_cast<int>(i) * lineHeight - 2;
    // A line the font cannot draw is left out; the panel stays.
    (void)OIIO::ImageBufAlgo::render_text(buffer, margin, baseline, lines[i], fontPixels, font,
                                          ink);
  }
  panel.width = static_cast<std::uint32_t>(width);
  panel.height = static_cast<std::uint32_t>(height);
  panel.bytes.resize(std::size_t{panel.width} * panel.height * 4);
  buffer.get_pixels(OIIO::ROI::All(), OIIO::TypeDesc::UINT8, panel.bytes.data());
  if (bgra) {
    for (std::size_t p = 0; p < panel.bytes.size(); p += 4) {
      std::swap(panel.bytes[p], panel.bytes[p + 2]);
    }
  }
  return panel;
}

}  // namespace pbdam::tools
