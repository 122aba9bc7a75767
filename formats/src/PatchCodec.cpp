// Patch codec (PatchCodec.h): delta + zigzag coding, byte planes and one LZO1X block per patch,
// following [P-BDAM 2003] §4.4 (LZO-compressed patches decoded on the fly while paging) with the
// byte-plane split measured in docs/architecture.md "Measured facts". Byte layout:
// formats/PatchBlob.md.
#include "pbdam/formats/PatchCodec.h"

#include <lzo/lzo1x.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cstring>
#include <numeric>
#include <string>

#include "ByteOrder.h"
#include "Lzo.h"
#include "pbdam/formats/Checksum.h"

namespace pbdam::formats {
namespace {

constexpr std::array<std::byte, 4> kMagic = {std::byte{'P'}, std::byte{'B'}, std::byte{'P'},
                                             std::byte{'T'}};
constexpr std::array<std::byte, 4> kMorphMagic = {std::byte{'P'}, std::byte{'B'}, std::byte{'M'},
                                                  std::byte{'T'}};
constexpr std::size_t kMorphCrcOffset = 12;
constexpr std::size_t kCrcOffset = 28;
constexpr std::size_t kBytesPerVertex = 8;  // b1, b2 (2 + 2) and heightSteps (4)
constexpr unsigned kIndexEscape = 15;       // nibble value: the code is in the wide stream
// lzo1x_999 level for PatchCompression::Compact: most of level 9's gain over lzo1x_1 at ~10% of
// its time on 1k-triangle patches (measurements in PatchBlob.md).
constexpr int kCompactLevel = 4;
// Slack after the decoded payload so the branch-free index loop may read one wide code past
// the end of the wide stream (the value is then discarded).
constexpr std::size_t kScratchSlack = 16;

// ---- zigzag on wrapping 16/32-bit deltas ---------------------------------------------------

std::uint16_t zigzag16(std::uint16_t delta) noexcept {
  const unsigned sign = 0U - (static_cast<unsigned>(delta) >> 15);
  return static_cast<std::uint16_t>((static_cast<unsigned>(delta) << 1) ^ sign);
}

std::uint16_t unzigzag16(unsigned z) noexcept {
  return static_cast<std::uint16_t>((z >> 1) ^ (0U - (z & 1U)));
}

std::uint32_t zigzag32(std::uint32_t delta) noexcept { return (delta << 1) ^ (0U - (delta >> 31)); }

std::uint32_t unzigzag32(std::uint32_t z) noexcept { return (z >> 1) ^ (0U - (z & 1U)); }

// Payload size for the given counts (PatchBlob.md): vertex planes, the index nibble plane and
// the two byte planes of the wide index codes.
std::uint64_t rawBytesFor(std::uint64_t vertices, std::uint64_t triangles,
                          std::uint64_t wideCodes) noexcept {
  return vertices * kBytesPerVertex + (triangles * 3 + 1) / 2 + wideCodes * 2;
}

// Index code of `index` given the count of new vertices so far (PatchBlob.md, "Indices").
unsigned indexCode(unsigned newVertices, unsigned index) noexcept {
  return (newVertices - index) & 0xFFFFU;
}

Error corrupt(std::string_view context, std::string_view what) {
  std::string message;
  message.reserve(context.size() + what.size() + 2);
  message.append(context).append(": ").append(what);
  return makeError(ErrorCode::CorruptData, std::move(message));
}

// Fills `raw` with the payload of PatchBlob.md; returns the number of wide index codes.
std::size_t buildPayload(const PatchMesh& mesh, std::vector<unsigned char>& raw) {
  const std::size_t n = mesh.vertices.size();
  const std::size_t indexCount = mesh.indices.size();
  std::size_t wide = 0;
  {
    unsigned newVertices = 0;
    for (const std::uint16_t index : mesh.indices) {
      const unsigned code = indexCode(newVertices, index);
      newVertices += static_cast<unsigned>(code == 0);
      wide += static_cast<std::size_t>(code >= kIndexEscape);
    }
  }
  raw.assign(rawBytesFor(n, indexCount / 3, wide), 0);
  unsigned char* b1Lo = raw.data();
  unsigned char* b1Hi = b1Lo + n;
  unsigned char* b2Lo = b1Hi + n;
  unsigned char* b2Hi = b2Lo + n;
  unsigned char* h0 = b2Hi + n;
  unsigned char* h1 = h0 + n;
  unsigned char* h2 = h1 + n;
  unsigned char* h3 = h2 + n;
  std::uint16_t prevB1 = 0;
  std::uint16_t prevB2 = 0;
  std::uint32_t prevH = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const PatchVertex& v = mesh.vertices[i];
    const std::uint16_t z1 = zigzag16(static_cast<std::uint16_t>(v.b1 - prevB1));
    const std::uint16_t z2 = zigzag16(static_cast<std::uint16_t>(v.b2 - prevB2));
    const auto h = static_cast<std::uint32_t>(v.heightSteps);
    const std::uint32_t zh = zigzag32(h - prevH);
    b1Lo[i] = static_cast<unsigned char>(z1 & 0xFFU);
    b1Hi[i] = static_cast<unsigned char>(z1 >> 8);
    b2Lo[i] = static_cast<unsigned char>(z2 & 0xFFU);
    b2Hi[i] = static_cast<unsigned char>(z2 >> 8);
    h0[i] = static_cast<unsigned char>(zh & 0xFFU);
    h1[i] = static_cast<unsigned char>((zh >> 8) & 0xFFU);
    h2[i] = static_cast<unsigned char>((zh >> 16) & 0xFFU);
    h3[i] = static_cast<unsigned char>(zh >> 24);
    prevB1 = v.b1;
    prevB2 = v.b2;
    prevH = h;
  }
  unsigned char* nibbles = h3 + n;
  unsigned char* wideLo = nibbles + (indexCount + 1) / 2;
  unsigned char* wideHi = wideLo + wide;
  unsigned newVertices = 0;
  std::size_t w = 0;
  for (std::size_t k = 0; k < indexCount; ++k) {
    const unsigned code = indexCode(newVertices, mesh.indices[k]);
    newVertices += static_cast<unsigned>(code == 0);
    const unsigned nibble = std::min(code, kIndexEscape);
    nibbles[k / 2] = static_cast<unsigned char>(nibbles[k / 2] | (nibble << (4 * (k & 1))));
    if (code >= kIndexEscape) {
      wideLo[w] = static_cast<unsigned char>(code & 0xFFU);
      wideHi[w] = static_cast<unsigned char>(code >> 8);
      ++w;
    }
  }
  return wide;
}

// Parses and checks the header; on success fills `info`.
Result<PatchBlobInfo> readHeader(std::span<const std::byte> blob, std::string_view context) {
  if (blob.size() < kPatchBlobHeaderBytes) {
    return corrupt(context, "patch blob of " + std::to_string(blob.size()) +
                                " bytes is shorter than its 32-byte header");
  }
  const std::byte* p = blob.data();
  if (std::memcmp(p, kMagic.data(), kMagic.size()) != 0) {
    return corrupt(context, "patch blob has a bad magic number");
  }
  const std::uint16_t version = getU16(p + 4);
  if (version != kPatchBlobVersion) {
    return corrupt(context, "patch blob version " + std::to_string(version) +
                                " is not the supported version " +
                                std::to_string(kPatchBlobVersion));
  }
  if (getU16(p + 6) != 0) return corrupt(context, "patch blob has unknown flags set");
  PatchBlobInfo info;
  info.vertexCount = getU32(p + 8);
  info.triangleCount = getU32(p + 12);
  info.wideIndexCount = getU32(p + 16);
  info.rawBytes = getU32(p + 20);
  info.compressedBytes = getU32(p + 24);
  if (info.vertexCount > kPatchMaxVertices) {
    return corrupt(context, "patch vertex count " + std::to_string(info.vertexCount) + " exceeds " +
                                std::to_string(kPatchMaxVertices));
  }
  if (info.triangleCount > kPatchMaxTriangles) {
    return corrupt(context, "patch triangle count " + std::to_string(info.triangleCount) +
                                " exceeds " + std::to_string(kPatchMaxTriangles));
  }
  if (info.wideIndexCount > std::uint64_t{info.triangleCount} * 3) {
    return corrupt(context, "patch wide index count " + std::to_string(info.wideIndexCount) +
                                " exceeds its index count");
  }
  if (info.rawBytes != rawBytesFor(info.vertexCount, info.triangleCount, info.wideIndexCount)) {
    return corrupt(context, "patch raw size " + std::to_string(info.rawBytes) +
                                " does not match its vertex and triangle counts");
  }
  if (info.compressedBytes != blob.size() - kPatchBlobHeaderBytes) {
    return corrupt(context, "patch compressed size " + std::to_string(info.compressedBytes) +
                                " does not match the blob size " + std::to_string(blob.size()));
  }
  if (info.compressedBytes > lzoWorstCaseBytes(info.rawBytes)) {
    return corrupt(context, "patch compressed size exceeds the LZO bound of its raw size");
  }
  return info;
}

// CRC-32 of the blob without its CRC field (the header's last field).
std::uint32_t blobCrc(std::span<const std::byte> blob) noexcept {
  const std::uint32_t head = crc32(blob.first(kCrcOffset));
  return crc32(blob.subspan(kPatchBlobHeaderBytes), head);
}

}  // namespace

void optimizePatchForRendering(PatchMesh& mesh) {
  const std::size_t indexCount = mesh.indices.size();
  assert(std::all_of(mesh.indices.begin(), mesh.indices.end(),
                     [&](std::uint16_t i) { return i < mesh.vertices.size(); }));
  if (indexCount == 0) {
    mesh.vertices.clear();
    return;
  }
  // Both orders depend on the indices alone, and many patches share theirs (every leaf of a
  // dataset has the same grid): the last topology's result is reused on each thread. The fetch
  // order is found by reordering vertex numbers, so a reuse gives the very bytes a fresh run
  // would.
  struct Orders {
    std::size_t vertexCount = 0;
    std::vector<std::uint16_t> input;
    std::vector<std::uint16_t> ordered;  // the cache order, indices already renumbered
    std::vector<std::uint32_t> source;   // new vertex k is old vertex source[k]
  };
  thread_local Orders last;
  if (last.vertexCount != mesh.vertices.size() || last.input != mesh.indices) {
    last.vertexCount = mesh.vertices.size();
    last.input = mesh.indices;
    last.ordered.resize(indexCount);
    meshopt_optimizeVertexCache(last.ordered.data(), mesh.indices.data(), indexCount,
                                mesh.vertices.size());
    std::vector<std::uint32_t> numbers(mesh.vertices.size());
    std::iota(numbers.begin(), numbers.end(), 0U);
    last.source.resize(mesh.vertices.size());
    const std::size_t used =
        meshopt_optimizeVertexFetch(last.source.data(), last.ordered.data(), indexCount,
                                    numbers.data(), numbers.size(), sizeof(std::uint32_t));
    last.source.resize(used);
  }
  std::vector<PatchVertex> fetched(last.source.size());
  for (std::size_t k = 0; k < fetched.size(); ++k) fetched[k] = mesh.vertices[last.source[k]];
  mesh.indices = last.ordered;
  mesh.vertices = std::move(fetched);
}

Result<std::vector<std::byte>> encodePatch(const PatchMesh& mesh, PatchCompression compression) {
  const std::size_t n = mesh.vertices.size();
  if (n > kPatchMaxVertices) {
    return invalidArgument("patch has " + std::to_string(n) + " vertices; at most " +
                           std::to_string(kPatchMaxVertices) + " fit 16-bit indices");
  }
  if (mesh.indices.size() % 3 != 0) {
    return invalidArgument("patch index count " + std::to_string(mesh.indices.size()) +
                           " is not a multiple of 3");
  }
  const std::size_t triangles = mesh.indices.size() / 3;
  if (triangles > kPatchMaxTriangles) {
    return invalidArgument("patch has " + std::to_string(triangles) + " triangles; at most " +
                           std::to_string(kPatchMaxTriangles) + " are allowed");
  }
  for (std::size_t k = 0; k < mesh.indices.size(); ++k) {
    if (mesh.indices[k] >= n) {
      return invalidArgument("patch index " + std::to_string(k) + " = " +
                             std::to_string(mesh.indices[k]) + " is out of range for " +
                             std::to_string(n) + " vertices");
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const PatchVertex& v = mesh.vertices[i];
    if (std::uint32_t{v.b1} + v.b2 > kPatchBarycentricOne) {
      return invalidArgument("patch vertex " + std::to_string(i) + " has b1 + b2 = " +
                             std::to_string(std::uint32_t{v.b1} + v.b2) + " > 32768");
    }
  }
  if (!lzoReady()) return makeError(ErrorCode::Internal, "lzo_init failed");

  thread_local std::vector<unsigned char> raw;
  thread_local std::vector<unsigned char> workMemory(
      std::max<std::size_t>(LZO1X_999_MEM_COMPRESS, LZO1X_1_MEM_COMPRESS));
  const std::size_t wide = buildPayload(mesh, raw);

  std::vector<std::byte> blob(kPatchBlobHeaderBytes + lzoWorstCaseBytes(raw.size()));
  auto* dst = reinterpret_cast<unsigned char*>(blob.data() + kPatchBlobHeaderBytes);
  lzo_uint compressed = blob.size() - kPatchBlobHeaderBytes;
  const int rc =
      compression == PatchCompression::Fast
          ? lzo1x_1_compress(raw.data(), raw.size(), dst, &compressed, workMemory.data())
          : lzo1x_999_compress_level(raw.data(), raw.size(), dst, &compressed, workMemory.data(),
                                     nullptr, 0, nullptr, kCompactLevel);
  if (rc != LZO_E_OK) {
    return makeError(ErrorCode::Internal, "LZO compression failed with " + std::to_string(rc));
  }
  blob.resize(kPatchBlobHeaderBytes + compressed);

  std::byte* h = blob.data();
  std::memcpy(h, kMagic.data(), kMagic.size());
  putU16(h + 4, kPatchBlobVersion);
  putU16(h + 6, 0);
  putU32(h + 8, static_cast<std::uint32_t>(n));
  putU32(h + 12, static_cast<std::uint32_t>(triangles));
  putU32(h + 16, static_cast<std::uint32_t>(wide));
  putU32(h + 20, static_cast<std::uint32_t>(raw.size()));
  putU32(h + 24, static_cast<std::uint32_t>(compressed));
  putU32(h + kCrcOffset, blobCrc(blob));
  return blob;
}

Result<PatchBlobInfo> inspectPatchBlob(std::span<const std::byte> blob, std::string_view context) {
  return readHeader(blob, context);
}

Result<void> decodePatch(std::span<const std::byte> blob, PatchMesh& out,
                         std::string_view context) {
  auto header = readHeader(blob, context);
  if (!header) return std::move(header).error();
  const PatchBlobInfo info = *header;
  const std::uint32_t storedCrc = getU32(blob.data() + kCrcOffset);
  const std::uint32_t actualCrc = blobCrc(blob);
  if (storedCrc != actualCrc) return corrupt(context, "patch blob CRC-32 mismatch");
  if (!lzoReady()) return makeError(ErrorCode::Internal, "lzo_init failed");

  // Decompress into exactly rawBytes; the buffer only grows, so steady state allocates nothing.
  thread_local std::vector<unsigned char> raw;
  if (raw.size() < std::size_t{info.rawBytes} + kScratchSlack) {
    raw.resize(std::size_t{info.rawBytes} + kScratchSlack);
  }
  lzo_uint produced = info.rawBytes;
  const auto* src = reinterpret_cast<const unsigned char*>(blob.data() + kPatchBlobHeaderBytes);
  const int rc = lzo1x_decompress_safe(src, info.compressedBytes, raw.data(), &produced, nullptr);
  if (rc != LZO_E_OK || produced != info.rawBytes) {
    return corrupt(context, "patch LZO block does not decompress to its declared " +
                                std::to_string(info.rawBytes) + " bytes (lzo error " +
                                std::to_string(rc) + ")");
  }

  const std::size_t n = info.vertexCount;
  const std::size_t indexCount = std::size_t{info.triangleCount} * 3;
  const std::size_t wideCount = info.wideIndexCount;
  const unsigned char* nibbles = raw.data() + n * kBytesPerVertex;
  const std::size_t nibbleBytes = (indexCount + 1) / 2;
  // The escape nibbles must match the declared wide codes exactly (the index loop below relies
  // on it to stay inside the wide stream), and an odd count's padding nibble must be 0.
  std::size_t escapes = 0;
  for (std::size_t j = 0; j < nibbleBytes; ++j) {
    escapes += static_cast<std::size_t>((nibbles[j] & 0x0FU) == kIndexEscape) +
               static_cast<std::size_t>((nibbles[j] >> 4) == kIndexEscape);
  }
  if (escapes != wideCount || (indexCount % 2 == 1 && (nibbles[nibbleBytes - 1] >> 4) != 0)) {
    return corrupt(context, "patch index stream does not match its " + std::to_string(wideCount) +
                                " wide codes");
  }

  out.vertices.resize(n);
  out.indices.resize(indexCount);

  const unsigned char* b1Lo = raw.data();
  const unsigned char* b1Hi = b1Lo + n;
  const unsigned char* b2Lo = b1Hi + n;
  const unsigned char* b2Hi = b2Lo + n;
  const unsigned char* h0 = b2Hi + n;
  const unsigned char* h1 = h0 + n;
  const unsigned char* h2 = h1 + n;
  const unsigned char* h3 = h2 + n;
  PatchVertex* vertices = out.vertices.data();
  unsigned b1 = 0;
  unsigned b2 = 0;
  std::uint32_t h = 0;
  unsigned badBarycentric = 0;
  for (std::size_t i = 0; i < n; ++i) {
    b1 = (b1 + unzigzag16(b1Lo[i] | (unsigned{b1Hi[i]} << 8))) & 0xFFFFU;
    b2 = (b2 + unzigzag16(b2Lo[i] | (unsigned{b2Hi[i]} << 8))) & 0xFFFFU;
    const std::uint32_t zh = std::uint32_t{h0[i]} | (std::uint32_t{h1[i]} << 8) |
                             (std::uint32_t{h2[i]} << 16) | (std::uint32_t{h3[i]} << 24);
    h += unzigzag32(zh);
    badBarycentric |= static_cast<unsigned>(b1 + b2 > kPatchBarycentricOne);
    vertices[i] = PatchVertex{static_cast<std::uint16_t>(b1), static_cast<std::uint16_t>(b2),
                              static_cast<std::int32_t>(h)};
  }
  if (badBarycentric != 0) {
    return corrupt(context, "patch vertex has b1 + b2 > 32768");
  }

  // Branch-free: the wide stream is read at every index (at most one code past its end, into
  // the scratch slack) and the value used only behind an escape nibble.
  const unsigned char* wideLo = nibbles + nibbleBytes;
  const unsigned char* wideHi = wideLo + wideCount;
  std::uint16_t* indices = out.indices.data();
  unsigned newVertices = 0;
  std::size_t w = 0;
  unsigned badIndex = 0;
  const auto vertexCount = static_cast<unsigned>(n);
  const auto decodeOne = [&](unsigned nibble) noexcept {
    const unsigned wideCode = wideLo[w] | (unsigned{wideHi[w]} << 8);
    const bool escaped = nibble == kIndexEscape;
    const unsigned code = escaped ? wideCode : nibble;
    w += static_cast<std::size_t>(escaped);
    const unsigned index = indexCode(newVertices, code);  // newVertices - code, 16 bits
    newVertices += static_cast<unsigned>(code == 0);
    badIndex |= static_cast<unsigned>(index >= vertexCount);
    return static_cast<std::uint16_t>(index);
  };
  const std::size_t pairs = indexCount / 2;
  for (std::size_t j = 0; j < pairs; ++j) {
    const unsigned byte = nibbles[j];
    indices[2 * j] = decodeOne(byte & 0x0FU);
    indices[2 * j + 1] = decodeOne(byte >> 4);
  }
  if (indexCount % 2 == 1) indices[indexCount - 1] = decodeOne(nibbles[pairs] & 0x0FU);
  if (badIndex != 0) {
    return corrupt(context, "patch index out of range for " + std::to_string(n) + " vertices");
  }
  return {};
}

// ---- morph targets (PatchBlob.md, "Morph targets") ------------------------------------------

namespace {

std::uint32_t morphBlobCrc(std::span<const std::byte> blob) noexcept {
  const std::uint32_t head = crc32(blob.first(kMorphCrcOffset));
  return crc32(blob.subspan(kMorphBlobHeaderBytes), head);
}

}  // namespace

Result<std::vector<std::byte>> encodeMorphTargets(const PatchMesh& mesh,
                                                  std::span<const std::int32_t> targets) {
  const std::size_t n = mesh.vertices.size();
  if (targets.size() != n) {
    return invalidArgument(std::to_string(targets.size()) + " morph targets for a patch of " +
                           std::to_string(n) + " vertices");
  }
  if (n > kPatchMaxVertices) {
    return invalidArgument("patch has " + std::to_string(n) + " vertices; at most " +
                           std::to_string(kPatchMaxVertices) + " are allowed");
  }
  if (!lzoReady()) return makeError(ErrorCode::Internal, "lzo_init failed");
  thread_local std::vector<unsigned char> raw;
  thread_local std::vector<unsigned char> workMemory(LZO1X_1_MEM_COMPRESS);
  raw.assign(4 * n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t z = zigzag32(static_cast<std::uint32_t>(targets[i]) -
                                     static_cast<std::uint32_t>(mesh.vertices[i].heightSteps));
    for (std::size_t plane = 0; plane < 4; ++plane) {
      raw[plane * n + i] = static_cast<unsigned char>((z >> (8 * plane)) & 0xFFU);
    }
  }
  std::vector<std::byte> blob(kMorphBlobHeaderBytes + lzoWorstCaseBytes(raw.size()));
  auto* dst = reinterpret_cast<unsigned char*>(blob.data() + kMorphBlobHeaderBytes);
  lzo_uint compressed = blob.size() - kMorphBlobHeaderBytes;
  if (const int rc = lzo1x_1_compress(raw.data(), raw.size(), dst, &compressed, workMemory.data());
      rc != LZO_E_OK) {
    return makeError(ErrorCode::Internal, "LZO compression failed with " + std::to_string(rc));
  }
  blob.resize(kMorphBlobHeaderBytes + compressed);
  std::byte* h = blob.data();
  std::memcpy(h, kMorphMagic.data(), kMorphMagic.size());
  putU16(h + 4, kMorphBlobVersion);
  putU16(h + 6, 0);
  putU32(h + 8, static_cast<std::uint32_t>(n));
  putU32(h + kMorphCrcOffset, morphBlobCrc(blob));
  return blob;
}

Result<void> decodeMorphTargets(std::span<const std::byte> blob, const PatchMesh& mesh,
                                std::vector<std::int32_t>& out, std::string_view context) {
  const std::size_t n = mesh.vertices.size();
  out.resize(n);
  if (blob.empty()) {
    for (std::size_t i = 0; i < n; ++i) out[i] = mesh.vertices[i].heightSteps;
    return {};
  }
  if (blob.size() < kMorphBlobHeaderBytes) {
    return corrupt(context, "morph-target blob of " + std::to_string(blob.size()) +
                                " bytes is shorter than its 16-byte header");
  }
  const std::byte* p = blob.data();
  if (std::memcmp(p, kMorphMagic.data(), kMorphMagic.size()) != 0) {
    return corrupt(context, "morph-target blob has a bad magic number");
  }
  if (const std::uint16_t version = getU16(p + 4); version != kMorphBlobVersion) {
    return corrupt(context, "morph-target blob version " + std::to_string(version) +
                                " is not the supported version " +
                                std::to_string(kMorphBlobVersion));
  }
  if (getU16(p + 6) != 0) return corrupt(context, "morph-target blob has unknown flags set");
  if (const std::uint32_t count = getU32(p + 8); count != n) {
    return corrupt(context, "morph-target blob holds " + std::to_string(count) +
                                " targets for a patch of " + std::to_string(n) + " vertices");
  }
  const std::size_t compressedBytes = blob.size() - kMorphBlobHeaderBytes;
  if (compressedBytes > lzoWorstCaseBytes(4 * n)) {
    return corrupt(context, "morph-target blob exceeds the LZO bound of its raw size");
  }
  if (getU32(p + kMorphCrcOffset) != morphBlobCrc(blob)) {
    return corrupt(context, "morph-target blob CRC-32 mismatch");
  }
  if (!lzoReady()) return makeError(ErrorCode::Internal, "lzo_init failed");
  thread_local std::vector<unsigned char> raw;
  raw.resize(4 * n);
  lzo_uint produced = raw.size();
  const auto* src = reinterpret_cast<const unsigned char*>(p + kMorphBlobHeaderBytes);
  const int rc = lzo1x_decompress_safe(src, compressedBytes, raw.data(), &produced, nullptr);
  if (rc != LZO_E_OK || produced != raw.size()) {
    return corrupt(context, "morph-target LZO block does not decompress to its " +
                                std::to_string(raw.size()) + " bytes (lzo error " +
                                std::to_string(rc) + ")");
  }
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t z = std::uint32_t{raw[i]} | (std::uint32_t{raw[n + i]} << 8) |
                            (std::uint32_t{raw[2 * n + i]} << 16) |
                            (std::uint32_t{raw[3 * n + i]} << 24);
    out[i] = static_cast<std::int32_t>(static_cast<std::uint32_t>(mesh.vertices[i].heightSteps) +
                                       unzigzag32(z));
  }
  return {};
}

}  // namespace pbdam::formats
