// CRC-32 check values.
#include <gtest/gtest.h>

#include <string_view>

#include "pbdam/formats/Checksum.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

std::span<const std::byte> bytesOf(std::string_view s) {
  return std::as_bytes(std::span<const char>(s.data(), s.size()));
}

TEST(Checksum, MatchesTheStandardCheckValue) {
  EXPECT_EQ(crc32(bytesOf("123456789")), 0xCBF43926u);  // CRC-32/ISO-HDLC check value
  EXPECT_EQ(crc32(bytesOf("")), 0u);
  // Continuing a CRC equals checksumming the concatenation.
  EXPECT_EQ(crc32(bytesOf("6789"), crc32(bytesOf("12345"))), 0xCBF43926u);
}

}  // namespace
}  // namespace pbdam::formats
