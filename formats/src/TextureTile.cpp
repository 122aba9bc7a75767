// Texture tile codec, BC1 and BC5 compression (TextureTile.h; byte layout in
// formats/TextureTile.md; [P-BDAM 2003] §5: textures stored as DXT1 = BC1). LZO1X through
// liblzo2, BC1 and BC5 through libsquish, one block at a time so nothing here starts threads.
#include "pbdam/formats/TextureTile.h"

#include <lzo/lzo1x.h>
#include <squish.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

#include "ByteOrder.h"
#include "Lzo.h"
#include "pbdam/formats/Checksum.h"

namespace pbdam::formats {
namespace {

constexpr std::array<std::uint8_t, 4> kMagic{'P', 'B', 'T', 'X'};
constexpr std::uint16_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 24;
constexpr std::size_t kCrcOffset = 20;

// Payload compression codes (header byte 7).
constexpr std::uint8_t kStored = 0;
constexpr std::uint8_t kLzo1x = 1;

bool validFormat(std::uint8_t format) noexcept {
  return format == static_cast<std::uint8_t>(TexelFormat::Rgba8) ||
         format == static_cast<std::uint8_t>(TexelFormat::Bc1) ||
         format == static_cast<std::uint8_t>(TexelFormat::Bc5) ||
         format == static_cast<std::uint8_t>(TexelFormat::Rg8);
}

const char* formatName(TexelFormat format) noexcept {
  switch (format) {
    case TexelFormat::Rgba8:
      return "rgba8";
    case TexelFormat::Bc1:
      return "bc1";
    case TexelFormat::Bc5:
      return "bc5";
    case TexelFormat::Rg8:
      return "rg8";
  }
  return "unknown";
}

bool isBlockFormat(TexelFormat format) noexcept {
  return format == TexelFormat::Bc1 || format == TexelFormat::Bc5;
}

// Bytes of one 4×4 block (block formats) or of one texel (the others).
std::size_t unitBytes(TexelFormat format) noexcept {
  switch (format) {
    case TexelFormat::Rgba8:
      return 4;
    case TexelFormat::Bc1:
      return 8;
    case TexelFormat::Bc5:
      return 16;
    case TexelFormat::Rg8:
      return 2;
  }
  return 0;
}

constexpr std::size_t kBc4BlockBytes = 8;

Error corrupt(std::string_view context, const std::string& what) {
  return makeError(ErrorCode::CorruptData, std::string(context) + ": " + what);
}

// Checks size, border and data length of an in-memory tile; empty string when consistent.
std::string describeInconsistency(const TextureTileImage& tile) {
  const std::size_t expected = textureTileDataBytes(tile.sizeTexels, tile.format);
  if (expected == 0) {
    return "invalid size " + std::to_string(tile.sizeTexels) + " for " + formatName(tile.format) +
           " (1.." + std::to_string(kMaxTextureTileTexels) +
           (isBlockFormat(tile.format) ? ", a multiple of 4)" : ")");
  }
  if (2ull * tile.borderTexels >= tile.sizeTexels) {
    return "border " + std::to_string(tile.borderTexels) + " leaves no inner texels of " +
           std::to_string(tile.sizeTexels);
  }
  if (tile.data.size() != expected) {
    return "data holds " + std::to_string(tile.data.size()) + " bytes, a " +
           std::to_string(tile.sizeTexels) + "² " + formatName(tile.format) + " tile needs " +
           std::to_string(expected);
  }
  return {};
}

// A tile of `like`'s size and border in `format`, its texels zero: what a conversion fills.
TextureTileImage emptyTileLike(const TextureTileImage& like, TexelFormat format) {
  TextureTileImage out;
  out.sizeTexels = like.sizeTexels;
  out.format = format;
  out.borderTexels = like.borderTexels;
  out.data.resize(textureTileDataBytes(like.sizeTexels, format));
  return out;
}

}  // namespace

std::size_t textureTileDataBytes(std::uint32_t sizeTexels, TexelFormat format) noexcept {
  if (sizeTexels == 0 || sizeTexels > kMaxTextureTileTexels) return 0;
  const std::size_t size = sizeTexels;
  if (!isBlockFormat(format)) return size * size * unitBytes(format);
  if (size % 4 != 0) return 0;
  return (size / 4) * (size / 4) * unitBytes(format);
}

Result<std::vector<std::byte>> encodeTextureTile(const TextureTileImage& tile) {
  if (const std::string problem = describeInconsistency(tile); !problem.empty()) {
    return invalidArgument("texture tile: " + problem);
  }
  if (!lzoReady()) return makeError(ErrorCode::Internal, "texture tile: lzo_init failed");

  const std::size_t rawBytes = tile.data.size();
  std::vector<std::byte> blob(kHeaderBytes + lzoWorstCaseBytes(rawBytes));
  // LZO1X-1 wants LZO1X_1_MEM_COMPRESS bytes of aligned scratch; per call keeps this reentrant.
  std::vector<lzo_align_t> work((LZO1X_1_MEM_COMPRESS + sizeof(lzo_align_t) - 1) /
                                sizeof(lzo_align_t));
  lzo_uint packedBytes = 0;
  const int status = lzo1x_1_compress(
      tile.data.data(), rawBytes,
      reinterpret_cast<unsigned char*>(blob.data() + kHeaderBytes),  // NOLINT: byte view
      &packedBytes, work.data());
  std::uint8_t compression = kLzo1x;
  if (status != LZO_E_OK || packedBytes >= rawBytes) {
    // Incompressible (tiny tiles, most BC1 tiles): store the texels as they are.
    compression = kStored;
    packedBytes = rawBytes;
    std::memcpy(blob.data() + kHeaderBytes, tile.data.data(), rawBytes);
  }
  blob.resize(kHeaderBytes + packedBytes);

  std::byte* header = blob.data();
  std::memcpy(header, kMagic.data(), kMagic.size());
  putU16(header + 4, kVersion);
  header[6] = static_cast<std::byte>(tile.format);
  header[7] = static_cast<std::byte>(compression);
  putU16(header + 8, static_cast<std::uint16_t>(tile.sizeTexels));
  putU16(header + 10, static_cast<std::uint16_t>(tile.borderTexels));
  putU32(header + 12, static_cast<std::uint32_t>(rawBytes));
  putU32(header + 16, static_cast<std::uint32_t>(packedBytes));
  const std::span<const std::byte> bytes(blob);
  std::uint32_t crc = crc32(bytes.first(kCrcOffset));
  crc = crc32(bytes.subspan(kHeaderBytes), crc);
  putU32(header + kCrcOffset, crc);
  return blob;
}

Result<TextureTileImage> decodeTextureTile(std::span<const std::byte> blob,
                                           std::string_view context) {
  if (blob.size() < kHeaderBytes) {
    return corrupt(context, "texture tile of " + std::to_string(blob.size()) +
                                " bytes is shorter than its " + std::to_string(kHeaderBytes) +
                                "-byte header");
  }
  const std::byte* header = blob.data();
  if (std::memcmp(header, kMagic.data(), kMagic.size()) != 0) {
    return corrupt(context, "not a texture tile (bad magic)");
  }
  if (const std::uint32_t version = getU16(header + 4); version != kVersion) {
    return corrupt(context, "unsupported texture tile version " + std::to_string(version));
  }
  const std::uint32_t storedBytes = getU32(header + 16);
  if (storedBytes != blob.size() - kHeaderBytes) {
    return corrupt(context, "texture tile payload of " + std::to_string(storedBytes) +
                                " bytes but " + std::to_string(blob.size() - kHeaderBytes) +
                                " bytes follow the header");
  }
  std::uint32_t crc = crc32(blob.first(kCrcOffset));
  crc = crc32(blob.subspan(kHeaderBytes), crc);
  if (const std::uint32_t stored = getU32(header + kCrcOffset); stored != crc) {
    return corrupt(context, "texture tile checksum mismatch");
  }

  const auto formatByte = std::to_integer<std::uint8_t>(header[6]);
  if (!validFormat(formatByte)) {
    return corrupt(context, "unknown texel format " + std::to_string(formatByte));
  }
  TextureTileImage tile;
  tile.format = static_cast<TexelFormat>(formatByte);
  tile.sizeTexels = getU16(header + 8);
  tile.borderTexels = getU16(header + 10);
  const std::size_t expected = textureTileDataBytes(tile.sizeTexels, tile.format);
  if (expected == 0) {
    return corrupt(context, "invalid " + std::string(formatName(tile.format)) + " tile size " +
                                std::to_string(tile.sizeTexels) + " (1.." +
                                std::to_string(kMaxTextureTileTexels) +
                                (isBlockFormat(tile.format) ? ", a multiple of 4)" : ")"));
  }
  if (2ull * tile.borderTexels >= tile.sizeTexels) {
    return corrupt(context, "texture tile border " + std::to_string(tile.borderTexels) +
                                " too large for size " + std::to_string(tile.sizeTexels));
  }
  if (const std::uint32_t rawBytes = getU32(header + 12); rawBytes != expected) {
    return corrupt(context, "texture tile declares " + std::to_string(rawBytes) +
                                " texel bytes, its size needs " + std::to_string(expected));
  }

  const std::span<const std::byte> payload = blob.subspan(kHeaderBytes);
  const auto compression = std::to_integer<std::uint8_t>(header[7]);
  tile.data.resize(expected);
  if (compression == kStored) {
    if (payload.size() != expected) {
      return corrupt(context, "stored texture tile payload of " + std::to_string(payload.size()) +
                                  " bytes, expected " + std::to_string(expected));
    }
    std::memcpy(tile.data.data(), payload.data(), expected);
  } else if (compression == kLzo1x) {
    if (payload.size() > lzoWorstCaseBytes(expected)) {
      return corrupt(context, "texture tile LZO payload larger than any encoding of its texels");
    }
    if (!lzoReady()) return makeError(ErrorCode::Internal, "texture tile: lzo_init failed");
    lzo_uint outBytes = expected;
    const int status = lzo1x_decompress_safe(
        reinterpret_cast<const unsigned char*>(payload.data()),  // NOLINT: byte view
        payload.size(), tile.data.data(), &outBytes, nullptr);
    if (status != LZO_E_OK || outBytes != expected) {
      return corrupt(context, "texture tile LZO payload does not expand to " +
                                  std::to_string(expected) + " bytes (lzo status " +
                                  std::to_string(status) + ")");
    }
  } else {
    return corrupt(context, "unknown texture tile compression " + std::to_string(compression));
  }
  return tile;
}

Result<TextureTileImage> compressBc1(const TextureTileImage& rgba, Bc1Quality quality) {
  if (rgba.format != TexelFormat::Rgba8)
    return invalidArgument("texture tile: compressBc1 needs an rgba8 tile");
  if (const std::string problem = describeInconsistency(rgba); !problem.empty()) {
    return invalidArgument("texture tile: " + problem);
  }
  if (rgba.sizeTexels % 4 != 0) {
    return invalidArgument("texture tile: BC1 needs a size that is a multiple of 4, not " +
                           std::to_string(rgba.sizeTexels));
  }
  const int flags = squish::kDxt1 | (quality == Bc1Quality::Fast ? squish::kColourRangeFit
                                                                 : squish::kColourClusterFit);
  TextureTileImage out = emptyTileLike(rgba, TexelFormat::Bc1);
  const std::size_t size = rgba.sizeTexels;
  const std::size_t blocksPerRow = size / 4;
  std::array<std::uint8_t, 64> block{};
  for (std::size_t by = 0; by < blocksPerRow; ++by) {
    for (std::size_t bx = 0; bx < blocksPerRow; ++bx) {
      for (std::size_t row = 0; row < 4; ++row) {
        const std::size_t source = ((4 * by + row) * size + 4 * bx) * 4;
        std::memcpy(block.data() + row * 16, rgba.data.data() + source, 16);
      }
      // Opaque tiles: alpha < 128 would make squish spend a palette entry on transparency.
      for (std::size_t texel = 0; texel < 16; ++texel) block[texel * 4 + 3] = 255;
      squish::Compress(block.data(), out.data.data() + (by * blocksPerRow + bx) * 8, flags);
    }
  }
  return out;
}

Result<TextureTileImage> expandToRgba8(const TextureTileImage& tile) {
  if (tile.format != TexelFormat::Rgba8 && tile.format != TexelFormat::Bc1) {
    return invalidArgument(
        std::string("texture tile: expandToRgba8 expands rgba8 and bc1 tiles, not ") +
        formatName(tile.format) + " (normal-map tiles expand with expandToRg8)");
  }
  if (const std::string problem = describeInconsistency(tile); !problem.empty()) {
    return invalidArgument("texture tile: " + problem);
  }
  if (tile.format == TexelFormat::Rgba8) return tile;
  TextureTileImage out = emptyTileLike(tile, TexelFormat::Rgba8);
  const std::size_t size = tile.sizeTexels;
  const std::size_t blocksPerRow = size / 4;
  std::array<std::uint8_t, 64> block{};
  for (std::size_t by = 0; by < blocksPerRow; ++by) {
    for (std::size_t bx = 0; bx < blocksPerRow; ++bx) {
      squish::Decompress(block.data(), tile.data.data() + (by * blocksPerRow + bx) * 8,
                         squish::kDxt1);
      for (std::size_t row = 0; row < 4; ++row) {
        const std::size_t target = ((4 * by + row) * size + 4 * bx) * 4;
        std::memcpy(out.data.data() + target, block.data() + row * 16, 16);
      }
    }
  }
  return out;
}

Result<TextureTileImage> compressBc5(const TextureTileImage& rg8) {
  if (rg8.format != TexelFormat::Rg8)
    return invalidArgument("texture tile: compressBc5 needs an rg8 tile");
  if (const std::string problem = describeInconsistency(rg8); !problem.empty()) {
    return invalidArgument("texture tile: " + problem);
  }
  if (rg8.sizeTexels % 4 != 0) {
    return invalidArgument("texture tile: BC5 needs a size that is a multiple of 4, not " +
                           std::to_string(rg8.sizeTexels));
  }
  TextureTileImage out = emptyTileLike(rg8, TexelFormat::Bc5);
  const std::size_t size = rg8.sizeTexels;
  const std::size_t blocksPerRow = size / 4;
  // squish's kBc5 reads R into the block's first BC4 half and G into its second (TestTextureTile
  // checks it) and ignores B and A, which are set anyway so that every byte is defined.
  std::array<std::uint8_t, 64> block{};
  for (std::size_t texel = 0; texel < 16; ++texel) block[texel * 4 + 3] = 255;
  for (std::size_t by = 0; by < blocksPerRow; ++by) {
    for (std::size_t bx = 0; bx < blocksPerRow; ++bx) {
      for (std::size_t row = 0; row < 4; ++row) {
        const std::uint8_t* source = rg8.data.data() + ((4 * by + row) * size + 4 * bx) * 2;
        for (std::size_t x = 0; x < 4; ++x) {
          block[(row * 4 + x) * 4 + 0] = source[2 * x];
          block[(row * 4 + x) * 4 + 1] = source[2 * x + 1];
        }
      }
      squish::Compress(block.data(), out.data.data() + (by * blocksPerRow + bx) * 16, squish::kBc5);
    }
  }
  return out;
}

Result<TextureTileImage> expandToRg8(const TextureTileImage& tile) {
  if (tile.format != TexelFormat::Rg8 && tile.format != TexelFormat::Bc5) {
    return invalidArgument(
        std::string("texture tile: expandToRg8 expands rg8 and bc5 tiles, not ") +
        formatName(tile.format) + " (colour tiles expand with expandToRgba8)");
  }
  if (const std::string problem = describeInconsistency(tile); !problem.empty()) {
    return invalidArgument("texture tile: " + problem);
  }
  if (tile.format == TexelFormat::Rg8) return tile;
  TextureTileImage out = emptyTileLike(tile, TexelFormat::Rg8);
  const std::size_t size = tile.sizeTexels;
  const std::size_t blocksPerRow = size / 4;
  // libsquish 1.15's Decompress ignores kBc4/kBc5 (it would decode the bytes as a BC1 colour
  // block), but a BC4 block is bit for bit a DXT5 alpha block: each half goes through the DXT5
  // path as the alpha half of an otherwise zero block, and the channel comes out in A.
  std::array<std::uint8_t, 16> dxt5{};
  std::array<std::uint8_t, 64> decoded{};
  for (std::size_t by = 0; by < blocksPerRow; ++by) {
    for (std::size_t bx = 0; bx < blocksPerRow; ++bx) {
      const std::uint8_t* bc5 = tile.data.data() + (by * blocksPerRow + bx) * 16;
      for (std::size_t channel = 0; channel < 2; ++channel) {
        std::memcpy(dxt5.data(), bc5 + channel * kBc4BlockBytes, kBc4BlockBytes);
        squish::Decompress(decoded.data(), dxt5.data(), squish::kDxt5);
        for (std::size_t row = 0; row < 4; ++row) {
          std::uint8_t* target = out.data.data() + ((4 * by + row) * size + 4 * bx) * 2;
          for (std::size_t x = 0; x < 4; ++x)
            target[2 * x + channel] = decoded[(row * 4 + x) * 4 + 3];
        }
      }
    }
  }
  return out;
}

}  // namespace pbdam::formats
