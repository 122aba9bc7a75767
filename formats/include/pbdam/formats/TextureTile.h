// Texture tiles of the per-face texture quadtree (docs/architecture.md "Geometry"; [P-BDAM 2003]
// §3/§4, the texture quadtree, and §5: tiles stored GPU-compressed as BC1 = DXT1): the in-memory
// image, the on-disk tile codec (header + CRC-32 + LZO1X payload; byte layout in
// formats/TextureTile.md), BC1 compression of colour tiles and BC5 compression of normal-map tiles
// through libsquish. Thread-safety: every function is pure and may be called from any number of
// threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// How a tile's texels are stored. The numeric values are written to disk. Rgba8 and Bc1 hold
/// colour tiles; Rg8 and Bc5 hold normal-map tiles, two channels: the x and y components of a
/// tangent-space normal.
enum class TexelFormat : std::uint8_t {
  Rgba8 = 0,  ///< 4 bytes per texel: R, G, B, A
  Bc1 = 1,    ///< BC1 (DXT1) 4×4 blocks of 8 bytes, opaque (alpha always 255)
  Bc5 = 2,    ///< BC5 4×4 blocks of 16 bytes: a BC4 block of R, then one of G
  Rg8 = 3,    ///< 2 bytes per texel: R, G
};

/// The largest tile side the codec accepts, in texels.
inline constexpr std::uint32_t kMaxTextureTileTexels = 4096;

/// A square texture tile.
///
/// Orientation (the same for every format, and what a GPU upload of `data` gives): texel (x, y)
/// has face u growing with x and face v growing with y; row y = 0 is the tile's lowest-v row.
///  - Rgba8: texel (x, y) is data[4·(y·sizeTexels + x) .. +4), rows packed, no padding.
///  - Rg8: texel (x, y) is data[2·(y·sizeTexels + x) .. +2), rows packed, no padding.
///  - Bc1: block (bx, by) covers texels x in [4bx, 4bx+4), y in [4by, 4by+4) and is the 8 bytes
///    at data[8·(by·(sizeTexels/4) + bx)]; inside a block, row 0 is the block's lowest y (the
///    standard BC1 layout, so the bytes upload to VK_FORMAT_BC1_RGB(A)_*_BLOCK unchanged).
///  - Bc5: as Bc1, but each block is the 16 bytes at data[16·(by·(sizeTexels/4) + bx)]: the 8-byte
///    BC4 block of R, then that of G (the standard BC5 layout; uploads to
///    VK_FORMAT_BC5_UNORM_BLOCK unchanged).
/// `borderTexels` texels on each side lie beyond the tile's quadtree square (filtering border);
/// the codec stores the number and checks 2·borderTexels < sizeTexels, nothing more.
struct TextureTileImage final {
  std::uint32_t sizeTexels = 0;             ///< texels on a side, the border included
  TexelFormat format = TexelFormat::Rgba8;  ///< how `data` holds the texels
  std::uint32_t borderTexels = 0;           ///< texels of border on each side
  std::vector<std::uint8_t> data;           ///< the texels, laid out as above

  /// Field by field, the texel bytes included.
  friend bool operator==(const TextureTileImage&, const TextureTileImage&) = default;
};

/// Returns the number of bytes `data` must hold for a tile of `sizeTexels` in `format`
/// (size²·4 for Rgba8, size²·2 for Rg8, (size/4)²·8 for Bc1, (size/4)²·16 for Bc5), or 0 when the
/// size is not valid for the format (0, over kMaxTextureTileTexels, or not a multiple of 4 for Bc1
/// and Bc5).
std::size_t textureTileDataBytes(std::uint32_t sizeTexels, TexelFormat format) noexcept;

/// Encodes `tile` into a self-contained blob: a 24-byte header (magic "PBTX", version, format,
/// payload compression, size, border, payload sizes, CRC-32 of every other byte) followed by the
/// payload. The payload is LZO1X-1 compressed when that makes it smaller, else stored as is
/// (decided per tile; formats/TextureTile.md has the measurements behind it). Deterministic: the
/// same tile always gives the same bytes. Returns InvalidArgument when the size, border or data
/// length is inconsistent (see textureTileDataBytes).
Result<std::vector<std::byte>> encodeTextureTile(const TextureTileImage& tile);

/// Decodes a blob written by encodeTextureTile. Safe for untrusted input: every field and length
/// is checked before use (size ≤ kMaxTextureTileTexels, a multiple of 4 for Bc1/Bc5, exact payload
/// lengths, no trailing bytes), the CRC-32 is verified, and LZO payloads are expanded with
/// lzo1x_decompress_safe into exactly the expected length. Returns CorruptData with a message
/// "<context>: <what was wrong>" (context names the file and offset, e.g. "face2.bin@123456").
Result<TextureTileImage> decodeTextureTile(std::span<const std::byte> blob,
                                           std::string_view context);

/// libsquish's colour fit for BC1. Measured on shaded-relief and imagery tiles (one core of the
/// build machine; formats/TextureTile.md): High 0.5–0.9 Mtexel/s at 36–41 dB PSNR, Fast
/// 20–22 Mtexel/s at 33–38 dB. High is the default: tiles are built once and looked at often.
enum class Bc1Quality : std::uint8_t {
  High = 0,  ///< squish::kColourClusterFit
  Fast = 1,  ///< squish::kColourRangeFit
};

/// Compresses an Rgba8 tile to Bc1 with libsquish (kDxt1 and the colour fit of `quality`; alpha
/// is ignored, the result is opaque). Blocks are compressed one at a time on the calling thread
/// (never through libsquish's OpenMP path), so the result is deterministic and the call nests
/// safely inside TBB tasks. `rgba` must be Rgba8 with a size that is a multiple of 4, else
/// InvalidArgument. borderTexels is kept.
Result<TextureTileImage> compressBc1(const TextureTileImage& rgba,
                                     Bc1Quality quality = Bc1Quality::High);

/// Expands a Bc1 tile to Rgba8 (libsquish's reference decoder, one block at a time); an Rgba8
/// tile is returned unchanged. Colour tiles only: InvalidArgument for an Rg8 or Bc5 tile (use
/// expandToRg8), and when the data length does not match the size.
Result<TextureTileImage> expandToRgba8(const TextureTileImage& tile);

/// Compresses an Rg8 normal-map tile to Bc5 with libsquish (kBc5: R goes to each block's first
/// BC4 half, G to its second). Blocks are compressed one at a time on the calling thread (never
/// through libsquish's OpenMP path), so the result is deterministic and the call nests safely
/// inside TBB tasks. Smooth fields come back within a few levels per channel
/// (formats/TextureTile.md has the measurements). `rg8` must be Rg8 with a size that is a multiple
/// of 4, else InvalidArgument. borderTexels is kept.
Result<TextureTileImage> compressBc5(const TextureTileImage& rg8);

/// Expands a Bc5 tile to Rg8, one block at a time with libsquish's reference BC4 decoder (its
/// DXT5 alpha decoder, which a BC4 block is bit for bit; libsquish 1.15's Decompress does not
/// decode kBc5 itself). The decoder interpolates with truncating integer division, so it may
/// differ from a GPU's sampling of the same blocks by one level. An Rg8 tile is returned
/// unchanged. Normal-map tiles only: InvalidArgument for an Rgba8 or Bc1 tile (use
/// expandToRgba8), and when the data length does not match the size.
Result<TextureTileImage> expandToRg8(const TextureTileImage& tile);

}  // namespace pbdam::formats
