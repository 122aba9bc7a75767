// Little-endian header fields of the formats module's blobs (formats/PatchBlob.md,
// formats/TextureTile.md): store and load 16- and 32-bit unsigned integers at a byte pointer,
// independent of the host's byte order. Private to pbdam_formats.
#pragma once

#include <cstddef>
#include <cstdint>

namespace pbdam::formats {

/// Stores `value` at p[0..2), low byte first. `p` must have room for 2 bytes.
inline void putU16(std::byte* p, std::uint16_t value) noexcept {
  p[0] = static_cast<std::byte>(value & 0xFFU);
  p[1] = static_cast<std::byte>(value >> 8);
}

/// Stores `value` at p[0..4), low byte first. `p` must have room for 4 bytes.
inline void putU32(std::byte* p, std::uint32_t value) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::byte>((value >> (8 * i)) & 0xFFU);
}

/// Loads the 16-bit value stored low byte first at p[0..2).
inline std::uint16_t getU16(const std::byte* p) noexcept {
  return static_cast<std::uint16_t>(std::to_integer<unsigned>(p[0]) |
                                    (std::to_integer<unsigned>(p[1]) << 8));
}

/// Loads the 32-bit value stored low byte first at p[0..4).
inline std::uint32_t getU32(const std::byte* p) noexcept {
  std::uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value |= std::to_integer<std::uint32_t>(p[i]) << (8 * i);
  return value;
}

}  // namespace pbdam::formats
