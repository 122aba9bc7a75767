// libFuzzer target for the texture-tile decoder (TextureTile.h): decodeTextureTile on arbitrary
// bytes; an accepted tile must have exactly the data its size and format need, expand to RGBA8,
// and encode again to bytes that decode to the same tile. Seeds: RGBA8 and BC1 tiles of a
// small MOLA build (tests/fuzz/corpus/texture_tile).
#include <cstddef>
#include <cstdint>
#include <span>

#include "pbdam/formats/TextureTile.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pbdam::formats;
  const auto bytes = std::as_bytes(std::span<const std::uint8_t>(data, size));
  auto tile = decodeTextureTile(bytes, "fuzz");
  if (!tile) return 0;
  if (tile->data.size() != textureTileDataBytes(tile->sizeTexels, tile->format)) __builtin_trap();
  if (!expandToRgba8(*tile)) __builtin_trap();
  auto again = encodeTextureTile(*tile);
  if (!again) __builtin_trap();
  auto back = decodeTextureTile(*again, "fuzz re-encoded");
  if (!back || !(*back == *tile)) __builtin_trap();
  return 0;
}
