// Texture tile codec and BC1 (TextureTile.h, formats/TextureTile.md): exact RGBA8 round trips,
// BC1 quality and determinism, rejection of every corruption and truncation, golden bytes.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/TextureTile.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

// A smooth, opaque test image: gradients and a low-frequency wave.
TextureTileImage smoothTile(std::uint32_t size, std::uint32_t border) {
  TextureTileImage tile{size, TexelFormat::Rgba8, border, {}};
  tile.data.resize(textureTileDataBytes(size, TexelFormat::Rgba8));
  for (std::uint32_t y = 0; y < size; ++y) {
    for (std::uint32_t x = 0; x < size; ++x) {
      const double fx = static_cast<double>(x) / size;
      const double fy = static_cast<double>(y) / size;
      std::uint8_t* texel = tile.data.data() + (static_cast<std::size_t>(y) * size + x) * 4;
      texel[0] = static_cast<std::uint8_t>(std::lround(40.0 + 180.0 * fx));
      texel[1] = static_cast<std::uint8_t>(std::lround(60.0 + 150.0 * fy));
      texel[2] =
          static_cast<std::uint8_t>(std::lround(128.0 + 100.0 * std::sin(6.0 * fx + 4.0 * fy)));
      texel[3] = 255;
    }
  }
  return tile;
}

TextureTileImage noiseTile(std::uint32_t size, std::uint32_t seed) {
  TextureTileImage tile{size, TexelFormat::Rgba8, 0, {}};
  tile.data.resize(textureTileDataBytes(size, TexelFormat::Rgba8));
  std::mt19937 random(seed);
  for (std::uint8_t& byte : tile.data) byte = static_cast<std::uint8_t>(random() & 0xFFu);
  return tile;
}

double psnrRgb(const TextureTileImage& a, const TextureTileImage& b) {
  double squared = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < a.data.size(); ++i) {
    if (i % 4 == 3) continue;
    const double d = static_cast<double>(a.data[i]) - static_cast<double>(b.data[i]);
    squared += d * d;
    ++count;
  }
  const double mse = squared / static_cast<double>(count);
  return mse == 0.0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

std::vector<std::byte> encodeOrDie(const TextureTileImage& tile) {
  auto blob = encodeTextureTile(tile);
  EXPECT_TRUE(blob) << blob.error().message;
  return blob ? std::move(blob).value() : std::vector<std::byte>{};
}

// Rewrites the CRC so that a deliberately inconsistent header passes the checksum.
void fixCrc(std::vector<std::byte>& blob) {
  const std::span<const std::byte> bytes(blob);
  std::uint32_t crc = crc32(bytes.first(20));
  crc = crc32(bytes.subspan(24), crc);
  for (int i = 0; i < 4; ++i)
    blob[20 + static_cast<std::size_t>(i)] = static_cast<std::byte>(crc >> (8 * i));
}

void putU32(std::vector<std::byte>& blob, std::size_t offset, std::uint32_t value) {
  for (std::size_t i = 0; i < 4; ++i) blob[offset + i] = static_cast<std::byte>(value >> (8 * i));
}

TEST(TextureTile, RoundTripsRgba8Exactly) {
  for (const TextureTileImage& tile : {smoothTile(64, 2), noiseTile(16, 7), smoothTile(5, 2)}) {
    const std::vector<std::byte> blob = encodeOrDie(tile);
    auto decoded = decodeTextureTile(blob, "tile");
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(*decoded, tile);
  }
}

TEST(TextureTile, CompressesWhatCompressesAndStoresTheRest) {
  // A flat-coloured tile shrinks under LZO; random bytes are stored (header + raw texels).
  TextureTileImage flat{32, TexelFormat::Rgba8, 2,
                        std::vector<std::uint8_t>(std::size_t{32} * 32 * 4, 200)};
  EXPECT_LT(encodeOrDie(flat).size(), flat.data.size() / 10);
  EXPECT_EQ(encodeOrDie(noiseTile(32, 3)).size(), 24u + 32u * 32u * 4u);
}

TEST(TextureTile, Bc1IsCloseToTheSourceAndDeterministic) {
  const TextureTileImage rgba = smoothTile(64, 2);
  auto bc1 = compressBc1(rgba);
  ASSERT_TRUE(bc1) << bc1.error().message;
  EXPECT_EQ(bc1->format, TexelFormat::Bc1);
  EXPECT_EQ(bc1->borderTexels, 2u);
  EXPECT_EQ(bc1->data.size(), 16u * 16u * 8u);
  auto again = compressBc1(rgba);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->data, bc1->data);

  auto expanded = expandToRgba8(*bc1);
  ASSERT_TRUE(expanded) << expanded.error().message;
  EXPECT_EQ(expanded->format, TexelFormat::Rgba8);
  EXPECT_GT(psnrRgb(*expanded, rgba), 30.0);
  for (std::size_t i = 3; i < expanded->data.size(); i += 4) ASSERT_EQ(expanded->data[i], 255);

  // The fast fit is worse but still usable, and the stored blob round-trips bit-exactly.
  auto fast = compressBc1(rgba, Bc1Quality::Fast);
  ASSERT_TRUE(fast);
  EXPECT_GT(psnrRgb(*expandToRgba8(*fast), rgba), 28.0);
  auto decoded = decodeTextureTile(encodeOrDie(*bc1), "bc1");
  ASSERT_TRUE(decoded) << decoded.error().message;
  EXPECT_EQ(*decoded, *bc1);
}

TEST(TextureTile, RejectsInconsistentTilesOnEncode) {
  TextureTileImage tile = smoothTile(8, 1);
  tile.data.pop_back();
  EXPECT_EQ(encodeTextureTile(tile).error().code, ErrorCode::InvalidArgument);
  EXPECT_FALSE(encodeTextureTile(TextureTileImage{0, TexelFormat::Rgba8, 0, {}}));
  EXPECT_FALSE(encodeTextureTile(smoothTile(8, 4)));  // border leaves no inner texels
  TextureTileImage bc1{6, TexelFormat::Bc1, 0, std::vector<std::uint8_t>(32)};
  EXPECT_FALSE(encodeTextureTile(bc1));
  EXPECT_EQ(textureTileDataBytes(4097, TexelFormat::Rgba8), 0u);
  EXPECT_FALSE(compressBc1(smoothTile(6, 0)));                // not a multiple of 4
  EXPECT_FALSE(compressBc1(*compressBc1(smoothTile(8, 0))));  // not RGBA8
}

TEST(TextureTile, RejectsEverySingleByteCorruption) {
  // One LZO-compressed tile, one stored tile, one BC1 tile.
  TextureTileImage flat{8, TexelFormat::Rgba8, 1,
                        std::vector<std::uint8_t>(std::size_t{8} * 8 * 4, 90)};
  for (const TextureTileImage& tile : {flat, noiseTile(4, 11), *compressBc1(smoothTile(8, 1))}) {
    const std::vector<std::byte> blob = encodeOrDie(tile);
    ASSERT_TRUE(decodeTextureTile(blob, "tile"));
    for (std::size_t i = 0; i < blob.size(); ++i) {
      for (const int mask : {0x01, 0x80, 0xFF}) {
        std::vector<std::byte> bad = blob;
        bad[i] ^= static_cast<std::byte>(mask);
        auto decoded = decodeTextureTile(bad, "face3.bin@4096");
        ASSERT_FALSE(decoded) << "byte " << i << " mask " << mask;
        EXPECT_EQ(decoded.error().code, ErrorCode::CorruptData);
        EXPECT_EQ(decoded.error().message.rfind("face3.bin@4096: ", 0), 0u)
            << decoded.error().message;
      }
    }
  }
}

TEST(TextureTile, RejectsTruncationsAndTrailingBytes) {
  TextureTileImage flat{8, TexelFormat::Rgba8, 1,
                        std::vector<std::uint8_t>(std::size_t{8} * 8 * 4, 90)};
  const std::vector<std::byte> blob = encodeOrDie(flat);
  for (std::size_t length = 0; length < blob.size(); ++length) {
    auto decoded = decodeTextureTile(std::span(blob).first(length), "cut");
    ASSERT_FALSE(decoded) << "length " << length;
    EXPECT_EQ(decoded.error().code, ErrorCode::CorruptData);
  }
  std::vector<std::byte> longer = blob;
  longer.push_back(std::byte{0});
  EXPECT_FALSE(decodeTextureTile(longer, "long"));
}

TEST(TextureTile, RejectsInconsistentHeadersEvenWithAValidChecksum) {
  TextureTileImage flat{8, TexelFormat::Rgba8, 1,
                        std::vector<std::uint8_t>(std::size_t{8} * 8 * 4, 90)};
  const std::vector<std::byte> blob = encodeOrDie(flat);
  ASSERT_EQ(std::to_integer<int>(blob[7]), 1);  // LZO
  const auto expectCorrupt = [](std::vector<std::byte> bad, const char* what) {
    fixCrc(bad);
    auto decoded = decodeTextureTile(bad, "hostile");
    ASSERT_FALSE(decoded) << what;
    EXPECT_EQ(decoded.error().code, ErrorCode::CorruptData) << what;
  };
  std::vector<std::byte> bad = blob;
  bad[8] = std::byte{0x00};  // size 0
  bad[9] = std::byte{0x00};
  expectCorrupt(bad, "size 0");
  bad = blob;
  bad[8] = std::byte{0x01};  // size 4097
  bad[9] = std::byte{0x10};
  expectCorrupt(bad, "size 4097");
  bad = blob;
  bad[10] = std::byte{4};  // border 4 of size 8
  expectCorrupt(bad, "border");
  bad = blob;
  putU32(bad, 12, 0xFFFFFFFFu);  // raw size
  expectCorrupt(bad, "raw size");
  bad = blob;
  bad[6] = std::byte{1};  // BC1 with an RGBA8 raw size
  expectCorrupt(bad, "format/size");
  bad = blob;
  bad[6] = std::byte{7};
  expectCorrupt(bad, "format");
  bad = blob;
  bad[7] = std::byte{9};
  expectCorrupt(bad, "compression");
  bad = blob;
  bad[7] = std::byte{0};  // claims stored, payload is LZO
  expectCorrupt(bad, "stored length");
  bad = blob;
  for (std::size_t i = 24; i < bad.size(); ++i) bad[i] = std::byte{0xFF};  // garbage LZO stream
  expectCorrupt(bad, "lzo garbage");
  bad = blob;
  bad[4] = std::byte{2};  // version
  expectCorrupt(bad, "version");
}

TEST(TextureTile, MatchesGoldenBytes) {
  // A 4×4 RGBA8 tile (texel (x, y) = (16x, 16y, 128, 255)), too small for LZO to pay: stored.
  TextureTileImage tile{4, TexelFormat::Rgba8, 1, {}};
  for (std::uint8_t y = 0; y < 4; ++y) {
    for (std::uint8_t x = 0; x < 4; ++x) {
      tile.data.insert(tile.data.end(), {static_cast<std::uint8_t>(16 * x),
                                         static_cast<std::uint8_t>(16 * y), 128, 255});
    }
  }
  const std::vector<std::uint8_t> header{
      'P',  'B',  'T',  'X',   // magic
      0x01, 0x00,              // version 1
      0x00,                    // rgba8
      0x00,                    // stored
      0x04, 0x00,              // 4 texels
      0x01, 0x00,              // border 1
      0x40, 0x00, 0x00, 0x00,  // 64 texel bytes
      0x40, 0x00, 0x00, 0x00,  // 64 payload bytes
  };
  const std::vector<std::byte> blob = encodeOrDie(tile);
  ASSERT_EQ(blob.size(), 24u + 64u);
  for (std::size_t i = 0; i < header.size(); ++i) {
    EXPECT_EQ(std::to_integer<std::uint8_t>(blob[i]), header[i]) << "byte " << i;
  }
  EXPECT_EQ(std::memcmp(blob.data() + 24, tile.data.data(), 64), 0);
  // The CRC field, pinned: a change to the CRC's coverage shows up here.
  std::uint32_t crc = 0;
  for (std::size_t i = 0; i < 4; ++i)
    crc |= std::to_integer<std::uint32_t>(blob[20 + i]) << (8 * i);
  EXPECT_EQ(crc, 0xE20DC506u);

  // One hand-made BC1 block (endpoints pure red 0xF800 and pure blue 0x001F, so 4-colour mode;
  // row y uses index y throughout): the stored bytes and the standard decoding of them.
  const TextureTileImage bc1{
      4, TexelFormat::Bc1, 0, {0x00, 0xF8, 0x1F, 0x00, 0x00, 0x55, 0xAA, 0xFF}};
  const std::vector<std::byte> bc1Blob = encodeOrDie(bc1);
  const std::vector<std::uint8_t> bc1Golden{'P',  'B',  'T',  'X',  0x01, 0x00, 0x01, 0x00,
                                            0x04, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00,
                                            0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                            0x00, 0xF8, 0x1F, 0x00, 0x00, 0x55, 0xAA, 0xFF};
  ASSERT_EQ(bc1Blob.size(), bc1Golden.size());
  for (std::size_t i = 0; i < bc1Golden.size(); ++i) {
    if (i >= 20 && i < 24) continue;  // the CRC, checked through decoding below
    EXPECT_EQ(std::to_integer<std::uint8_t>(bc1Blob[i]), bc1Golden[i]) << "byte " << i;
  }
  auto decoded = decodeTextureTile(bc1Blob, "golden");
  ASSERT_TRUE(decoded) << decoded.error().message;
  auto expanded = expandToRgba8(*decoded);
  ASSERT_TRUE(expanded);
  const std::array<std::array<std::uint8_t, 4>, 4> rowColours{
      {{255, 0, 0, 255}, {0, 0, 255, 255}, {170, 0, 85, 255}, {85, 0, 170, 255}}};
  for (std::size_t y = 0; y < 4; ++y) {
    for (std::size_t x = 0; x < 4; ++x) {
      for (std::size_t c = 0; c < 4; ++c) {
        EXPECT_EQ(expanded->data[(y * 4 + x) * 4 + c], rowColours[y][c]) << x << "," << y;
      }
    }
  }
}

}  // namespace
}  // namespace pbdam::formats
