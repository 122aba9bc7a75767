// CRC-32 (zlib's, ISO-HDLC polynomial) of byte ranges: the checksum every dataset blob, node
// table and tile carries and every decoder verifies. Thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace pbdam::formats {

/// CRC-32 of `bytes`, continuing from `crc` (0 to start).
std::uint32_t crc32(std::span<const std::byte> bytes, std::uint32_t crc = 0) noexcept;

}  // namespace pbdam::formats
