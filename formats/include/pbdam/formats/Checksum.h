// CRC-32 (zlib's, ISO-HDLC polynomial) of byte ranges: the checksum every dataset blob, node
// table and tile carries and every decoder verifies. Thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace pbdam::formats {

/// CRC-32 of `bytes`, continuing from `crc` (0 to start).
std::uint32_t crc32(std::span<const std::byte> bytes, std::uint32_t crc = 0) noexcept;

/// The CRC-32 of two byte runs one after the other, from the first's CRC, the second's CRC and
/// the second's length (zlib's crc32_combine): a file whose head is written after its tail.
std::uint32_t crc32Combine(std::uint32_t first, std::uint32_t second,
                           std::uint64_t secondBytes) noexcept;

}  // namespace pbdam::formats
