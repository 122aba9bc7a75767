// The distributed build's own logic without MPI (docs/builder.md "Distributed build",
// "Checkpoints"): ranks simulated by threads sharing in-memory collectives give the plain
// build's bytes; an interrupted build resumes from its checkpoint to the same bytes; a
// checkpoint of other options, or a damaged one, is refused with a clear message. These run in
// process, so the sanitizer presets cover the serialisation and checkpoint code.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <barrier>
#include <fstream>
#include <thread>

#include "TestData.h"
#include "pbdam/builder/Builder.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/builder/Communicator.h"
#include "pbdam/formats/FileWrite.h"
#include "pbdam/formats/Manifest.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

BuildOptions checkpointMola(const fs::path& dem, const fs::path& out) {
  BuildOptions o;
  o.demPath = dem;
  o.planetSpec = "mars";
  o.outDir = out;
  o.leafVertices = 17;
  o.minPatchTriangles = 128;
  o.depth = 4;
  o.textureTileTexels = 64;
  o.textureFormat = TexelFormat::Rgba8;
  o.threads = 1;
  return o;
}

void expectSameDataset(const fs::path& a, const fs::path& b) {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(a)) {
    const auto name = entry.path().filename();
    EXPECT_TRUE(test::readFile(a / name) == test::readFile(b / name)) << name << " differs";
    ++files;
  }
  EXPECT_EQ(files, 7);
  EXPECT_FALSE(fs::exists(b / Checkpoint::kDirectoryName))
      << "a finished build keeps no checkpoint";
}

/// Ranks as threads of this process: collectives through shared slots and a barrier.
class ThreadGroup final {
 public:
  explicit ThreadGroup(int ranks)
      : ranks_(ranks), barrier_(ranks), slots_(static_cast<std::size_t>(ranks)) {}

  class Rank final : public Communicator {
   public:
    Rank(ThreadGroup& group, int rank) : group_(group), rank_(rank) {}
    int rank() const noexcept override { return rank_; }
    int size() const noexcept override { return group_.ranks_; }
    std::string hostName() const override { return "thread"; }
    std::vector<std::vector<std::byte>> allGather(std::vector<std::byte> mine) override {
      group_.slots_[static_cast<std::size_t>(rank_)] = std::move(mine);
      group_.barrier_.arrive_and_wait();
      auto all = group_.slots_;
      group_.barrier_.arrive_and_wait();
      return all;
    }
    void broadcast(std::vector<std::byte>& bytes) override {
      if (rank_ == 0) group_.slots_[0] = bytes;
      group_.barrier_.arrive_and_wait();
      if (rank_ != 0) bytes = group_.slots_[0];
      group_.barrier_.arrive_and_wait();
    }
    [[noreturn]] void abortJob(int) override { std::abort(); }

   private:
    ThreadGroup& group_;
    int rank_;
  };

 private:
  int ranks_;
  std::barrier<> barrier_;
  std::vector<std::vector<std::byte>> slots_;
};

/// Runs the build on `ranks` thread-ranks; rank 0's result.
Result<BuildSummary> buildOnRanks(const BuildOptions& options, int ranks) {
  ThreadGroup group(ranks);
  std::vector<std::unique_ptr<ThreadGroup::Rank>> comms;
  comms.reserve(static_cast<std::size_t>(ranks));
  for (int r = 0; r < ranks; ++r) comms.push_back(std::make_unique<ThreadGroup::Rank>(group, r));
  std::vector<std::optional<Result<BuildSummary>>> results(static_cast<std::size_t>(ranks));
  std::vector<std::thread> threads;
  threads.reserve(static_cast<std::size_t>(ranks));
  for (int r = 0; r < ranks; ++r) {
    threads.emplace_back([&, r] {
      BuildOptions o = options;
      o.communicator = comms[static_cast<std::size_t>(r)].get();
      results[static_cast<std::size_t>(r)] = buildDataset(o);
    });
  }
  for (auto& t : threads) t.join();
  for (int r = 1; r < ranks; ++r) {
    EXPECT_EQ(results[static_cast<std::size_t>(r)]->ok(), results[0]->ok()) << "rank " << r;
  }
  return std::move(*results[0]);
}

TEST(DistributedBuild, ThreadRanksGiveThePlainBuildsBytes) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  auto plain = buildDataset(checkpointMola(dem, dir / "plain"));
  ASSERT_TRUE(plain) << plain.error().message;
  for (int ranks : {2, 3, 5}) {
    const fs::path out = dir / ("r" + std::to_string(ranks));
    std::vector<std::string> lines;
    BuildOptions o = checkpointMola(dem, out);
    o.log = [&](std::string_view line) { lines.emplace_back(line); };
    auto summary = buildOnRanks(o, ranks);
    ASSERT_TRUE(summary) << summary.error().message;
    EXPECT_EQ(summary->ranks, ranks);
    EXPECT_EQ(summary->patches, plain->patches);
    EXPECT_EQ(summary->totalTriangles, plain->totalTriangles);
    EXPECT_EQ(summary->rootErrorMeters, plain->rootErrorMeters);
    EXPECT_EQ(summary->patchBytesRaw, plain->patchBytesRaw);
    expectSameDataset(dir / "plain", out);
    // One line per level (4..0) naming every rank's share.
    int levelLines = 0;
    for (const auto& line : lines) {
      if (line.rfind("level ", 0) == 0) {
        ++levelLines;
        EXPECT_NE(line.find("rank " + std::to_string(ranks - 1) + " "), std::string::npos) << line;
      }
    }
    EXPECT_EQ(levelLines, 5);
  }
}

TEST(DistributedBuild, DifferentOptionsOnOneRankAreRefusedOnAll) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  ThreadGroup group(2);
  ThreadGroup::Rank r0(group, 0);
  ThreadGroup::Rank r1(group, 1);
  BuildOptions a = checkpointMola(dem, dir / "out");
  a.communicator = &r0;
  BuildOptions b = a;
  b.communicator = &r1;
  b.demPath = dir / "missing.lbl";  // rank 1 cannot read its DEM
  std::optional<Result<BuildSummary>> ra;
  std::optional<Result<BuildSummary>> rb;
  std::thread t([&] { rb = buildDataset(b); });
  ra = buildDataset(a);
  t.join();
  ASSERT_FALSE(*ra);
  ASSERT_FALSE(*rb);
  EXPECT_EQ(ra->error().message.rfind("rank 1: ", 0), 0u) << ra->error().message;
  EXPECT_NE(ra->error().message.find("missing.lbl"), std::string::npos) << ra->error().message;
}

TEST(DistributedBuild, AnInterruptedBuildResumesToTheSameBytes) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  ASSERT_TRUE(buildDataset(checkpointMola(dem, dir / "plain")));
  for (int failLevel : {4, 2, 0}) {
    const fs::path out = dir / ("cut" + std::to_string(failLevel));
    BuildOptions o = checkpointMola(dem, out);
    o.fault.failRank = 0;
    o.fault.failLevel = failLevel;
    o.fault.failByKill = false;
    auto failed = buildDataset(o);
    ASSERT_FALSE(failed);
    EXPECT_NE(failed.error().message.find("injected failure"), std::string::npos);
    EXPECT_FALSE(fs::exists(out / "manifest.json"));
    auto state = Checkpoint(out).readState();
    ASSERT_TRUE(state && *state);
    if (failLevel == 4) {
      EXPECT_FALSE((*state)->completeLevel);  // nothing finished yet
    } else {
      EXPECT_EQ((*state)->completeLevel, failLevel + 1);
    }
    // Resume with other thread and rank counts: they are not part of the fingerprint.
    o.fault = {};
    o.resume = true;
    o.threads = 2;
    std::vector<std::string> lines;
    o.log = [&](std::string_view line) { lines.emplace_back(line); };
    auto resumed = buildOnRanks(o, 2);
    ASSERT_TRUE(resumed) << resumed.error().message;
    if (failLevel == 4) {
      EXPECT_FALSE(resumed->resumedAfterLevel);
    } else {
      EXPECT_EQ(resumed->resumedAfterLevel, failLevel + 1);
      for (const auto& line : lines) {
        EXPECT_NE(line.rfind("level " + std::to_string(failLevel + 1) + ":", 0), 0u)
            << "a checkpointed level was rebuilt: " << line;
      }
    }
    expectSameDataset(dir / "plain", out);
  }
}

TEST(BuildCheckpoint, ResumeRefusesOtherOptionsAndDamagedCheckpoints) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const fs::path out = dir / "out";
  BuildOptions o = checkpointMola(dem, out);
  o.fault = {0, 1, false};
  ASSERT_FALSE(buildDataset(o));
  o.fault = {};
  o.resume = true;

  BuildOptions other = o;
  other.textureFormat = TexelFormat::Bc1;
  auto refused = buildDataset(other);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("texture-format rgba8, this build bc1"), std::string::npos)
      << refused.error().message;
  EXPECT_EQ(refused.error().message.find('\n'), std::string::npos);

  // A flipped byte in a level file is caught by its CRC.
  const fs::path level3 = Checkpoint(out).file(Checkpoint::Kind::Nodes, 3);
  std::string bytes = test::readFile(level3);
  ASSERT_GT(bytes.size(), 1000u);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  std::ofstream(level3, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  auto damaged = buildDataset(o);
  ASSERT_FALSE(damaged);
  EXPECT_EQ(damaged.error().code, ErrorCode::CorruptData);
  EXPECT_NE(damaged.error().message.find("level-03.part-0.nodes: checksum mismatch"),
            std::string::npos)
      << damaged.error().message;

  // A missing level file is caught before any work is redone.
  fs::remove(Checkpoint(out).file(Checkpoint::Kind::Nodes, 4));
  auto missing = buildDataset(o);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("level-04.part-0.nodes is missing"), std::string::npos)
      << missing.error().message;

  // Without --resume the checkpoint is discarded and the build starts over.
  o.resume = false;
  ASSERT_TRUE(buildDataset(o));
  ASSERT_TRUE(buildDataset(checkpointMola(dem, dir / "plain")));
  expectSameDataset(dir / "plain", out);
}

TEST(BuildCheckpoint, ResumeRefusesTheCheckpointOfABuilderThatMadeItsLevelsAnotherWay) {
  // The builder before each level's errors were bounded through its children carried no
  // per-triangle errors and recorded no builder-levels entry: its checkpoint has the state of
  // this one without that line, and its level files cannot be continued.
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const fs::path out = dir / "out";
  BuildOptions o = checkpointMola(dem, out);
  o.fault = {0, 4, false};
  ASSERT_FALSE(buildDataset(o));
  const fs::path state = Checkpoint(out).directory() / "state";
  std::string text = test::readFile(state);
  const std::string entry = "option builder-levels=2\n";
  const std::size_t at = text.find(entry);
  ASSERT_NE(at, std::string::npos) << text;
  text.erase(at, entry.size());
  std::ofstream(state, std::ios::binary)
      .write(text.data(), static_cast<std::streamsize>(text.size()));
  o.fault = {};
  o.resume = true;
  auto refused = buildDataset(o);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(refused.error().message.find("written by an older builder (levels version 1, this "
                                         "builder's 2)"),
            std::string::npos)
      << refused.error().message;
  EXPECT_NE(refused.error().message.find("rerun without --resume"), std::string::npos);
}

TEST(BuildCheckpoint, ResumeWithoutACheckpointBuildsFromTheStart) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  BuildOptions o = checkpointMola(dem, dir / "out");
  o.depth = 2;
  o.resume = true;
  std::vector<std::string> lines;
  o.log = [&](std::string_view line) { lines.emplace_back(line); };
  auto r = buildDataset(o);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_FALSE(r->resumedAfterLevel);
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines[0].rfind("resume: no checkpoint in ", 0), 0u) << lines[0];
}

/// The bytes the files of `dir` take on the disk, and their sizes.
std::pair<std::uint64_t, std::uint64_t> diskAndApparentBytes(const fs::path& dir) {
  std::uint64_t disk = 0;
  std::uint64_t apparent = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    struct stat st {};
    if (::stat(entry.path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    disk += static_cast<std::uint64_t>(st.st_blocks) * 512;
    apparent += static_cast<std::uint64_t>(st.st_size);
  }
  return {disk, apparent};
}

// A disk too small for the checkpoint and the face files side by side: the assembly frees each
// level file's pages once the faces whose nodes they hold are written. The dataset's bytes are
// the same; the checkpoint then says so, and a resume after such an assembly failed is refused
// (its levels are gone) with what to do instead.
TEST(BuildCheckpoint, AnAssemblyThatFreesTheCheckpointGivesTheSameBytesAndCannotResume) {
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  std::vector<std::string> lines;
  BuildOptions plainOptions = checkpointMola(dem, dir / "plain");
  plainOptions.log = [&](std::string_view line) { lines.emplace_back(line); };
  ASSERT_TRUE(buildDataset(plainOptions));
  for (const auto& line : lines) {  // Auto, with room: nothing freed
    EXPECT_EQ(line.find("freeing"), std::string::npos) << line;
  }

  const fs::path out = dir / "freed";
  BuildOptions o = checkpointMola(dem, out);
  o.freeCheckpoint = BuildOptions::FreeCheckpoint::Always;
  o.threads = 2;
  std::optional<std::pair<std::uint64_t, std::uint64_t>> afterFace0;
  std::optional<std::pair<std::uint64_t, std::uint64_t>> afterFace5;
  bool marked = false;
  o.progress = [&](std::string_view stage, double fraction) {
    if (stage != "write") return;
    const auto bytes = diskAndApparentBytes(out / Checkpoint::kDirectoryName);
    if (fraction < 0.2 && !afterFace0) {
      afterFace0 = bytes;
      auto state = Checkpoint(out).readState();
      marked = state && *state && (*state)->assemblyFreedLevels;
    }
    if (fraction > 0.99) afterFace5 = bytes;
  };
  auto built = buildOnRanks(o, 2);
  ASSERT_TRUE(built) << built.error().message;
  expectSameDataset(dir / "plain", out);
  ASSERT_TRUE(afterFace0 && afterFace5);
  EXPECT_TRUE(marked) << "the state did not say the levels were freed";
  // Pages go as their faces are written (at this tiny depth a face's nodes are spread by the
  // diamonds across face edges), and when all are, what stays is the texture parts (12%), the
  // state and the pages the files' headers and footers share with nodes.
  EXPECT_LT(afterFace0->first, afterFace0->second);
  EXPECT_LT(afterFace5->first, afterFace5->second / 4)
      << afterFace5->first << " of " << afterFace5->second << " bytes still on the disk";

  // The disk fills at face 3: faces 0..2's pages were freed, so the levels cannot be resumed.
  const fs::path cut = dir / "cut";
  BuildOptions failing = checkpointMola(dem, cut);
  failing.freeCheckpoint = BuildOptions::FreeCheckpoint::Always;
  failWritesForTesting((cut / "face3").string());
  auto full = buildDataset(failing);
  failWritesForTesting("");
  ASSERT_FALSE(full);
  EXPECT_EQ(full.error().code, ErrorCode::NoSpace) << full.error().message;
  failing.resume = true;
  auto refused = buildDataset(failing);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, ErrorCode::CorruptData);
  EXPECT_NE(refused.error().message.find("an earlier assembly freed its level files' pages"),
            std::string::npos)
      << refused.error().message;
  failing.resume = false;
  ASSERT_TRUE(buildDataset(failing));
  expectSameDataset(dir / "plain", cut);
}

// ETOPO20 with the Luxembourg GeoTIFF and an image for it (a plain PPM, so it takes the
// inset's footprint): the sparse forest, the composite's samples and the inset's texture come out
// byte-identical on any rank count and after a resume; a resume with another inset texture is
// refused.
TEST(DistributedBuild, AnInsetBuildIsTheSameBytesOnAnyRankCountAndAfterAResume) {
  const fs::path etopo20 = "/usr/share/ferret-vis/data/etopo20.cdf";
  PBDAM_REQUIRE_DATA(dem, etopo20);
  PBDAM_REQUIRE_DATA(luxembourg, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  test::TempDir dir;
  const auto writePpm = [&](const fs::path& path, int red) {
    std::ofstream out(path, std::ios::binary);
    out << "P6\n8 8\n255\n";
    for (int k = 0; k < 64; ++k) out << static_cast<char>(red) << '\x40' << '\x20';
  };
  writePpm(dir / "lux.ppm", 200);
  writePpm(dir / "other.ppm", 100);
  const auto options = [&](const fs::path& out) {
    BuildOptions o = checkpointMola(dem, out);
    o.planetSpec = "earth";
    o.insets = {InsetSpec{luxembourg, {}, dir / "lux.ppm"}};
    return o;
  };
  auto plain = buildDataset(options(dir / "plain"));
  ASSERT_TRUE(plain) << plain.error().message;
  EXPECT_EQ(plain->depth, 20u);
  auto manifest = readManifest(dir / "plain");
  ASSERT_TRUE(manifest) << manifest.error().message;
  ASSERT_EQ(manifest->insets.size(), 1u);
  EXPECT_EQ(manifest->insets[0].texture, "lux.ppm");

  BuildOptions ranks = options(dir / "ranks");
  ranks.threads = 2;
  ranks.freeCheckpoint = BuildOptions::FreeCheckpoint::Always;  // a sparse forest's parts too
  auto two = buildOnRanks(ranks, 2);
  ASSERT_TRUE(two) << two.error().message;
  expectSameDataset(dir / "plain", dir / "ranks");

  BuildOptions cut = options(dir / "cut");
  cut.fault.failRank = 0;
  cut.fault.failLevel = 12;
  cut.fault.failByKill = false;
  ASSERT_FALSE(buildDataset(cut));
  cut.fault = {};
  cut.resume = true;
  BuildOptions otherTexture = cut;
  otherTexture.insets[0].texturePath = dir / "other.ppm";
  auto refused = buildDataset(otherTexture);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("inset-texture"), std::string::npos)
      << refused.error().message;
  cut.threads = 2;
  auto resumed = buildOnRanks(cut, 2);
  ASSERT_TRUE(resumed) << resumed.error().message;
  EXPECT_EQ(resumed->resumedAfterLevel, 13);
  expectSameDataset(dir / "plain", dir / "cut");
}

}  // namespace
}  // namespace pbdam::builder
