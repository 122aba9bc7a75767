// Patch codec (PatchCodec.h, formats/PatchBlob.md): exact round trips, the pinned byte format,
// rejection of every corruption and truncation, vertex-cache optimisation and the compression
// ratio [P-BDAM 2003] §4.4 reports (< 50% of the raw vertex + index data).
#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <thread>
#include <tuple>
#include <vector>

#include "SyntheticPatches.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

using test::gridPatch;
using test::simplifiedPatch;

PatchMesh optimized(PatchMesh mesh) {
  optimizePatchForRendering(mesh);
  return mesh;
}

// Triangles as vertex triples rotated to start at the smallest vertex (orientation kept), sorted.
using Triple = std::array<std::tuple<std::uint16_t, std::uint16_t, std::int32_t>, 3>;
std::vector<Triple> triangleSet(const PatchMesh& mesh) {
  std::vector<Triple> set;
  for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
    Triple tri;
    for (std::size_t c = 0; c < 3; ++c) {
      const PatchVertex& v = mesh.vertices[mesh.indices[3 * t + c]];
      tri[c] = {v.b1, v.b2, v.heightSteps};
    }
    std::rotate(tri.begin(), std::min_element(tri.begin(), tri.end()), tri.end());
    set.push_back(tri);
  }
  std::sort(set.begin(), set.end());
  return set;
}

std::vector<std::byte> encodeOrDie(const PatchMesh& mesh,
                                   PatchCompression compression = PatchCompression::Fast) {
  auto blob = encodePatch(mesh, compression);
  EXPECT_TRUE(blob.ok()) << (blob.ok() ? "" : blob.error().message);
  return blob.ok() ? std::move(blob).value() : std::vector<std::byte>{};
}

void expectRoundTrip(const PatchMesh& mesh) {
  for (PatchCompression compression : {PatchCompression::Compact, PatchCompression::Fast}) {
    const std::vector<std::byte> blob = encodeOrDie(mesh, compression);
    PatchMesh decoded;
    const Result<void> r = decodePatch(blob, decoded, "test");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(decoded, mesh);
  }
}

// A blob assembled by hand from a raw payload (PatchBlob.md), independent of the encoder: the
// LZO1X block is one literal run (first byte 17 + length, at most 238 bytes) and the end marker.
// `declaredRawBytes` overrides the raw size field (0: the payload's size).
std::vector<std::byte> handMadeBlob(std::uint32_t vertices, std::uint32_t triangles,
                                    std::uint32_t wideCodes, const std::vector<std::uint8_t>& raw,
                                    std::uint32_t declaredRawBytes = 0) {
  // Sized up front: GCC 12 at -O2 with sanitizers reports a false -Warray-bounds for
  // push_back followed by insert into a one-element vector.
  std::vector<std::uint8_t> lzo(1 + raw.size() + 3);
  lzo[0] = static_cast<std::uint8_t>(17 + raw.size());
  std::copy(raw.begin(), raw.end(), lzo.begin() + 1);
  lzo[1 + raw.size()] = 0x11;
  std::vector<std::uint8_t> bytes = {'P', 'B', 'P', 'T', 1, 0, 0, 0};
  auto put32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  put32(vertices);
  put32(triangles);
  put32(wideCodes);
  put32(declaredRawBytes != 0 ? declaredRawBytes : static_cast<std::uint32_t>(raw.size()));
  put32(static_cast<std::uint32_t>(lzo.size()));
  put32(0);  // CRC, filled below
  bytes.insert(bytes.end(), lzo.begin(), lzo.end());
  std::vector<std::byte> blob(bytes.size());
  std::memcpy(blob.data(), bytes.data(), bytes.size());
  const std::uint32_t crc = crc32(std::span(blob).subspan(32), crc32(std::span(blob).first(28)));
  for (std::size_t i = 0; i < 4; ++i) blob[28 + i] = static_cast<std::byte>(crc >> (8 * i));
  return blob;
}

void expectCorrupt(std::span<const std::byte> blob, const char* what) {
  PatchMesh out;
  const Result<void> r = decodePatch(blob, out, "face2.pbdam offset 123456");
  ASSERT_FALSE(r.ok()) << what;
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData) << what;
  EXPECT_EQ(r.error().message.rfind("face2.pbdam offset 123456: ", 0), 0U) << r.error().message;
}

// ---- round trips -----------------------------------------------------------------------------

TEST(PatchCodec, RoundTripsRegularGrid) {
  expectRoundTrip(gridPatch(32, 1));
  expectRoundTrip(optimized(gridPatch(32, 2)));
}

TEST(PatchCodec, RoundTripsSimplifiedMesh) { expectRoundTrip(simplifiedPatch(128, 1000, 3)); }

TEST(PatchCodec, RoundTripsSingleTriangleAndEmptyMesh) {
  expectRoundTrip(PatchMesh{{{0, 0, 5}, {32768, 0, -7}, {0, 32768, 123456}}, {0, 1, 2}});
  expectRoundTrip(PatchMesh{});
}

TEST(PatchCodec, RoundTripsLargestPatchAndExtremeValues) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> b(0, 32768);
  std::uniform_int_distribution<std::int32_t> h(std::numeric_limits<std::int32_t>::min(),
                                                std::numeric_limits<std::int32_t>::max());
  PatchMesh mesh;
  mesh.vertices.resize(kPatchMaxVertices);
  for (PatchVertex& v : mesh.vertices) {
    v.b1 = static_cast<std::uint16_t>(b(rng));
    v.b2 = static_cast<std::uint16_t>(b(rng) % (32769 - v.b1));
    v.heightSteps = h(rng);
  }
  mesh.vertices[0] = {32768, 0, std::numeric_limits<std::int32_t>::min()};
  mesh.vertices[1] = {0, 32768, std::numeric_limits<std::int32_t>::max()};
  std::uniform_int_distribution<int> index(0, kPatchMaxVertices - 1);
  mesh.indices.resize(std::size_t{3} * kPatchMaxTriangles);
  for (std::uint16_t& i : mesh.indices) i = static_cast<std::uint16_t>(index(rng));
  mesh.indices[0] = 65534;
  expectRoundTrip(mesh);
}

TEST(PatchCodec, DecodeReusesTheOutputCapacity) {
  const PatchMesh mesh = simplifiedPatch(64, 1000, 4);
  const std::vector<std::byte> blob = encodeOrDie(mesh);
  PatchMesh out;
  ASSERT_TRUE(decodePatch(blob, out, "test").ok());
  const PatchVertex* vertices = out.vertices.data();
  const std::uint16_t* indices = out.indices.data();
  ASSERT_TRUE(decodePatch(encodeOrDie(gridPatch(8, 5)), out, "test").ok());  // smaller
  ASSERT_TRUE(decodePatch(blob, out, "test").ok());
  EXPECT_EQ(out.vertices.data(), vertices);
  EXPECT_EQ(out.indices.data(), indices);
  EXPECT_EQ(out, mesh);
}

TEST(PatchCodec, EncodingIsDeterministic) {
  const PatchMesh mesh = simplifiedPatch(128, 1000, 6);
  const std::vector<std::byte> first = encodeOrDie(mesh);
  std::vector<std::byte> fromThread;
  std::thread([&] { fromThread = encodeOrDie(mesh); }).join();
  EXPECT_EQ(first, encodeOrDie(mesh));
  EXPECT_EQ(first, fromThread);
  PatchMesh again = gridPatch(32, 7);
  PatchMesh other = gridPatch(32, 7);
  optimizePatchForRendering(again);
  optimizePatchForRendering(other);
  EXPECT_EQ(again, other);
}

TEST(PatchCodec, AShapeOptimisedAgainGivesWhatAFreshRunGives) {
  // Orders are reused from the last patch of the same topology (every leaf shares one): with
  // other heights, after other shapes, and on a thread that has seen nothing, the same bytes.
  const PatchMesh first = gridPatch(32, 7);
  const PatchMesh second = gridPatch(32, 8);  // the same grid, other heights
  ASSERT_EQ(first.indices, second.indices);
  ASSERT_NE(first.vertices, second.vertices);
  PatchMesh fresh = second;
  std::thread([&] { optimizePatchForRendering(fresh); }).join();
  PatchMesh reused = first;
  optimizePatchForRendering(reused);
  reused = second;
  optimizePatchForRendering(reused);
  EXPECT_EQ(reused, fresh);
  PatchMesh afterOther = simplifiedPatch(128, 1000, 6);
  optimizePatchForRendering(afterOther);
  afterOther = second;
  optimizePatchForRendering(afterOther);
  EXPECT_EQ(afterOther, fresh);
  EXPECT_NE(fresh.indices, second.indices);  // the orders did change something
}

TEST(PatchCodec, CompressesRealisticPatchesBelowHalf) {
  for (const PatchMesh& mesh : {optimized(gridPatch(32, 8)), simplifiedPatch(128, 1000, 9),
                                simplifiedPatch(256, 1000, 10)}) {
    // The plain representation: 8 bytes per vertex, three 16-bit indices per triangle.
    const std::size_t plain = 8 * mesh.vertices.size() + 6 * mesh.triangleCount();
    const std::vector<std::byte> blob = encodeOrDie(mesh);
    EXPECT_LE(blob.size() * 2, plain) << mesh.vertices.size() << " vertices";
    const Result<PatchBlobInfo> info = inspectPatchBlob(blob, "test");
    ASSERT_TRUE(info.ok());
    EXPECT_EQ(info->vertexCount, mesh.vertices.size());
    EXPECT_EQ(info->triangleCount, mesh.triangleCount());
    EXPECT_EQ(info->rawBytes, 8 * mesh.vertices.size() + (3 * mesh.triangleCount() + 1) / 2 +
                                  std::size_t{2} * info->wideIndexCount);
    EXPECT_LT(info->wideIndexCount, mesh.indices.size() / 5);  // few codes need 16 bits
    EXPECT_EQ(info->compressedBytes + kPatchBlobHeaderBytes, blob.size());
  }
}

// ---- the pinned format -------------------------------------------------------------------------

// Two triangles over the patch's unit square corner; any format change alters these bytes.
TEST(PatchCodec, MatchesGoldenBytes) {
  const PatchMesh mesh{{{0, 0, 64}, {32768, 0, -64}, {0, 32768, 640}, {16384, 16384, 1}},
                       {0, 1, 3, 0, 3, 2}};
  const std::vector<std::uint8_t> golden = {
      // clang-format off
      0x50, 0x42, 0x50, 0x54,  // magic "PBPT"
      0x01, 0x00, 0x00, 0x00,  // version 1, flags 0
      0x04, 0x00, 0x00, 0x00,  // 4 vertices
      0x02, 0x00, 0x00, 0x00,  // 2 triangles
      0x02, 0x00, 0x00, 0x00,  // 2 wide index codes
      0x27, 0x00, 0x00, 0x00,  // raw payload 39 = 4 * 8 + 3 + 2 * 2 bytes
      0x29, 0x00, 0x00, 0x00,  // LZO block 41 bytes
      0x13, 0x03, 0x19, 0x5f,  // CRC-32
      0x06, 0x00, 0xff, 0xff, 0x00, 0x00, 0xff, 0xff, 0x80, 0x00, 0xa0, 0x01,  // LZO1X block
      0x00, 0x06, 0x7f, 0x80, 0xff, 0x80, 0xfd, 0x00, 0x00, 0x05, 0x04, 0x00,
      0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x2f, 0x0f, 0xff, 0xff,
      0xff, 0xff, 0x11, 0x00, 0x00,
      // clang-format on
  };
  const std::vector<std::byte> blob = encodeOrDie(mesh);
  std::vector<std::uint8_t> bytes(blob.size());
  std::memcpy(bytes.data(), blob.data(), blob.size());
  EXPECT_EQ(bytes, golden);
  std::vector<std::byte> goldenBlob(golden.size());
  std::memcpy(goldenBlob.data(), golden.data(), golden.size());
  PatchMesh decoded;
  ASSERT_TRUE(decodePatch(goldenBlob, decoded, "golden").ok());
  EXPECT_EQ(decoded, mesh);
}

TEST(PatchCodec, DecodesAHandMadeBlob) {
  // One triangle (0, 2, 1) over vertices (0,0,h=-1), (32768,0,h=1), (0,32768,h=1): the payload
  // of PatchBlob.md written out: zigzag deltas in byte planes, then the index codes.
  const std::vector<std::uint8_t> raw = {
      0x00, 0xFF, 0xFF,  // b1 = 0, 32768, 0: deltas 0, 0x8000, 0x8000 -> zigzag 0, 0xFFFF, 0xFFFF
      0x00, 0xFF, 0xFF,  //   (high bytes)
      0x00, 0x00, 0xFF,  // b2 = 0, 0, 32768: zigzag 0, 0, 0xFFFF
      0x00, 0x00, 0xFF,  //   (high bytes)
      0x01, 0x04, 0x00,  // h = -1, 1, 1: deltas -1, +2, 0 -> zigzag 1, 4, 0 (byte 0)
      0x00, 0x00, 0x00,  //   (byte 1)
      0x00, 0x00, 0x00,  //   (byte 2)
      0x00, 0x00, 0x00,  //   (byte 3)
      // Index codes (new-vertex count - index): 0 - 0 = 0, 1 - 2 = 0xFFFF (wide), 1 - 1 = 0.
      0xF0, 0x00,  // nibbles 0, 15 (escape) | 0, padding 0
      0xFF, 0xFF,  // the wide code 0xFFFF: low bytes, high bytes
  };
  PatchMesh out;
  const Result<void> r = decodePatch(handMadeBlob(3, 1, 1, raw), out, "hand");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const PatchMesh expected{{{0, 0, -1}, {32768, 0, 1}, {0, 32768, 1}}, {0, 2, 1}};
  EXPECT_EQ(out, expected);
  const Result<PatchBlobInfo> info = inspectPatchBlob(handMadeBlob(3, 1, 1, raw), "hand");
  ASSERT_TRUE(info.ok());
  EXPECT_EQ(info->wideIndexCount, 1U);
  EXPECT_EQ(info->rawBytes, raw.size());
}

// ---- corruption ---------------------------------------------------------------------------------

TEST(PatchCodec, RejectsEverySingleByteCorruption) {
  const std::vector<std::byte> blob = encodeOrDie(optimized(gridPatch(4, 12)));
  for (std::size_t i = 0; i < blob.size(); ++i) {
    for (unsigned flip : {0x01U, 0x80U, 0xFFU}) {
      std::vector<std::byte> bad = blob;
      bad[i] ^= static_cast<std::byte>(flip);
      SCOPED_TRACE(testing::Message() << "byte " << i << " ^ " << flip);
      expectCorrupt(bad, "flipped byte");
    }
  }
}

TEST(PatchCodec, RejectsEveryTruncation) {
  const std::vector<std::byte> blob = encodeOrDie(optimized(gridPatch(4, 13)));
  for (std::size_t size = 0; size < blob.size(); ++size) {
    SCOPED_TRACE(testing::Message() << "size " << size);
    expectCorrupt(std::span(blob).first(size), "truncated");
  }
  std::vector<std::byte> longer = blob;
  longer.push_back(std::byte{0});
  expectCorrupt(longer, "trailing byte");
}

TEST(PatchCodec, RejectsGarbage) {
  std::mt19937 rng(14);
  for (std::size_t size : {1U, 31U, 32U, 33U, 64U, 1000U, 100000U}) {
    std::vector<std::byte> garbage(size);
    for (std::byte& b : garbage) b = static_cast<std::byte>(rng() & 0xFFU);
    expectCorrupt(garbage, "random bytes");
    if (size >= 32) {  // a plausible header in front of random bytes
      const std::vector<std::byte> valid = encodeOrDie(gridPatch(2, 15));
      std::copy_n(valid.begin(), 28, garbage.begin());
      expectCorrupt(garbage, "valid header prefix");
    }
  }
}

TEST(PatchCodec, RejectsBadContentBehindAValidChecksum) {
  const std::vector<std::uint8_t> raw(3 * 8 + 2, 0);  // vertices (0, 0, 0), codes 0, 0, 0
  PatchMesh out;
  ASSERT_TRUE(decodePatch(handMadeBlob(3, 1, 0, raw), out, "hand").ok());
  EXPECT_EQ(out.indices, (std::vector<std::uint16_t>{0, 1, 2}));

  std::vector<std::uint8_t> badIndex = raw;
  badIndex[25] = 0x0F;                            // third code escaped ...
  badIndex.insert(badIndex.end(), {0xFE, 0xFF});  // ... = 0xFFFE: index 2 - 0xFFFE = 4 >= 3
  expectCorrupt(handMadeBlob(3, 1, 1, badIndex), "index out of range");
  expectCorrupt(handMadeBlob(3, 1, 0, {badIndex.begin(), badIndex.end() - 2}),
                "escape without a declared wide code");
  std::vector<std::uint8_t> noEscape = raw;
  noEscape.insert(noEscape.end(), {0x00, 0x00});
  expectCorrupt(handMadeBlob(3, 1, 1, noEscape), "declared wide code without an escape");
  std::vector<std::uint8_t> padding = raw;
  padding[25] = 0x10;
  expectCorrupt(handMadeBlob(3, 1, 0, padding), "non-zero padding nibble");
  std::vector<std::uint8_t> badB = raw;
  badB[2] = 0xFD;  // b1 of vertex 2: delta zigzag 0xFFFD = +0x8001 -> b1 = 32769
  badB[3 + 2] = 0xFF;
  expectCorrupt(handMadeBlob(3, 1, 0, badB), "b1 + b2 > 32768");
  const std::vector<std::uint8_t> shortRaw(raw.begin(), raw.end() - 1);
  expectCorrupt(handMadeBlob(3, 1, 0, shortRaw, 26), "LZO output shorter than declared");
  expectCorrupt(handMadeBlob(3, 1, 0, raw, 27), "raw size not implied by the counts");
  expectCorrupt(handMadeBlob(70000, 0, 0, {}), "too many vertices");
  expectCorrupt(handMadeBlob(0, kPatchMaxTriangles + 1, 0, {}), "too many triangles");
  expectCorrupt(handMadeBlob(0, 1, 4, {}), "more wide codes than indices");
}

// ---- encode preconditions
// ------------------------------------------------------------------------

TEST(PatchCodec, EncodeRejectsInvalidMeshes) {
  const PatchMesh triangle{{{0, 0, 0}, {32768, 0, 0}, {0, 32768, 0}}, {0, 1, 2}};
  auto expectInvalid = [](const PatchMesh& mesh, const char* what) {
    const auto r = encodePatch(mesh);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument) << what;
  };
  PatchMesh tooMany = triangle;
  tooMany.vertices.resize(kPatchMaxVertices + 1);
  expectInvalid(tooMany, "65536 vertices");
  PatchMesh outOfRange = triangle;
  outOfRange.indices[2] = 3;
  expectInvalid(outOfRange, "index out of range");
  const PatchMesh notTriangles{triangle.vertices, {0, 1, 2, 0}};
  expectInvalid(notTriangles, "4 indices");
  PatchMesh b1TooLarge = triangle;
  b1TooLarge.vertices[1].b1 = 32769;
  expectInvalid(b1TooLarge, "b1 > 32768");
  PatchMesh sumTooLarge = triangle;
  sumTooLarge.vertices[1] = {20000, 20000, 0};
  expectInvalid(sumTooLarge, "b1 + b2 > 32768");
}

// ---- rendering order
// -----------------------------------------------------------------------------

TEST(PatchCodec, OptimizeKeepsTrianglesAndImprovesVertexCache) {
  PatchMesh mesh = gridPatch(32, 16);
  std::mt19937 rng(17);
  // Shuffle triangles (keeping each one's corner order) and vertices.
  std::vector<std::array<std::uint16_t, 3>> triangles(mesh.triangleCount());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    triangles[t] = {mesh.indices[3 * t], mesh.indices[3 * t + 1], mesh.indices[3 * t + 2]};
  }
  std::shuffle(triangles.begin(), triangles.end(), rng);
  std::vector<std::uint16_t> permutation(mesh.vertices.size());
  for (std::size_t i = 0; i < permutation.size(); ++i) {
    permutation[i] = static_cast<std::uint16_t>(i);
  }
  std::shuffle(permutation.begin(), permutation.end(), rng);
  PatchMesh shuffled;
  shuffled.vertices.resize(mesh.vertices.size());
  for (std::size_t i = 0; i < permutation.size(); ++i) {
    shuffled.vertices[permutation[i]] = mesh.vertices[i];
  }
  for (const auto& t : triangles) {
    for (std::uint16_t i : t) shuffled.indices.push_back(permutation[i]);
  }
  shuffled.vertices.push_back({1, 1, 1});  // unreferenced: dropped

  PatchMesh result = shuffled;
  optimizePatchForRendering(result);
  EXPECT_EQ(triangleSet(result), triangleSet(mesh));
  EXPECT_EQ(result.vertices.size(), mesh.vertices.size());
  auto acmr = [](const PatchMesh& m) {
    return meshopt_analyzeVertexCache(m.indices.data(), m.indices.size(), m.vertices.size(), 16, 0,
                                      0)
        .acmr;
  };
  EXPECT_LT(acmr(result), 0.8f * acmr(shuffled));
  EXPECT_LT(acmr(result), 0.75f);  // a 32x32 grid can reach ~0.6 with a 16-entry FIFO
  // Vertices are in first-use order.
  std::uint16_t next = 0;
  for (std::uint16_t i : result.indices) {
    ASSERT_LE(i, next);
    if (i == next) ++next;
  }
}

// ---- morph targets ------------------------------------------------------------------------

std::vector<std::int32_t> someTargets(const PatchMesh& mesh) {
  std::vector<std::int32_t> targets;
  std::mt19937 random(11);
  std::uniform_int_distribution<std::int32_t> step(-300, 300);
  for (const PatchVertex& v : mesh.vertices) {
    targets.push_back(random() % 3 == 0 ? v.heightSteps : v.heightSteps + step(random));
  }
  if (!targets.empty()) targets.back() = std::numeric_limits<std::int32_t>::min();
  return targets;
}

TEST(MorphTargets, RoundTripAndAreDeterministic) {
  const PatchMesh mesh = optimized(simplifiedPatch(128, 1000, 3));
  const std::vector<std::int32_t> targets = someTargets(mesh);
  auto blob = encodeMorphTargets(mesh, targets);
  ASSERT_TRUE(blob) << blob.error().message;
  auto again = encodeMorphTargets(mesh, targets);
  ASSERT_TRUE(again);
  EXPECT_EQ(*blob, *again);
  std::vector<std::int32_t> decoded;
  ASSERT_TRUE(decodeMorphTargets(*blob, mesh, decoded, "t"));
  EXPECT_EQ(decoded, targets);
  // Targets equal to the own heights (vertices the coarser surface passes through) cost
  // almost nothing.
  std::vector<std::int32_t> own;
  for (const PatchVertex& v : mesh.vertices) own.push_back(v.heightSteps);
  auto flat = encodeMorphTargets(mesh, own);
  ASSERT_TRUE(flat);
  EXPECT_LT(flat->size(), blob->size() / 4);
}

TEST(MorphTargets, AnEmptyBlobMeansTheOwnHeights) {
  const PatchMesh mesh = optimized(gridPatch(8, 1));
  std::vector<std::int32_t> decoded;
  ASSERT_TRUE(decodeMorphTargets({}, mesh, decoded, "t"));
  ASSERT_EQ(decoded.size(), mesh.vertices.size());
  for (std::size_t v = 0; v < decoded.size(); ++v) {
    EXPECT_EQ(decoded[v], mesh.vertices[v].heightSteps);
  }
}

TEST(MorphTargets, RejectCorruptionTruncationAndAnotherPatch) {
  const PatchMesh mesh = optimized(simplifiedPatch(64, 300, 5));
  auto blob = encodeMorphTargets(mesh, someTargets(mesh));
  ASSERT_TRUE(blob);
  std::vector<std::int32_t> out;
  for (std::size_t k = 0; k < blob->size(); ++k) {
    std::vector<std::byte> bad = *blob;
    bad[k] ^= std::byte{0x5A};
    const auto r = decodeMorphTargets(bad, mesh, out, "face0.pbdam@42");
    ASSERT_FALSE(r) << "byte " << k;
    EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
    EXPECT_NE(r.error().message.find("face0.pbdam@42: morph-target"), std::string::npos)
        << r.error().message;
  }
  for (std::size_t n = 1; n < blob->size(); ++n) {
    EXPECT_FALSE(decodeMorphTargets(std::span(*blob).first(n), mesh, out, "t")) << n;
  }
  const PatchMesh other = optimized(gridPatch(4, 2));
  const auto wrong = decodeMorphTargets(*blob, other, out, "t");
  ASSERT_FALSE(wrong);
  EXPECT_NE(wrong.error().message.find("targets for a patch of"), std::string::npos);
  EXPECT_FALSE(encodeMorphTargets(mesh, std::vector<std::int32_t>(3, 0)));
}

}  // namespace
}  // namespace pbdam::formats
