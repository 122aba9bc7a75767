// Node tables paged through a bounded cache (FaceViewOptions::nodeCacheBytes), on the real test
// datasets: every record, every child link and every heap-index lookup is the one the whole
// table gives, and so is every cut refinement makes from them, with a cache far smaller than the
// tables (so chunks are read back from the files over and over). A chunk rewritten or truncated
// on disk after the open is never read as a record: the node comes back as an empty leaf and
// the dataset's damage() names the file, the offset and what happened.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "PrivateCopy.h"
#include "TestData.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {
namespace {

/// The smallest cache: one chunk a shard.
FaceViewOptions pagedTables() {
  FaceViewOptions options;
  options.nodeCacheBytes = 1;
  return options;
}

std::array<std::byte, kNodeRecordBytes> encoded(const NodeRecord& record) {
  std::array<std::byte, kNodeRecordBytes> bytes{};
  encodeNodeRecord(record, bytes);
  return bytes;
}

/// Every row of every face: the same record, the same first child, found by its heap index.
void expectSameTables(const DatasetView& whole, const DatasetView& paged) {
  for (int f = 0; f < 6; ++f) {
    const FaceView& w = whole.face(f);
    const FaceView& p = paged.face(f);
    ASSERT_FALSE(w.nodeTablePaged());
    ASSERT_TRUE(p.nodeTablePaged()) << "face " << f << " of " << w.header().nodeCount << " nodes";
    for (std::uint64_t row = 0; row < w.header().nodeCount; ++row) {
      const NodeRecord record = w.nodeAt(row);
      ASSERT_EQ(encoded(p.nodeAt(row)), encoded(record)) << "face " << f << " row " << row;
      const std::uint32_t tree = row < w.header().tree1FirstNode ? 0 : 1;
      ASSERT_EQ(p.findNode(tree, record.heapIndex), row) << "face " << f << " row " << row;
      if (record.leaf()) {
        // A leaf's children exist in neither.
        EXPECT_FALSE(p.findNode(tree, 2 * record.heapIndex + 1).has_value());
        EXPECT_FALSE(w.findNode(tree, 2 * record.heapIndex + 1).has_value());
      } else {
        ASSERT_EQ(p.firstChildOf(row), w.firstChildOf(row)) << "face " << f << " row " << row;
      }
    }
    EXPECT_FALSE(p.damage().has_value());
  }
  // The cache is far smaller than the tables: chunks were read back many times.
  EXPECT_GT(paged.nodeChunkReads(), 0u);
  EXPECT_EQ(whole.nodeChunkReads(), 0u);
}

void expectSameCuts(const DatasetView& whole, const DatasetView& paged) {
  const Viewport viewport{640, 480, 60.0};
  const std::array<CameraPose, 3> poses = {CameraPose{0.0, 0.0, 8.0e6, 0.0, -90.0, 0.0},
                                           CameraPose{-14.6, 175.4, 3.0e4, 20.0, -20.0, 0.0},
                                           CameraPose{49.6, 6.1, 2.0e4, 200.0, -15.0, 0.0}};
  RefinementOptions options;
  options.tolerancePixels = 2.0;
  for (const CameraPose& pose : poses) {
    const Cut a = refine(whole, Camera::fromPose(whole.planet(), pose, viewport), options);
    const Cut b = refine(paged, Camera::fromPose(paged.planet(), pose, viewport), options);
    ASSERT_EQ(a.patches.size(), b.patches.size()) << pose.latDegrees << "," << pose.lonDegrees;
    for (std::size_t i = 0; i < a.patches.size(); ++i) {
      EXPECT_EQ(a.patches[i].node, b.patches[i].node);
      EXPECT_EQ(a.patches[i].screenErrorPixels, b.patches[i].screenErrorPixels);
    }
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.nodesVisited, b.nodesVisited);
  }
  EXPECT_FALSE(paged.damage().has_value());
}

/// `dir` opened twice: node tables held whole, and paged through the smallest cache.
struct BothWays {
  std::unique_ptr<MappedDataset> whole;
  std::unique_ptr<MappedDataset> paged;
};
void openBothWays(const std::filesystem::path& dir, BothWays& both) {
  auto whole = MappedDataset::open(dir);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  auto paged = MappedDataset::open(dir, pagedTables());
  ASSERT_TRUE(paged.ok()) << paged.error().message;
  both = {std::move(*whole), std::move(*paged)};
}

TEST(PagedNodeTables, MolaRecordsLinksLookupsAndCutsAreTheWholeTables) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  BothWays both;
  ASSERT_NO_FATAL_FAILURE(openBothWays(dir, both));
  const DatasetView& w = both.whole->view();
  const DatasetView& p = both.paged->view();
  expectSameTables(w, p);
  expectSameCuts(w, p);
}

TEST(PagedNodeTables, AnInsetsSparseForestIsTheWholeTables) {
  PBDAM_REQUIRE_DATASET(dir, "luxembourg");
  BothWays both;
  ASSERT_NO_FATAL_FAILURE(openBothWays(dir, both));
  const DatasetView& w = both.whole->view();
  const DatasetView& p = both.paged->view();
  bool sparse = false;
  for (int f = 0; f < 6; ++f) sparse |= !w.face(f).completeForest();
  ASSERT_TRUE(sparse) << "the inset dataset should have a sparse forest somewhere";
  expectSameTables(w, p);
  expectSameCuts(w, p);
}

// The render thread, the loader and the prefetcher refine at once through one cache (TSan
// checks its locks in the tsan preset).
TEST(PagedNodeTables, ThreadsRefiningAtOnceGetTheWholeTablesCuts) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  BothWays both;
  ASSERT_NO_FATAL_FAILURE(openBothWays(dir, both));
  const DatasetView& w = both.whole->view();
  const DatasetView& p = both.paged->view();
  const Viewport viewport{320, 240, 60.0};
  std::vector<Camera> cameras;
  cameras.reserve(8);
  for (int k = 0; k < 8; ++k) {
    const CameraPose pose{-30.0 + 8.0 * k, 40.0 * k, 2.0e6 / (k + 1), 30.0 * k, -50.0, 0.0};
    cameras.push_back(Camera::fromPose(w.planet(), pose, viewport));
  }
  std::vector<std::uint64_t> expected;
  expected.reserve(cameras.size());
  for (const Camera& camera : cameras) expected.push_back(refine(w, camera, {}).triangles);
  std::array<std::vector<std::uint64_t>, 4> got;
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < got.size(); ++t) {
    threads.emplace_back([&, t] {
      for (int round = 0; round < 3; ++round) {
        for (std::size_t k = 0; k < cameras.size(); ++k) {
          got[t].push_back(refine(p, cameras[(k + t) % cameras.size()], {}).triangles);
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (std::size_t t = 0; t < got.size(); ++t) {
    for (std::size_t i = 0; i < got[t].size(); ++i) {
      EXPECT_EQ(got[t][i], expected[(i + t) % cameras.size()]) << "thread " << t << " cut " << i;
    }
  }
  EXPECT_FALSE(p.damage().has_value());
}

/// Reads every row of every face, so that the first chunks are evicted from the small cache.
void readEveryRow(const DatasetView& view) {
  for (int f = 0; f < 6; ++f) {
    for (std::uint64_t row = 0; row < view.face(f).header().nodeCount; ++row) {
      static_cast<void>(view.face(f).nodeAt(row));
    }
  }
}

TEST(PagedNodeTables, AChunkRewrittenAfterOpenIsDamageNeverADifferentRecord) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  auto dataset = MappedDataset::open(dir, pagedTables());
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  ASSERT_TRUE(view.face(1).nodeTablePaged());
  const NodeRecord before = view.face(1).nodeAt(3);
  ASSERT_GT(before.blobBytes, 0u);
  readEveryRow(view);
  // Node 3 of face 1, its error field: a plausible value, so only the chunk's checksum can tell.
  const int fd = ::open((dir / "face1.pbdam").c_str(), O_WRONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  const std::byte value{0x42};
  ASSERT_EQ(
      ::pwrite(fd, &value, 1, static_cast<off_t>(kFaceHeaderBytes + 3 * kNodeRecordBytes + 136)),
      1);
  ::close(fd);
  const std::uint64_t readsBefore = view.nodeChunkReads();
  const NodeRecord after = view.face(1).nodeAt(3);
  EXPECT_GT(view.nodeChunkReads(), readsBefore) << "the chunk was still cached: nothing tested";
  EXPECT_TRUE(after.leaf());
  EXPECT_EQ(after.blobBytes, 0u);
  EXPECT_EQ(after.errorMeters, 0.0f);
  const auto damage = view.damage();
  ASSERT_TRUE(damage.has_value());
  EXPECT_EQ(damage->code, ErrorCode::CorruptData);
  for (const char* part : {"face1.pbdam", "offset 128", "changed after the file was opened"}) {
    EXPECT_NE(damage->message.find(part), std::string::npos) << part << ": " << damage->message;
  }
}

TEST(PagedNodeTables, ATableTruncatedAfterOpenIsDamageNamingFileAndOffset) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  auto dataset = MappedDataset::open(dir, pagedTables());
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  readEveryRow(view);
  ASSERT_EQ(::truncate((dir / "face2.pbdam").c_str(), 64), 0);
  const NodeRecord root = view.face(2).nodeAt(0);
  EXPECT_TRUE(root.leaf());
  EXPECT_EQ(root.blobBytes, 0u);
  const auto damage = view.damage();
  ASSERT_TRUE(damage.has_value());
  EXPECT_NE(damage->message.find("face2.pbdam"), std::string::npos) << damage->message;
  EXPECT_NE(damage->message.find("offset"), std::string::npos) << damage->message;
}

}  // namespace
}  // namespace pbdam::streaming
