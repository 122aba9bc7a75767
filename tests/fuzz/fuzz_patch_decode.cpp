// libFuzzer target for the patch decoder (PatchCodec.h; LZO-compressed patches of [P-BDAM 2003]
// §4.4): untrusted blobs must decode or fail cleanly, never read or write out of bounds. Each
// input is decoded as given and again with its size field and CRC repaired, so that mutations
// reach the LZO stream and the payload checks behind the checksum; whatever decodes must
// re-encode and decode to the same mesh.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/PatchCodec.h"

namespace {

void check(bool condition) {
  if (!condition) std::abort();
}

void decodeAndVerify(std::span<const std::byte> blob) {
  static pbdam::formats::PatchMesh mesh;  // reused across inputs, as the streaming decoder does
  const pbdam::formats::Result<pbdam::formats::PatchBlobInfo> info =
      pbdam::formats::inspectPatchBlob(blob, "fuzz");
  const pbdam::formats::Result<void> decoded = pbdam::formats::decodePatch(blob, mesh, "fuzz");
  if (!decoded.ok()) {
    check(decoded.error().code == pbdam::formats::ErrorCode::CorruptData);
    return;
  }
  check(info.ok());
  check(mesh.vertices.size() == info->vertexCount);
  check(mesh.triangleCount() == info->triangleCount);
  auto again = pbdam::formats::encodePatch(mesh);
  check(again.ok());
  pbdam::formats::PatchMesh roundTrip;
  check(pbdam::formats::decodePatch(*again, roundTrip, "fuzz re-encoded").ok());
  check(roundTrip == mesh);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto* bytes = reinterpret_cast<const std::byte*>(data);
  decodeAndVerify(std::span(bytes, size));

  if (size >= pbdam::formats::kPatchBlobHeaderBytes) {
    std::vector<std::byte> fixed(bytes, bytes + size);
    const auto put32 = [&](std::size_t offset, std::uint32_t value) {
      for (std::size_t i = 0; i < 4; ++i) {
        fixed[offset + i] = static_cast<std::byte>((value >> (8 * i)) & 0xFFU);
      }
    };
    put32(24,
          static_cast<std::uint32_t>(size - pbdam::formats::kPatchBlobHeaderBytes));  // LZO size
    const std::span<const std::byte> all(fixed);
    put32(28,
          pbdam::formats::crc32(all.subspan(32), pbdam::formats::crc32(all.first(28))));  // CRC-32
    decodeAndVerify(fixed);
  }
  return 0;
}
