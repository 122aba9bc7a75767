#include "FlyHud.h"

#include <filesystem>
#include <utility>

#include "pbdam/formats/ImageCodec.h"

namespace pbdam::tools {
namespace {

constexpr const char* kFont = "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf";

}  // namespace

HudPixels drawHud(const std::vector<std::string>& lines, bool bgra, std::uint32_t maxWidth,
                  int fontPixels) {
  HudPixels panel;
  if (lines.empty() || maxWidth == 0) return panel;
  const formats::Result<const formats::ImageCodec*> codec = formats::imageCodec();
  // Without the module there is no text to draw; the frame still shows.
  if (!codec) return panel;
  const std::string font = std::filesystem::exists(kFont) ? kFont : "";
  formats::Pixels8 drawn = (*codec)->drawText(lines, font, maxWidth, fontPixels);
  panel.width = static_cast<std::uint32_t>(drawn.width);
  panel.height = static_cast<std::uint32_t>(drawn.height);
  panel.bytes = std::move(drawn.bytes);
  if (bgra) {
    for (std::size_t p = 0; p < panel.bytes.size(); p += 4) {
      std::swap(panel.bytes[p], panel.bytes[p + 2]);
    }
  }
  return panel;
}

}  // namespace pbdam::tools
