// The void map (VoidMap.h): golden layout, round trip, the lookup of the sample nearest a point,
// and every kind of damage rejected with the offset named.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/VoidMap.h"

namespace pbdam::formats {
namespace {

VoidMap sample() {
  VoidMap map;
  VoidGrid g;
  g.firstLatDegrees = 37.0 - 1.0 / 24.0;
  g.firstLonDegrees = 74.0 + 1.0 / 24.0;
  g.latSpacingDegrees = 1.0 / 12.0;
  g.lonSpacingDegrees = 1.0 / 12.0;
  g.width = 240;
  g.height = 120;
  g.runs = {VoidRun{3, 10, 2, VoidKind::FilledFromRim}, VoidRun{3, 20, 1, VoidKind::SurfaceBelow},
            VoidRun{4, 9, 4, VoidKind::FilledFromRim}};
  map.surfaces.push_back(g);
  map.surfaces.push_back(VoidGrid{49.9, 5.7, 0.01, 0.01, 10, 10, {}});
  return map;
}

/// The bytes with their trailing CRC-32 made right again.
std::vector<std::byte> recrc(std::vector<std::byte> bytes) {
  const std::uint32_t crc = crc32(std::span<const std::byte>(bytes).first(bytes.size() - 4));
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  return bytes;
}

TEST(VoidMap, RoundTripsItsLayoutByteForByte) {
  const VoidMap map = sample();
  const std::vector<std::byte> bytes = encodeVoidMap(map);
  // Magic, version, count; per surface 4 doubles, width, height, run count; 16 B a run; CRC.
  ASSERT_EQ(bytes.size(), 8u + 4 + 4 + (32 + 12 + 3 * 16) + (32 + 12) + 4);
  EXPECT_EQ(std::memcmp(bytes.data(), "PBDVOIDS", 8), 0);
  EXPECT_EQ(static_cast<int>(bytes[8]), 1);  // version 1, little-endian
  auto back = decodeVoidMap(bytes, "voids.bin");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(*back == map);
}

TEST(VoidMap, AnswersTheKindOfTheSampleNearestAPoint) {
  const VoidGrid g = sample().surfaces[0];
  const auto at = [&](double row, double col) {
    return g.at(g.firstLatDegrees - row * g.latSpacingDegrees,
                g.firstLonDegrees + col * g.lonSpacingDegrees);
  };
  EXPECT_EQ(at(3, 10), VoidKind::FilledFromRim);
  EXPECT_EQ(at(3.4, 11.4), VoidKind::FilledFromRim);  // nearest (3, 11)
  EXPECT_EQ(at(3, 12), std::nullopt);
  EXPECT_EQ(at(3, 20), VoidKind::SurfaceBelow);
  EXPECT_EQ(at(4, 12), VoidKind::FilledFromRim);
  EXPECT_EQ(at(4, 13), std::nullopt);
  EXPECT_EQ(at(2.6, 9), std::nullopt);  // nearest (3, 9): valid
  EXPECT_EQ(at(-5, 10), std::nullopt);  // outside the grid
  EXPECT_EQ(g.at(g.firstLatDegrees - 3 * g.latSpacingDegrees,
                 g.firstLonDegrees + 10 * g.lonSpacingDegrees + 360.0),
            VoidKind::FilledFromRim);  // longitude modulo 360
}

TEST(VoidMap, RejectsDamageNamingTheOffset) {
  const std::vector<std::byte> good = encodeVoidMap(sample());
  const auto rejected = [](std::vector<std::byte> bytes, const std::string& expected) {
    auto map = decodeVoidMap(bytes, "voids.bin");
    ASSERT_FALSE(map.ok());
    EXPECT_EQ(map.error().code, ErrorCode::CorruptData);
    EXPECT_NE(map.error().message.find(expected), std::string::npos) << map.error().message;
    EXPECT_EQ(map.error().message.rfind("voids.bin at byte ", 0), 0u) << map.error().message;
  };
  rejected({}, "not a pbdam void map");
  rejected(std::vector<std::byte>(good.begin(), good.begin() + 40), "checksum mismatch");
  rejected(recrc(std::vector<std::byte>(good.begin(), good.end() - 20)), "");
  std::vector<std::byte> flipped = good;
  flipped[60] ^= std::byte{1};
  rejected(flipped, "checksum mismatch");
  std::vector<std::byte> version = good;
  version[8] = std::byte{2};
  rejected(recrc(version), "version 2");
  // The first run: row at 16 + 44 bytes in.
  constexpr std::size_t run = 16 + 44;
  std::vector<std::byte> outside = good;
  outside[run + 4] = std::byte{239};  // column 239, length 2: past the 240 columns
  rejected(recrc(outside), "outside its grid");
  std::vector<std::byte> kind = good;
  kind[run + 12] = std::byte{7};
  rejected(recrc(kind), "unknown void kind 7");
  std::vector<std::byte> order = good;
  order[run] = std::byte{9};  // row 9 before row 3
  rejected(recrc(order), "out of order or overlapping");
  std::vector<std::byte> spacing = good;
  std::memset(spacing.data() + 16 + 16, 0, 8);  // latitude spacing 0
  rejected(recrc(spacing), "not finite and positive");
  std::vector<std::byte> trailing = good;
  trailing.insert(trailing.end() - 4, std::byte{0});
  rejected(recrc(trailing), "bytes after the last surface");
}

}  // namespace
}  // namespace pbdam::formats
