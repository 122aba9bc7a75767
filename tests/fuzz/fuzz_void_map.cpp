// libFuzzer target for the void map decoder (VoidMap.h): decodeVoidMap on arbitrary bytes; an
// accepted map must encode again to the same bytes, and every run must answer its own kind at
// its samples. Each input is also tried with its CRC made right. Seeds: the void map of a build
// with voids punched into a real DEM (tests/fuzz/corpus/void_map).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/VoidMap.h"

namespace {

using namespace pbdam::formats;

void check(std::span<const std::byte> bytes) {
  auto map = decodeVoidMap(bytes, "fuzz");
  if (!map) return;
  const std::vector<std::byte> again = encodeVoidMap(*map);
  if (again.size() != bytes.size() || std::memcmp(again.data(), bytes.data(), bytes.size()) != 0) {
    __builtin_trap();
  }
  for (const VoidGrid& g : map->surfaces) {
    for (std::size_t k = 0; k < g.runs.size() && k < 64; ++k) {
      const VoidRun& r = g.runs[k];
      const double lat = g.firstLatDegrees - r.row * g.latSpacingDegrees;
      const double lon = g.firstLonDegrees + r.column * g.lonSpacingDegrees;
      // Far from the origin the georeference's rounding may pick a neighbour: only check grids
      // whose sample centres are exact enough to be found again.
      if (std::abs(lat) > 90.0 || std::abs(lon) > 720.0 || g.latSpacingDegrees < 1e-6 ||
          g.lonSpacingDegrees < 1e-6 || g.width > 360.0 / g.lonSpacingDegrees) {
        continue;
      }
      const auto kind = g.at(lat, lon);
      if (!kind || *kind != r.kind) __builtin_trap();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::byte> bytes(reinterpret_cast<const std::byte*>(data), size);
  check(bytes);
  if (size >= 4) {
    std::vector<std::byte> fixed(bytes.begin(), bytes.end());
    const std::uint32_t crc = crc32(std::span<const std::byte>(fixed).first(size - 4));
    std::memcpy(fixed.data() + size - 4, &crc, 4);
    check(fixed);
  }
  return 0;
}
