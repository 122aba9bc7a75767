// The payloads of the build checkpoint's part files (Checkpoint.h, docs/builder.md
// "Checkpoints"): the nodes and texture part footers and entries, the carry records (narrow and
// wide patches) and the carry index round-trip byte for byte, and damaged ones are rejected
// with an error that names the file.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <fstream>
#include <iterator>

#include "TestData.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/formats/Checksum.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

std::vector<std::byte> concat(std::vector<std::byte> a, const std::vector<std::byte>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

/// Overwrites the u64 at `at` (little-endian, as the files store it).
void putU64At(std::vector<std::byte>& bytes, std::size_t at, std::uint64_t value) {
  const auto b = std::bit_cast<std::array<std::byte, 8>>(value);
  std::copy(b.begin(), b.end(), bytes.begin() + static_cast<std::ptrdiff_t>(at));
}

WorkPatch patchWithin(std::int32_t maxCoordinate) {
  WorkPatch p;
  p.points = {LatticeXY{0, 0}, LatticeXY{maxCoordinate, 0}, LatticeXY{0, 7}, LatticeXY{3, 5}};
  p.indices = {0, 1, 3, 0, 3, 2};
  return p;
}

TEST(CheckpointFormat, LevelFooterRoundTrips) {
  const LevelPartFooter footer{48, 96, 191, 3, 1, 123456789, 2.5};
  const auto bytes = encodeLevelPartFooter(footer);
  ASSERT_EQ(bytes.size(), LevelPartFooter::kBytes);
  auto decoded = decodeLevelPartFooter(bytes, "f");
  ASSERT_TRUE(decoded) << decoded.error().message;
  EXPECT_EQ(decoded->firstDiamond, 48u);
  EXPECT_EQ(decoded->diamonds, 96u);
  EXPECT_EQ(decoded->nodes, 191u);
  EXPECT_EQ(decoded->insertedPoints, 3u);
  EXPECT_EQ(decoded->halvesOverTarget, 1u);
  EXPECT_EQ(decoded->patchBytesRaw, 123456789u);
  EXPECT_EQ(decoded->seconds, 2.5);
}

TEST(CheckpointFormat, NodeEntriesRoundTripThroughALevelPart) {
  std::array<std::byte, kNodeRecordBytes> recordA{};
  std::array<std::byte, kNodeRecordBytes> recordB{};
  recordA.fill(std::byte{0x11});
  recordB.fill(std::byte{0x22});
  const std::vector<std::byte> blobA(5, std::byte{0xAA});
  const std::vector<std::byte> blobB(9, std::byte{0xBB});
  ByteWriter w;
  putNodeEntry(w, 7, recordA, blobA);
  putNodeEntry(w, 8, recordB, blobB);
  const auto payload =
      concat(w.take(), encodeLevelPartFooter(LevelPartFooter{0, 1, 2, 0, 0, 0, 0}));
  auto view = LevelPartView::parse(payload, "level-04.part-0.nodes");
  ASSERT_TRUE(view) << view.error().message;
  std::vector<std::uint64_t> ids;
  auto walked = view->forEachNode([&](const NodeEntry& node, std::size_t) {
    ids.push_back(node.id);
    const auto& record = node.id == 7 ? recordA : recordB;
    EXPECT_TRUE(std::equal(node.record.begin(), node.record.end(), record.begin()));
    EXPECT_EQ(node.blob.size(), node.id == 7 ? 5u : 9u);
    return true;
  });
  EXPECT_TRUE(walked) << walked.error().message;
  EXPECT_EQ(ids, (std::vector<std::uint64_t>{7, 8}));
}

TEST(CheckpointFormat, RejectsADamagedLevelPart) {
  ByteWriter w;
  std::array<std::byte, kNodeRecordBytes> record{};
  putNodeEntry(w, 1, record, std::vector<std::byte>(4));
  putNodeEntry(w, 2, record, std::vector<std::byte>(4));
  const auto entries = w.take();
  // Too short for a footer.
  auto shortPayload = LevelPartView::parse(std::vector<std::byte>(10), "a.nodes");
  ASSERT_FALSE(shortPayload);
  EXPECT_EQ(shortPayload.error().code, ErrorCode::CorruptData);
  EXPECT_NE(shortPayload.error().message.find("a.nodes: truncated"), std::string::npos);
  // The footer promises more nodes than the entries hold.
  const auto cut = concat(std::vector<std::byte>(entries.begin(), entries.end() - 3),
                          encodeLevelPartFooter(LevelPartFooter{0, 1, 2, 0, 0, 0, 0}));
  auto view = LevelPartView::parse(cut, "b.nodes");
  ASSERT_TRUE(view);
  auto walked = view->forEachNode([](const NodeEntry&, std::size_t) { return true; });
  ASSERT_FALSE(walked);
  EXPECT_EQ(walked.error().message, "b.nodes: truncated");
  // Bytes left over after the entries the footer names.
  const auto extra = concat(entries, encodeLevelPartFooter(LevelPartFooter{0, 0, 0, 0, 0, 0, 0}));
  auto extraView = LevelPartView::parse(extra, "c.nodes");
  ASSERT_TRUE(extraView);
  EXPECT_FALSE(extraView->forEachNode([](const NodeEntry&, std::size_t) { return true; }));
  // A wrong-sized footer on its own.
  EXPECT_FALSE(decodeLevelPartFooter(std::vector<std::byte>(LevelPartFooter::kBytes - 1), "d"));
}

TEST(CheckpointFormat, TexturePartRoundTripsAndRejectsDamage) {
  ByteWriter w;
  putTileEntry(w, 1.5f, std::vector<std::byte>(3, std::byte{1}),
               std::vector<std::byte>(2, std::byte{5}));
  putTileEntry(w, 2.5f, std::vector<std::byte>(6, std::byte{2}),
               std::vector<std::byte>(4, std::byte{6}));
  const auto entries = w.take();
  const auto payload = concat(entries, encodeTexturePartFooter(TexturePartFooter{10, 2, 0.25}));
  auto view = TexturePartView::parse(payload, "texture.part-0.tiles");
  ASSERT_TRUE(view) << view.error().message;
  EXPECT_EQ(view->footer().firstTile, 10u);
  EXPECT_EQ(view->footer().tiles, 2u);
  EXPECT_EQ(view->footer().seconds, 0.25);
  std::vector<std::pair<std::uint64_t, float>> seen;
  auto walked = view->forEachTile([&](std::uint64_t k, float e, std::span<const std::byte> colour,
                                      std::span<const std::byte> normal) {
    seen.emplace_back(k, e);
    EXPECT_EQ(colour.size(), k == 10 ? 3u : 6u);
    EXPECT_EQ(normal.size(), k == 10 ? 2u : 4u);
    EXPECT_EQ(normal[0], k == 10 ? std::byte{5} : std::byte{6});
    return true;
  });
  EXPECT_TRUE(walked);
  EXPECT_EQ(seen, (std::vector<std::pair<std::uint64_t, float>>{{10, 1.5f}, {11, 2.5f}}));

  const auto damaged = concat(std::vector<std::byte>(entries.begin(), entries.end() - 1),
                              encodeTexturePartFooter(TexturePartFooter{10, 2, 0.25}));
  auto damagedView = TexturePartView::parse(damaged, "t.tiles");
  ASSERT_TRUE(damagedView);
  auto failed = damagedView->forEachTile([](std::uint64_t, float, auto, auto) { return true; });
  ASSERT_FALSE(failed);
  EXPECT_EQ(failed.error().message, "t.tiles: incomplete");
  auto tooShort = TexturePartView::parse(std::vector<std::byte>(5), "u.tiles");
  ASSERT_FALSE(tooShort);
  EXPECT_EQ(tooShort.error().message, "u.tiles: incomplete");
}

/// Carry records of one narrow (16-bit) and one wide (32-bit) patch and one without a patch,
/// and the index after them, as a level writes its carry part.
struct CarryFixture {
  std::vector<std::byte> payload;
  CarrySaturation saturation{0.75f, glm::dvec3(1.0e6, -2.5e6, 3.25), 1234.5f, 0.5f};
  WorkPatch narrow = patchWithin(65535);
  WorkPatch wide = patchWithin(70000);

  CarryFixture() {
    ByteWriter w;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> index;
    index.emplace_back(40, w.bytes().size());
    putCarryRecord(w, saturation, &narrow);
    index.emplace_back(12, w.bytes().size());
    putCarryRecord(w, saturation, &wide);
    index.emplace_back(25, w.bytes().size());
    putCarryRecord(w, saturation, nullptr);
    payload = concat(w.take(), encodeCarryIndex(index));
  }
};

TEST(CheckpointFormat, CarryRecordsAndIndexRoundTrip) {
  const CarryFixture f;
  auto view = CarryPartView::parse(f.payload, "level-03.part-0.carry");
  ASSERT_TRUE(view) << view.error().message;
  for (const auto& [id, expected] : {std::pair<std::uint64_t, const WorkPatch*>{40, &f.narrow},
                                     std::pair<std::uint64_t, const WorkPatch*>{12, &f.wide}}) {
    const auto offset = view->offsetOf(id);
    ASSERT_TRUE(offset) << id;
    CarrySaturation s;
    WorkPatch patch;
    ASSERT_TRUE(view->read(*offset, s, &patch)) << id;
    EXPECT_EQ(s.errorMeters, f.saturation.errorMeters);
    EXPECT_EQ(s.sphereCenter, f.saturation.sphereCenter);
    EXPECT_EQ(s.sphereRadiusMeters, f.saturation.sphereRadiusMeters);
    EXPECT_EQ(s.floorMeters, f.saturation.floorMeters);
    EXPECT_EQ(patch.points, expected->points);
    EXPECT_EQ(patch.indices, expected->indices);
  }
  // A record without a patch serves the saturation only.
  const auto offset = view->offsetOf(25);
  ASSERT_TRUE(offset);
  CarrySaturation s;
  EXPECT_TRUE(view->read(*offset, s, nullptr));
  WorkPatch patch;
  EXPECT_FALSE(view->read(*offset, s, &patch)) << "asked for a patch the record does not hold";
  EXPECT_FALSE(view->offsetOf(26));
  EXPECT_FALSE(view->offsetOf(0));
}

TEST(CheckpointFormat, RejectsADamagedCarry) {
  const CarryFixture f;
  // No room for the index count.
  auto empty = CarryPartView::parse(std::vector<std::byte>(7), "a.carry");
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().code, ErrorCode::CorruptData);
  EXPECT_EQ(empty.error().message, "a.carry: no index");
  // An index count larger than the payload can hold.
  std::vector<std::byte> badCount = f.payload;
  putU64At(badCount, badCount.size() - 8, badCount.size());
  auto bad = CarryPartView::parse(badCount, "b.carry");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message, "b.carry: bad index");
  // A record whose patch width is neither 2 nor 4, and one cut short.
  auto view = CarryPartView::parse(f.payload, "c.carry");
  ASSERT_TRUE(view);
  const std::size_t widthAt = 4 + 3 * 8 + 4 + 1 + 4;  // error, centre, radius, flag, points
  std::vector<std::byte> badWidth = f.payload;
  badWidth[widthAt] = std::byte{3};
  auto badWidthView = CarryPartView::parse(badWidth, "d.carry");
  ASSERT_TRUE(badWidthView);
  CarrySaturation s;
  WorkPatch patch;
  EXPECT_FALSE(badWidthView->read(*badWidthView->offsetOf(40), s, &patch));
  ByteWriter w;
  putCarryRecord(w, f.saturation, &f.wide);
  const auto record = w.take();
  ByteReader cut(std::span<const std::byte>(record).first(record.size() - 1));
  EXPECT_FALSE(getCarryRecord(cut, s, &patch));
  // An index entry pointing past the records is not found.
  std::vector<std::byte> badOffset = f.payload;
  const std::size_t firstEntry = badOffset.size() - 8 - std::size_t{3} * 16;
  putU64At(badOffset, firstEntry + 8, badOffset.size());
  auto badOffsetView = CarryPartView::parse(badOffset, "e.carry");
  ASSERT_TRUE(badOffsetView);
  std::uint64_t firstId = 0;
  std::memcpy(&firstId, badOffset.data() + firstEntry, 8);
  EXPECT_FALSE(badOffsetView->offsetOf(firstId));
}

TEST(CheckpointFormat, HypotenusePointsWithoutTrianglesRoundTripInBothWidths) {
  // What a level carries for its parent: the points on a patch's hypotenuse, no triangles.
  for (const std::int32_t far : {100, 70000}) {
    WorkPatch points;
    points.points = {LatticeXY{0, 0}, LatticeXY{far / 2, far / 2}, LatticeXY{far, far}};
    ByteWriter w;
    putCarryRecord(w, CarrySaturation{}, &points);
    const auto bytes = w.take();
    ByteReader r(bytes);
    CarrySaturation s;
    WorkPatch back;
    ASSERT_TRUE(getCarryRecord(r, s, &back)) << far;
    EXPECT_EQ(back.points, points.points);
    EXPECT_TRUE(back.indices.empty());
  }
}

TEST(CheckpointFormat, ACarryPatchIndexingPastItsPointsIsDamaged) {
  // Found by fuzz_checkpoint: the record decoded, and the simplifier would have read past the
  // patch's points. Also a partial triangle.
  const CarryFixture f;
  for (const bool partialTriangle : {false, true}) {
    WorkPatch bad = f.narrow;
    if (partialTriangle) {
      bad.indices.pop_back();
    } else {
      bad.indices[1] = static_cast<std::uint32_t>(bad.points.size());
    }
    ByteWriter w;
    putCarryRecord(w, f.saturation, &bad);
    const auto record = w.take();
    ByteReader r(record);
    CarrySaturation s;
    WorkPatch patch;
    EXPECT_FALSE(getCarryRecord(r, s, &patch)) << partialTriangle;
  }
}

TEST(AtomicFile, APrefixWrittenAfterTheRestGivesTheBytesAndTheCrcOfAFileWrittenInOrder) {
  // The face files' assembly: header and node table written last, in place, in pieces.
  test::TempDir dir;
  std::vector<std::byte> head(1000);
  std::vector<std::byte> tail(300000);  // past the writer's buffer
  for (std::size_t i = 0; i < head.size(); ++i) head[i] = static_cast<std::byte>(i * 7 + 1);
  for (std::size_t i = 0; i < tail.size(); ++i) tail[i] = static_cast<std::byte>(i * 13 + 5);
  auto w = AtomicFileWriter::create(dir / "f.bin");
  ASSERT_TRUE(w);
  ASSERT_TRUE(w->leavePrefix(head.size()));
  ASSERT_TRUE(w->append(std::span(tail).first(100)));
  ASSERT_TRUE(w->append(std::span(tail).subspan(100)));
  const std::span<const std::byte> h(head);
  ASSERT_TRUE(w->writePrefix(600, h.subspan(600)));  // any order
  ASSERT_TRUE(w->writePrefix(0, h.first(600)));
  EXPECT_FALSE(w->writePrefix(999, h.first(2)));  // past the prefix: refused
  w->prefixWritten(crc32(h));
  std::vector<std::byte> whole = head;
  whole.insert(whole.end(), tail.begin(), tail.end());
  EXPECT_EQ(w->crc(), crc32(whole));
  EXPECT_EQ(w->size(), whole.size());
  ASSERT_TRUE(w->finish());
  std::ifstream in(dir / "f.bin", std::ios::binary);
  std::vector<char> read((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(read.size(), whole.size());
  EXPECT_EQ(std::memcmp(read.data(), whole.data(), whole.size()), 0);
}

TEST(AtomicFile, APrefixNeverWrittenIsRefusedAtFinishAndLeavesNoFile) {
  test::TempDir dir;
  auto w = AtomicFileWriter::create(dir / "f.bin");
  ASSERT_TRUE(w);
  ASSERT_TRUE(w->leavePrefix(64));
  const std::array<std::byte, 4> bytes{};
  ASSERT_TRUE(w->append(bytes));
  auto done = w->finish();
  ASSERT_FALSE(done);
  EXPECT_NE(done.error().message.find("prefix"), std::string::npos) << done.error().message;
  *w = AtomicFileWriter();  // abandoned: the temporary goes
  EXPECT_FALSE(std::filesystem::exists(dir / "f.bin"));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace pbdam::builder
