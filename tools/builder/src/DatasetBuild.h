// One build of a dataset on one rank of however many (DatasetBuild), the stages it runs and
// the helpers they share: Builder.cpp (set-up, resampling, the levels, assembly) and
// TextureStage.cpp (the texture quadtree) define its members. Private to the builder.
// Thread-safety: one DatasetBuild per rank, run from that rank's thread (its stages use TBB
// inside); releaseResident() may be called from the trimmer's thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "BuildInputs.h"
#include "DatasetAssembly.h"
#include "DiamondBuilder.h"
#include "ForestPlan.h"
#include "StageClock.h"
#include "pbdam/builder/Builder.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/builder/Communicator.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/builder/TextureBuilder.h"
#include "pbdam/formats/Result.h"

namespace pbdam::builder {

using Clock = std::chrono::steady_clock;

/// Contiguous share [begin, end) of `count` items for `rank` of `ranks`.
std::pair<std::uint64_t, std::uint64_t> shareOf(std::uint64_t count, int rank, int ranks);

/// A write that found no space says how to go on: what is checkpointed is kept.
formats::Error withResumeHint(formats::Error error);

/// "[begin, end)", for messages naming a rank's share.
std::string rangeText(std::uint64_t begin, std::uint64_t end);

/// What rank 0 decided about the output directory and the checkpoint, sent to every rank.
struct StartPoint {
  std::optional<int> completeLevel;      // resume after this level
  std::uint32_t completeLevelParts = 1;  // its part files (the rank count that wrote them)
  bool textureComplete = false;
};

/// One build of the dataset, on however many ranks `comm` has: one for a plain `pbdam build`
/// (a LocalCommunicator), several under MPI or with thread-ranks in the tests. Every rank runs
/// the same stages on its share; rank 0 also decides the start point and assembles the dataset.
class DatasetBuild {
 public:
  DatasetBuild(const BuildOptions& o, Communicator& comm, BuildInputs& in)
      : o_(o),
        comm_(comm),
        in_(in),
        lattice_(in.n),
        d_(static_cast<int>(in.depth)),
        nodesPerTree_(Lattice::nodesPerTree(d_)),
        plan_(in.deepRegions.empty()
                  ? ForestPlan(lattice_, d_, in.leafCells)
                  : ForestPlan(lattice_, in.leafCells,
                               ForestShape::make(lattice_, *in.planet,
                                                 static_cast<int>(in.baseDepth), in.deepRegions))),
        tiles_(plan_.latticeTiles()),
        checkpoint_(o.outDir) {}

  /// Builds, marking each stage's CPU time on `clock`.
  formats::Result<BuildSummary> run(StageClock& clock);

 private:
  bool root() const noexcept { return comm_.rank() == 0; }
  void report(std::string_view stage, double fraction) const {
    if (root() && o_.progress) o_.progress(stage, fraction);
  }
  void log(const std::string& line) const {
    if (root() && o_.log) o_.log(line);
  }
  /// Tells the caller what every rank works on in the stage starting now.
  void announce(const std::string& stage, const std::string& unit, std::uint64_t count) const {
    if (!o_.stageStarted) return;
    std::string text = stage + " (";
    for (int r = 0; r < comm_.size(); ++r) {
      const auto [b, e] = shareOf(count, r, comm_.size());
      text +=
          (r == 0 ? "rank " : ", rank ") + std::to_string(r) + ": " + unit + " " + rangeText(b, e);
    }
    text += " of " + std::to_string(count) + "); checkpointed: ";
    if (completeLevel_) {
      text += *completeLevel_ == d_
                  ? "level " + std::to_string(d_)
                  : "levels " + std::to_string(d_) + ".." + std::to_string(*completeLevel_);
      if (textureComplete_) text += " and the textures";
    } else {
      text += "nothing yet";
    }
    o_.stageStarted(text);
  }
  /// A failure after the ranks started: one process returns it; several print it, naming
  /// this rank, its host and its work item, and stop the job.
  /// A full disk stops the job with exit code 2 (like bad input: the user's to fix), any
  /// other failure with 1.
  formats::Error fail(const std::string& item, const formats::Error& error) {
    formats::Error e = withResumeHint(error);
    if (comm_.size() == 1) return e;
    std::fprintf(stderr, "pbdam: rank %d of %d on %s failed while %s: %s\n", comm_.rank(),
                 comm_.size(), comm_.hostName().c_str(), item.c_str(), e.message.c_str());
    std::fflush(stderr);
    comm_.abortJob(e.code == formats::ErrorCode::NoSpace ? 2 : 1);
    return e;  // not reached: abortJob does not return
  }

  formats::Result<StartPoint> setUpOutput();
  formats::Result<void> resample();
  formats::Result<void> buildLevel(int level);
  formats::Result<void> buildTextures();
  /// Drops the pages of every mapping in use from this process (ResidentTrimmer).
  void releaseResident();
  /// Lets the DEM go (memory, or its scratch mapping), under the trimmer's lock.
  void releaseDem() {
    // The composite shares the base's heights and keeps the insets: with insets the DEM stays
    // (its pages are still dropped by the trimmer when it is mapped).
    if (in_.composite) return;
    std::lock_guard lock(residentMutex_);
    in_.dem.reset();
  }
  /// Reads the DEM again (for the textures) and checks it is the one the build started with.
  formats::Result<void> rereadDem();
  formats::Result<void> assemble(BuildSummary& summary);

  /// The part files one rank writes for a level, and the index of its carry records.
  struct LevelFiles {
    Checkpoint::PartWriter nodes;
    std::optional<Checkpoint::PartWriter> carry;                      // every level but 0
    std::vector<std::pair<std::uint64_t, std::uint64_t>> carryIndex;  // node id, record offset
  };
  /// The test hook BuildOptions::fault: this rank fails (or is killed) at `level`.
  formats::Result<void> injectFault(int level, const std::string& item);
  formats::Result<LevelFiles> startLevel(int level, const std::string& item);
  /// Builds diamonds [begin, end) of `diamonds` in batches (TBB within a batch) into `files`.
  formats::Result<LevelPartFooter> buildShare(int level, const std::vector<Diamond>& diamonds,
                                              std::uint64_t begin, std::uint64_t end,
                                              LevelFiles& files, const std::string& item);
  /// Appends one batch's bytes (diamonds from `first` on) to the part files, in diamond order.
  formats::Result<void> appendBatch(const std::vector<DiamondBytes>& batch, const Diamond* first,
                                    LevelFiles& files);
  formats::Result<void> finishLevel(const LevelPartFooter& footer, LevelFiles& files);
  /// Rank 0 records `level` as complete in the checkpoint state; every rank waits for it.
  formats::Result<void> recordLevel(int level);
  void logLevel(int level, const std::vector<Diamond>& diamonds,
                const std::vector<std::vector<std::byte>>& gathered, Clock::time_point t0);
  TextureSource textureSource() const;
  /// Tile `k` (face-major, heap order within a face) as its blob and rounded-up error.
  /// Builds tile `k`'s colour and normal-map blobs and its texture error; false on failure.
  bool buildTile(const TextureSource& source, std::uint64_t k, std::uint64_t tilesPerFace,
                 std::vector<std::byte>& blob, std::vector<std::byte>& normalBlob,
                 float& errorMeters) const;
  formats::Result<void> recordTextures(const std::vector<std::vector<std::byte>>& gathered,
                                       std::uint64_t tiles);

  const BuildOptions& o_;
  Communicator& comm_;
  BuildInputs& in_;
  Lattice lattice_;
  int d_;
  std::uint64_t nodesPerTree_;
  ForestPlan plan_;
  LatticeTiles tiles_;  // the lattice points the patches use
  Checkpoint checkpoint_;
  CheckpointState state_;
  std::optional<SampleGrid> grid_;
  float minHeightMeters_ = 0.0f;  ///< the grid's, kept for the manifest once it is gone
  float maxHeightMeters_ = 0.0f;

  // The carry of the level below the one being built (its diamonds' saturated errors and
  // spheres and its working patches, by node id), read from its part files.
  CarryReader below_;
  std::uint32_t belowParts_ = 0;  // part files of each level's output: the rank count
  bool verifyBelow_ = false;      // check the CRCs of a carry that a resume found
  // Mappings ResidentTrimmer releases: the grid and carry above, and while assembling these.
  std::mutex residentMutex_;
  AssemblyMappings assembling_;

  // What the checkpoint holds (every rank keeps track, for messages).
  std::optional<int> completeLevel_;
  bool textureComplete_ = false;

  // Progress of the simplification (rank 0).
  Clock::time_point simplifyStart_;
  std::uint64_t patchesDone_ = 0;
  std::uint64_t blockPatchesDone_ = 0;  // by this run's block levels, for the ETA
  double blockSeconds_ = 0.0;
};

}  // namespace pbdam::builder
