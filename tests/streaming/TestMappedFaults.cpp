// A mapped dataset whose files change under it, on a private copy of the MOLA test dataset: a
// byte rewritten in a node table is a checksum error naming the file when the dataset opens;
// node tables rewritten after the open are never read again (they were copied and checked
// then); face files truncated in place after the open make decoding, the no-stall preload and
// height queries fail with errors naming the file and offset instead of killing the process.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "PrivateCopy.h"
#include "TestData.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/DecodeScheduler.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/NoStallPolicy.h"

#if defined(__SANITIZE_THREAD__)
#include <tbb/global_control.h>
#endif

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {
namespace {

#if defined(__SANITIZE_THREAD__)
// Debian's libtbb is not instrumented (TestDecodeScheduler.cpp says why).
const tbb::global_control serialTbbUnderTsan(tbb::global_control::max_allowed_parallelism, 1);
#endif

/// Overwrites `bytes` at `offset` of `path` in place (same inode: a mapping sees the change).
void rewriteInPlace(const std::filesystem::path& path, std::uint64_t offset,
                    const std::vector<std::byte>& bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0) << path;
  ASSERT_EQ(::pwrite(fd, bytes.data(), bytes.size(), static_cast<off_t>(offset)),
            static_cast<ssize_t>(bytes.size()));
  ::close(fd);
}

TEST(MappedFaults, ANodeTableByteRewrittenOnDiskIsAChecksumErrorAtOpen) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  // Node 3 of face 1, its error field: a plausible value, so only the checksum can tell.
  const std::uint64_t offset = kFaceHeaderBytes + 3 * kNodeRecordBytes + 136;
  rewriteInPlace(dir / "face1.pbdam", offset, {std::byte{0x42}});
  auto dataset = MappedDataset::open(dir);
  ASSERT_FALSE(dataset.ok());
  EXPECT_EQ(dataset.error().code, ErrorCode::CorruptData);
  EXPECT_NE(dataset.error().message.find("face1.pbdam"), std::string::npos)
      << dataset.error().message;
  EXPECT_NE(dataset.error().message.find("node table checksum"), std::string::npos)
      << dataset.error().message;
}

TEST(MappedFaults, NodeTablesRewrittenAfterOpenAreNeverRead) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  const NodeKey key{1, 0, 3};
  const NodeRecord before = view.node(key);
  // The whole record zeroed in the file (and so in the shared mapping): the view still gives
  // the record it checked when the dataset opened.
  rewriteInPlace(dir / "face1.pbdam", kFaceHeaderBytes + 3 * kNodeRecordBytes,
                 std::vector<std::byte>(kNodeRecordBytes));
  const NodeRecord after = view.node(key);
  EXPECT_EQ(after.blobOffset, before.blobOffset);
  EXPECT_EQ(after.errorMeters, before.errorMeters);
  EXPECT_EQ(after.vertexCount, before.vertexCount);
  EXPECT_EQ(after.cornerPositions, before.cornerPositions);
}

TEST(MappedFaults, FacesTruncatedAfterOpenAreErrorsNamingFileAndOffset) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  for (int f = 0; f < 6; ++f) {
    const auto path = dir / view.manifest().faces[static_cast<std::size_t>(f)].file;
    ASSERT_EQ(::truncate(path.c_str(), 4096), 0);
  }

  // Decoding: every blob lies past the new ends; the first failing job names its file and
  // offset.
  std::vector<DecodeJob> jobs;
  for (std::uint64_t heap = 0; heap < 7; ++heap) {
    const NodeKey node{2, 0, heap};
    if (view.node(node).blobBytes == 0) continue;
    DecodeJob job;
    job.key = ResidentKey::patch(node);
    job.node = node;
    jobs.push_back(job);
  }
  DecodeJob tile;
  tile.tile = TileKey{4, 0};
  tile.key = ResidentKey::tile(tile.tile);
  jobs.push_back(tile);
  const DecodeScheduler decoder(view, TexelFormat::Rgba8);
  std::vector<std::byte> out(decoder.layout(jobs));
  const Result<void> decoded = decoder.decode(jobs, out);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.error().code, ErrorCode::CorruptData);
  EXPECT_NE(decoded.error().message.find("face2.pbdam"), std::string::npos)
      << decoded.error().message;
  EXPECT_NE(decoded.error().message.find("offset " +
                                         std::to_string(view.node(jobs.front().node).blobOffset)),
            std::string::npos)
      << decoded.error().message;
  // A tile alone fails the same way.
  const Result<void> tileOnly =
      decoder.decode(std::span(&jobs.back(), 1), std::span(out).first(decoder.tileBytes()));
  ASSERT_FALSE(tileOnly.ok());
  EXPECT_NE(tileOnly.error().message.find("face4.pbdam"), std::string::npos);

  // The no-stall preload skips what it cannot read and says so.
  const std::vector<Error> skipped = NoStallPolicy(**dataset).preloadCoarseLevels();
  EXPECT_FALSE(skipped.empty());
  for (const Error& e : skipped) EXPECT_NE(e.message.find("offset"), std::string::npos);

  // Height queries decode patches too.
  const auto height = surfaceHeightAt(view, 18.4, -133.9);
  ASSERT_FALSE(height.ok());
  EXPECT_NE(height.error().message.find(".pbdam"), std::string::npos) << height.error().message;
}

}  // namespace
}  // namespace pbdam::streaming
