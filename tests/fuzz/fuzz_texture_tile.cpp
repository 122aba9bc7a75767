// libFuzzer target for the texture-tile decoder (TextureTile.h): decodeTextureTile on arbitrary
// bytes; an accepted tile must have exactly the data its size and format need, expand (a colour
// tile, RGBA8 or BC1, with expandToRgba8; a normal-map tile, RG8 or BC5, with expandToRg8), and
// encode again to bytes that decode to the same tile. Each input is also tried with its CRC made
// right. Seeds (tests/fuzz/corpus/texture_tile): RGBA8 and BC1 tiles of a small MOLA build, and
// 16² RG8 and BC5 tiles (border 1) of a smooth two-channel field.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/TextureTile.h"

namespace {

using namespace pbdam::formats;

void check(std::span<const std::byte> bytes) {
  auto tile = decodeTextureTile(bytes, "fuzz");
  if (!tile) return;
  if (tile->data.size() != textureTileDataBytes(tile->sizeTexels, tile->format)) __builtin_trap();
  const bool colour = tile->format == TexelFormat::Rgba8 || tile->format == TexelFormat::Bc1;
  if (!(colour ? expandToRgba8(*tile) : expandToRg8(*tile))) __builtin_trap();
  auto again = encodeTextureTile(*tile);
  if (!again) __builtin_trap();
  auto back = decodeTextureTile(*again, "fuzz re-encoded");
  if (!back || !(*back == *tile)) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto bytes = std::as_bytes(std::span<const std::uint8_t>(data, size));
  check(bytes);
  // Again with the header's CRC-32 (bytes 20..23, over the other header bytes and the payload)
  // made right, so that mutations reach the checks behind it, as a tile written by a buggy or
  // hostile encoder would.
  constexpr std::size_t kHeaderBytes = 24;
  constexpr std::size_t kCrcOffset = 20;
  if (size < kHeaderBytes) return 0;
  std::vector<std::byte> fixed(bytes.begin(), bytes.end());
  std::uint32_t crc = crc32(std::span<const std::byte>(fixed).first(kCrcOffset));
  crc = crc32(std::span<const std::byte>(fixed).subspan(kHeaderBytes), crc);
  std::memcpy(fixed.data() + kCrcOffset, &crc, 4);
  check(fixed);
  return 0;
}
