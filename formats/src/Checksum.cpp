// CRC-32 through zlib (Checksum.h).
#include "pbdam/formats/Checksum.h"

#include <zlib.h>

#include <algorithm>

namespace pbdam::formats {

std::uint32_t crc32(std::span<const std::byte> bytes, std::uint32_t crc) noexcept {
  uLong value = crc;
  const auto* data = reinterpret_cast<const Bytef*>(bytes.data());  // NOLINT: byte view
  std::size_t left = bytes.size();
  while (left > 0) {
    const auto chunk = static_cast<uInt>(std::min<std::size_t>(left, 1U << 30));
    value = ::crc32(value, data, chunk);
    data += chunk;
    left -= chunk;
  }
  return static_cast<std::uint32_t>(value);
}

std::uint32_t crc32Combine(std::uint32_t first, std::uint32_t second,
                           std::uint64_t secondBytes) noexcept {
  return static_cast<std::uint32_t>(
      ::crc32_combine64(first, second, static_cast<z_off64_t>(secondBytes)));
}

}  // namespace pbdam::formats
