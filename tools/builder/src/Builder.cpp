// The P-BDAM build pipeline (Builder.h; docs/builder.md; [P-BDAM 2003] §5), one process or several
// (docs/builder.md "Distributed build"): every stage's independent work — lattice rows, the
// blocks (diamonds) of each bintree level with their error saturation, texture tiles — is split
// into contiguous ranges per rank and run with TBB inside each rank. Out of core: the lattice
// heights and bucketed source samples live in files every rank maps; each rank streams its nodes
// and its carry (what the next level needs) into its own checkpoint part files, batch by batch;
// the next level reads the children of its diamonds from those files. The ranks synchronise only
// between levels (a small all-gather of per-rank statistics); rank 0 records the checkpoint
// state and finally assembles the dataset from the part files through mappings. The inputs are
// prepared in BuildInputs.cpp, each diamond is built by DiamondBuilder, the part files' bytes are
// Checkpoint's, the texture stage is TextureStage.cpp (both define DatasetBuild.h's members) and
// the assembly is DatasetAssembly.cpp.
#include "pbdam/builder/Builder.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <mutex>
#include <span>
#include <stop_token>
#include <thread>

#include "BuildInputs.h"
#include "DatasetAssembly.h"
#include "DatasetBuild.h"
#include "DiamondBuilder.h"
#include "ForestPlan.h"
#include "StageClock.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/builder/TextureBuilder.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Planet.h"

using namespace pbdam::formats;

namespace pbdam::builder {

std::string LocalCommunicator::hostName() const {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

void LocalCommunicator::abortJob(int exitCode) { std::_Exit(exitCode); }

/// Contiguous share [begin, end) of `count` items for `rank` of `ranks`.
std::pair<std::uint64_t, std::uint64_t> shareOf(std::uint64_t count, int rank, int ranks) {
  const auto r = static_cast<std::uint64_t>(rank);
  const auto n = static_cast<std::uint64_t>(ranks);
  return {count * r / n, count * (r + 1) / n};
}

/// A write that found no space says how to go on: what is checkpointed is kept.
Error withResumeHint(Error error) {
  constexpr std::string_view kHint =
      "; free space (or raise the file-size limit) and rerun with --resume to continue";
  if (error.code == ErrorCode::NoSpace && error.message.find(kHint) == std::string::npos) {
    error.message += kHint;
  }
  return error;
}

std::string rangeText(std::uint64_t begin, std::uint64_t end) {
  char text[48];
  std::snprintf(text, sizeof text, "[%llu, %llu)", static_cast<unsigned long long>(begin),
                static_cast<unsigned long long>(end));
  return text;
}

namespace {

namespace fs = std::filesystem;

/// Collective: the first failure of any rank (lowest rank first) on every rank.
Result<void> agree(Communicator& comm, const Result<void>& mine) {
  ByteWriter w;
  w.put(static_cast<std::uint8_t>(mine ? 1 : 0));
  if (!mine) {
    w.put(static_cast<std::int32_t>(mine.error().code));
    w.putBytes(std::as_bytes(std::span<const char>(mine.error().message)));
  }
  if (comm.size() == 1) return mine;
  const auto all = comm.allGather(w.take());
  for (std::size_t r = 0; r < all.size(); ++r) {
    ByteReader in(all[r]);
    if (in.get<std::uint8_t>() == 1) continue;
    const auto code = static_cast<ErrorCode>(in.get<std::int32_t>());
    const auto text = in.take(all[r].size() - in.offset());
    std::string message(reinterpret_cast<const char*>(text.data()), text.size());
    if (r != 0) message.insert(0, "rank " + std::to_string(r) + ": ");
    return makeError(code, message);
  }
  return {};
}

/// The nodes of a level's diamonds (a leaf without partner is a diamond of one).
std::uint64_t nodesOf(std::span<const Diamond> diamonds) {
  return static_cast<std::uint64_t>(
             std::count_if(diamonds.begin(), diamonds.end(),
                           [](const Diamond& d) { return d[1] != ForestPlan::kNoNode; })) +
         diamonds.size();
}

}  // namespace

Result<StartPoint> DatasetBuild::setUpOutput() {
  std::error_code ec;
  fs::create_directories(o_.outDir, ec);
  if (ec) return makeError(ErrorCode::IoError, o_.outDir.string() + ": " + ec.message());
  // A rebuild first makes the directory incomplete, so a crash never leaves a stale manifest
  // describing new face files.
  fs::remove(o_.outDir / kManifestFileName, ec);
  StartPoint start;
  if (o_.resume) {
    auto saved = checkpoint_.readState();
    if (!saved) return std::move(saved).error();
    if (*saved) {
      if (auto differs = fingerprintMismatch((*saved)->fingerprint, state_.fingerprint)) {
        return invalidArgument("--resume: " + checkpoint_.directory().string() +
                               " belongs to another build: " + *differs +
                               " (rerun without --resume to start over)");
      }
      if ((*saved)->assemblyFreedLevels) {
        return makeError(ErrorCode::CorruptData,
                         "--resume: " + checkpoint_.directory().string() +
                             ": an earlier assembly freed its level files' pages to fit the face "
                             "files on the disk, then failed; rerun without --resume to build "
                             "again (or with --free-checkpoint never and more free disk)");
      }
      start.completeLevel = (*saved)->completeLevel;
      start.textureComplete = (*saved)->textureComplete;
      if (start.completeLevel) {
        const auto it = (*saved)->levelParts.find(*start.completeLevel);
        if (it != (*saved)->levelParts.end()) start.completeLevelParts = it->second;
      }
      // Every file the state promises must be there before any work is redone.
      std::vector<fs::path> needed;
      const CheckpointState& st = **saved;
      auto partsOf = [&](int level) {
        const auto it = st.levelParts.find(level);
        return it == st.levelParts.end() ? 1u : it->second;
      };
      if (start.completeLevel) {
        for (int level = d_; level >= *start.completeLevel; --level) {
          for (std::uint32_t part = 0; part < partsOf(level); ++part) {
            needed.push_back(checkpoint_.file(Checkpoint::Kind::Nodes, level, part));
          }
        }
        if (*start.completeLevel > 0) {
          for (std::uint32_t part = 0; part < partsOf(*start.completeLevel); ++part) {
            needed.push_back(checkpoint_.file(Checkpoint::Kind::Carry, *start.completeLevel, part));
          }
        }
      }
      if (start.textureComplete) {
        for (std::uint32_t part = 0; part < std::max(1u, st.textureParts); ++part) {
          needed.push_back(checkpoint_.file(Checkpoint::Kind::Texture, 0, part));
        }
      }
      for (const auto& path : needed) {
        if (!fs::exists(path, ec)) {
          return makeError(
              ErrorCode::CorruptData,
              "--resume: " + path.string() + " is missing (rerun without --resume to start over)");
        }
      }
      state_ = **saved;
      return start;
    }
    log("resume: no checkpoint in " + checkpoint_.directory().string() +
        ", building from the start");
  }
  if (auto r = checkpoint_.reset(true); !r) return std::move(r).error();
  if (auto r = checkpoint_.writeState(state_); !r) return std::move(r).error();
  return start;
}

void DatasetBuild::releaseResident() {
  std::lock_guard lock(residentMutex_);
  if (in_.dem) in_.dem->releaseResident();
  if (in_.composite) in_.composite->releaseResident();
  if (grid_) grid_->releaseResident();
  below_.releaseResident();
  assembling_.releaseResident();
}

Result<void> DatasetBuild::resample() {
  // Each rank resamples a share of the lattice rows into the one heights file and buckets a
  // share of the DEM rows into its own samples file; after a barrier every rank maps them all.
  const std::uint64_t rows = tiles_.rowCount();
  const auto [begin, end] = shareOf(rows, comm_.rank(), comm_.size());
  const std::string item =
      "resampling lattice rows " + rangeText(begin, end) + " of " + std::to_string(rows);
  announce("resampling", "lattice rows", rows);
  const auto t0 = Clock::now();
  const auto progress = [&](std::size_t done, std::size_t total) {
    report("resample",
           static_cast<double>(done) / static_cast<double>(std::max<std::size_t>(total, 1)));
  };
  auto stats =
      in_.composite
          ? SampleGrid::writeHeightRows(
                [this](double lat, double lon) { return in_.composite->heightAt(lat, lon); },
                *in_.planet, lattice_, tiles_, checkpoint_.heightsFile(),
                static_cast<std::size_t>(begin), static_cast<std::size_t>(end), progress)
          : SampleGrid::writeHeightRows(*in_.dem, *in_.planet, lattice_, tiles_,
                                        checkpoint_.heightsFile(), static_cast<std::size_t>(begin),
                                        static_cast<std::size_t>(end), progress);
  if (!stats) return fail(item, stats.error());
  const auto part = static_cast<std::uint32_t>(comm_.rank());
  // A complete forest's buckets are a few lattice cells wide; a sparse lattice's are sized by
  // the samples instead (SampleGrid::bucketCellsFor).
  std::uint64_t sampleCount = 0;
  if (in_.composite) {
    in_.composite->forEachSample([&sampleCount](int, double, double, double) { ++sampleCount; });
  } else {
    sampleCount = static_cast<std::uint64_t>(in_.dem->width() * in_.dem->height());
  }
  const std::uint32_t bucketCells = tiles_.isDense()
                                        ? SampleGrid::defaultBucketCells(lattice_)
                                        : SampleGrid::bucketCellsFor(lattice_, sampleCount);
  if (in_.composite) {
    // The composite's samples (the base's where no inset lies, each inset's where it is the
    // finest), shared out by their order.
    const SampleEnumerator samples = [this](const std::function<void(double, double, double)>& fn) {
      in_.composite->forEachSample(
          [&fn](int, double lat, double lon, double height) { fn(lat, lon, height); });
    };
    const auto [first, last] = shareOf(sampleCount, comm_.rank(), comm_.size());
    if (auto r = SampleGrid::writeSourceBuckets(samples, first, last, *in_.planet, lattice_,
                                                bucketCells, checkpoint_.samplesFile(part));
        !r) {
      return fail("bucketing composite samples " + rangeText(first, last), r.error());
    }
  } else {
    const auto demRows = static_cast<std::uint64_t>(in_.dem->height());
    const auto [rowBegin, rowEnd] = shareOf(demRows, comm_.rank(), comm_.size());
    if (auto r = SampleGrid::writeSourceBuckets(
            *in_.dem, *in_.planet, lattice_, bucketCells, checkpoint_.samplesFile(part),
            static_cast<std::size_t>(rowBegin), static_cast<std::size_t>(rowEnd));
        !r) {
      return fail("bucketing DEM rows " + rangeText(rowBegin, rowEnd), r.error());
    }
  }

  // Barrier: every rank's rows and samples are on disk; totals of the statistics.
  ByteWriter w;
  w.put(stats->noDataPoints);
  w.put(stats->minHeightMeters);
  w.put(stats->maxHeightMeters);
  HeightRowStats total;
  total.minHeightMeters = std::numeric_limits<float>::infinity();
  total.maxHeightMeters = -std::numeric_limits<float>::infinity();
  for (const auto& piece : comm_.allGather(w.take())) {
    ByteReader r(piece);
    total.noDataPoints += r.get<std::uint64_t>();
    total.minHeightMeters = std::min(total.minHeightMeters, r.get<float>());
    total.maxHeightMeters = std::max(total.maxHeightMeters, r.get<float>());
  }
  std::vector<fs::path> samples;
  for (std::uint32_t k = 0; k < static_cast<std::uint32_t>(comm_.size()); ++k) {
    samples.push_back(checkpoint_.samplesFile(k));
  }
  auto grid = SampleGrid::open(lattice_, tiles_, *in_.planet, checkpoint_.heightsFile(), samples,
                               bucketCells, total);
  if (!grid) return fail(item, grid.error());
  {
    std::lock_guard lock(residentMutex_);
    grid_.emplace(std::move(grid).value());
    grid_->setResidentBudget(o_.residentBudgetBytes);
  }
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  char line[160];
  if (tiles_.isDense()) {
    std::snprintf(line, sizeof line, "resample: %llu lattice rows over %d rank(s) in %.1f s",
                  static_cast<unsigned long long>(rows), comm_.size(), s);
  } else {
    std::snprintf(line, sizeof line,
                  "resample: %llu lattice rows of %llu tiles (%llu points) over %d rank(s) in "
                  "%.1f s",
                  static_cast<unsigned long long>(rows),
                  static_cast<unsigned long long>(tiles_.tileCount()),
                  static_cast<unsigned long long>(tiles_.pointCount()), comm_.size(), s);
  }
  log(line);
  return {};
}

Result<void> DatasetBuild::injectFault(int level, const std::string& item) {
  if (o_.fault.failRank != comm_.rank() || o_.fault.failLevel != level) return {};
  if (o_.fault.failByKill) {
    std::fprintf(stderr, "pbdam: test: rank %d kills itself (SIGKILL) at level %d\n", comm_.rank(),
                 level);
    std::fflush(stderr);
    std::raise(SIGKILL);
  }
  return fail(item, makeError(ErrorCode::Internal, "injected failure (PBDAM_TEST_FAIL_RANK)"));
}

Result<DatasetBuild::LevelFiles> DatasetBuild::startLevel(int level, const std::string& item) {
  const auto ranks = static_cast<std::uint32_t>(comm_.size());
  const auto part = static_cast<std::uint32_t>(comm_.rank());
  LevelFiles files;
  auto nodesFile = checkpoint_.startFile(Checkpoint::Kind::Nodes, level, part, ranks);
  if (!nodesFile) return fail(item, nodesFile.error());
  files.nodes = std::move(nodesFile).value();
  // Level 0's carry would serve no level: it is not written.
  if (level > 0) {
    auto c = checkpoint_.startFile(Checkpoint::Kind::Carry, level, part, ranks);
    if (!c) return fail(item, c.error());
    files.carry = std::move(c).value();
  }
  return files;
}

Result<void> DatasetBuild::appendBatch(const std::vector<DiamondBytes>& batch, const Diamond* first,
                                       LevelFiles& files) {
  for (std::size_t j = 0; j < batch.size(); ++j) {
    const DiamondBytes& bytes = batch[j];
    if (auto r = files.nodes.append(bytes.nodes); !r) return r;
    if (files.carry) {
      const Diamond& diamond = first[j];
      files.carryIndex.emplace_back(diamond[0], files.carry->size());
      if (diamond[1] != ForestPlan::kNoNode) {
        files.carryIndex.emplace_back(diamond[1], files.carry->size() + bytes.firstCarryBytes);
      }
      if (auto r = files.carry->append(bytes.carry); !r) return r;
    }
  }
  return {};
}

Result<LevelPartFooter> DatasetBuild::buildShare(int level, const std::vector<Diamond>& diamonds,
                                                 std::uint64_t begin, std::uint64_t end,
                                                 LevelFiles& files, const std::string& item) {
  const auto t0 = Clock::now();
  const std::uint64_t mine = end - begin;
  const auto threads =
      static_cast<std::uint64_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::uint64_t batch = 256 * threads;
  DiamondBuilder builder(DiamondLevel{
      *grid_, lattice_, plan_, d_, level, level < d_ ? &below_ : nullptr, o_.minPatchTriangles,
      o_.errorMargin, o_.heightStepMeters, files.carry.has_value()});
  std::vector<DiamondBytes> out;
  files.carryIndex.reserve(files.carry ? 2 * mine : 0);
  LevelPartFooter footer;
  footer.firstDiamond = begin;
  footer.diamonds = mine;
  footer.nodes = nodesOf(std::span<const Diamond>(diamonds).subspan(begin, mine));
  std::atomic<std::uint64_t> done{0};
  const auto caller = std::this_thread::get_id();
  auto lastReport = Clock::now();
  const std::uint64_t total = plan_.nodeCount();
  const std::uint64_t levelPatches = nodesOf(diamonds);
  for (std::uint64_t first = 0; first < mine && !builder.failed(); first += batch) {
    const std::uint64_t count = std::min(batch, mine - first);
    out.assign(count, DiamondBytes{});
    tbb::parallel_for(std::uint64_t{0}, count, [&](std::uint64_t j) {
      if (!builder.build(diamonds[begin + first + j], out[j])) return;
      ++done;
      if (std::this_thread::get_id() == caller && root() &&
          Clock::now() - lastReport > std::chrono::milliseconds(100)) {
        lastReport = Clock::now();
        const double share = static_cast<double>(done.load()) /
                             static_cast<double>(std::max<std::uint64_t>(mine, 1));
        report("simplify",
               (static_cast<double>(patchesDone_) + share * static_cast<double>(levelPatches)) /
                   static_cast<double>(total));
      }
    });
    if (builder.failed()) break;
    for (const DiamondBytes& bytes : out) footer.patchBytesRaw += bytes.rawBytes;
    if (auto r = appendBatch(out, diamonds.data() + begin + first, files); !r) {
      return fail(item, r.error());
    }
  }
  out.clear();
  if (builder.failed()) return fail(item, builder.failure());
  footer.insertedPoints = builder.insertedPoints();
  footer.halvesOverTarget = builder.halvesOverTarget();
  footer.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return footer;
}

Result<void> DatasetBuild::finishLevel(const LevelPartFooter& footer, LevelFiles& files) {
  if (auto r = files.nodes.append(encodeLevelPartFooter(footer)); !r) return r;
  if (auto r = files.nodes.finish(); !r) return r;
  if (files.carry) {
    if (auto r = files.carry->append(encodeCarryIndex(std::move(files.carryIndex))); !r) return r;
    files.carryIndex = {};
    if (auto r = files.carry->finish(); !r) return r;
  }
  return {};
}

Result<void> DatasetBuild::recordLevel(int level) {
  const auto ranks = static_cast<std::uint32_t>(comm_.size());
  if (root()) {
    const std::string writing = "writing the level " + std::to_string(level) + " checkpoint";
    state_.completeLevel = level;
    state_.levelParts[level] = ranks;
    if (auto w = checkpoint_.writeState(state_); !w) return fail(writing, w.error());
  }
  std::vector<std::byte> recorded(1);
  comm_.broadcast(recorded);
  completeLevel_ = level;
  return {};
}

void DatasetBuild::logLevel(int level, const std::vector<Diamond>& diamonds,
                            const std::vector<std::vector<std::byte>>& gathered,
                            Clock::time_point t0) {
  const std::uint64_t total = plan_.nodeCount();
  std::string line = "level " + std::to_string(level) + ": " + std::to_string(diamonds.size()) +
                     (level == d_ ? " leaf diamonds" : " blocks");
  char buf[200];
  for (std::size_t r = 0; r < gathered.size(); ++r) {
    const auto footer = decodeLevelPartFooter(gathered[r], "rank " + std::to_string(r));
    const std::uint64_t count = footer ? footer->diamonds : 0;
    const double s = footer ? footer->seconds : 0.0;
    std::snprintf(buf, sizeof buf, "%s rank %zu %llu in %.1f s (%.0f/s)", r == 0 ? ";" : ",", r,
                  static_cast<unsigned long long>(count), s,
                  s > 0.0 ? static_cast<double>(count) / s : 0.0);
    line += buf;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - simplifyStart_).count();
  const double fraction = static_cast<double>(patchesDone_) / static_cast<double>(total);
  std::snprintf(buf, sizeof buf, "; %.0f%% of patches, %.1f s", 100.0 * fraction, elapsed);
  line += buf;
  // Blocks cost ~10x what leaves do: the ETA extrapolates the block levels' rate only.
  if (level < d_) {
    blockSeconds_ += std::chrono::duration<double>(Clock::now() - t0).count();
    blockPatchesDone_ += nodesOf(diamonds);
    std::snprintf(buf, sizeof buf, ", ETA %.0f s",
                  blockSeconds_ / static_cast<double>(blockPatchesDone_) *
                      static_cast<double>(total - patchesDone_));
    line += buf;
  }
  log(line);
  report("simplify", fraction);
}

Result<void> DatasetBuild::buildLevel(int level) {
  const auto diamonds = plan_.diamondsOfLevel(level);
  const auto [begin, end] = shareOf(diamonds.size(), comm_.rank(), comm_.size());
  const std::string item = "building level " + std::to_string(level) + " diamonds " +
                           rangeText(begin, end) + " of " + std::to_string(diamonds.size());
  announce("level " + std::to_string(level), "diamonds", diamonds.size());
  if (auto r = injectFault(level, item); !r) return r;
  // The carry of the level below: saturated values and (above the first block level) the
  // working patches of this level's children, from the part files every rank wrote.
  if (level < d_) {
    std::lock_guard lock(residentMutex_);
    if (auto r = below_.open(checkpoint_, level + 1, belowParts_, verifyBelow_); !r) {
      return fail(item, r.error());
    }
    verifyBelow_ = false;
  }
  auto files = startLevel(level, item);
  if (!files) return std::move(files).error();

  // 1. Simplify, measure, saturate and serialise this rank's diamonds in batches, appending
  // each batch to the part files in diamond order: what is in memory is one batch, whatever
  // the level's size.
  const auto t0 = Clock::now();
  auto footer = buildShare(level, diamonds, begin, end, *files, item);
  if (!footer) return std::move(footer).error();

  // 2. Finish the part files: the nodes' footer (what the level reports), the carry's index.
  if (auto r = finishLevel(*footer, *files); !r) return fail(item, r.error());
  {
    std::lock_guard lock(residentMutex_);
    below_.close();  // the children have served
  }

  // 3. Synchronise: every rank's part files are complete; rank 0 records the level, and no
  // rank goes on before it has (otherwise a rank failing early in the next level could stop the
  // job while rank 0 writes, and a level every rank completed would be built again on resume).
  auto gathered = comm_.allGather(encodeLevelPartFooter(*footer));
  patchesDone_ += nodesOf(diamonds);
  const std::uint32_t previousParts = belowParts_;
  belowParts_ = static_cast<std::uint32_t>(comm_.size());
  if (auto r = recordLevel(level); !r) return r;
  if (!root()) return {};
  if (level < d_) checkpoint_.removeFile(Checkpoint::Kind::Carry, level + 1, previousParts);

  // 4. Report: per-rank throughput and the ETA of the simplification.
  logLevel(level, diamonds, gathered, t0);
  return {};
}

/// Rank 0: the face files and the manifest from the checkpointed levels and tiles.
Result<void> DatasetBuild::assemble(BuildSummary& summary) {
  const AssemblyInputs inputs{o_,
                              plan_,
                              checkpoint_,
                              state_,
                              *in_.planet,
                              in_.n,
                              in_.leafCells,
                              in_.depth,
                              in_.imagery.has_value(),
                              in_.demSource.format,
                              static_cast<double>(minHeightMeters_),
                              static_cast<double>(maxHeightMeters_),
                              manifestInsets(o_, in_),
                              leafSources(o_, in_, plan_, lattice_),
                              in_.composite ? in_.composite->voidMap() : formats::VoidMap{},
                              assembling_,
                              [this](double fraction) { report("write", fraction); },
                              [this](const std::string& line) { log(line); }};
  return assembleDataset(inputs, summary);
}

Result<BuildSummary> DatasetBuild::run(StageClock& clock) {
  BuildSummary summary;
  summary.latticeCells = in_.n;
  summary.insets = insetSummaries(o_, in_);
  summary.depth = in_.depth;
  summary.ranks = comm_.size();
  state_.fingerprint = fingerprintOf(o_, in_);

  // Rank 0 prepares the output directory and the checkpoint and tells everyone where to start.
  std::vector<std::byte> decision;
  if (root()) {
    auto start = setUpOutput();
    ByteWriter w;
    w.put(static_cast<std::uint8_t>(start ? 1 : 0));
    if (start) {
      w.put(static_cast<std::int32_t>(start->completeLevel.value_or(-1)));
      w.put(start->completeLevelParts);
      w.put(static_cast<std::uint8_t>(start->textureComplete ? 1 : 0));
    } else {
      w.put(static_cast<std::int32_t>(start.error().code));
      w.putBytes(std::as_bytes(std::span<const char>(start.error().message)));
    }
    decision = w.take();
  }
  comm_.broadcast(decision);
  StartPoint start;
  {
    ByteReader r(decision);
    if (r.get<std::uint8_t>() != 1) {
      const auto code = static_cast<ErrorCode>(r.get<std::int32_t>());
      const auto text = r.take(decision.size() - r.offset());
      return makeError(code, std::string(reinterpret_cast<const char*>(text.data()), text.size()));
    }
    const auto level = r.get<std::int32_t>();
    if (level >= 0) start.completeLevel = level;
    start.completeLevelParts = r.get<std::uint32_t>();
    start.textureComplete = r.get<std::uint8_t>() == 1;
  }
  completeLevel_ = start.completeLevel;
  textureComplete_ = start.textureComplete;
  if (start.completeLevel) {
    summary.resumedAfterLevel = start.completeLevel;
    summary.resumedAfterTexture = start.textureComplete;
    log("resume: the checkpoint has levels " + std::to_string(d_) + ".." +
        std::to_string(*start.completeLevel) + (start.textureComplete ? " and the textures" : "") +
        "; continuing" +
        (*start.completeLevel > 0 ? " at level " + std::to_string(*start.completeLevel - 1) : ""));
  }

  // RSS bound: mapped data (heights, samples, carry, checkpoint files) stays in the page cache,
  // and in this process only up to the resident budget (beyond it, what its threads touched in
  // the last quarter second).
  ResidentTrimmer trimmer(
      std::chrono::milliseconds(250), [this] { releaseResident(); }, o_.residentBudgetBytes);

  // ---- Resample (each rank a share of the lattice rows and of the DEM rows, into files that
  // every rank then maps).
  if (auto r = resample(); !r) return std::move(r).error();
  clock.mark(summary, "resample");
  summary.sourceSamples = grid_->sourceSampleCount();
  summary.latticeSamples = tiles_.pointCount();
  summary.noDataPoints = grid_->noDataPoints();

  // RSS bound: the levels read the lattice and the bucketed samples only, so the DEM (the
  // largest thing in memory: 2.1 GB of floats for the paper-scale 32768×16384 input) is released
  // until the textures read it again.
  releaseDem();

  // ---- Levels D .. 0: leaves, then one block per diamond; saturation with each level.
  simplifyStart_ = Clock::now();
  int next = d_;
  if (start.completeLevel) {
    for (int level = d_; level >= *start.completeLevel; --level) {
      patchesDone_ += nodesOf(plan_.diamondsOfLevel(level));
    }
    next = *start.completeLevel - 1;
    belowParts_ = start.completeLevelParts;
    verifyBelow_ = true;
  }
  for (int level = next; level >= 0; --level) {
    if (auto r = buildLevel(level); !r) return std::move(r).error();
    clock.mark(summary, "level " + std::to_string(level));
  }

  // ---- Texture quadtree.
  if (!start.textureComplete) {
    if (auto r = buildTextures(); !r) return std::move(r).error();
    clock.mark(summary, "textures");
  }

  // RSS bound: the assembly reads checkpoint files only, so the DEM the textures read again
  // (2.17 GB at the paper scale) goes before it. The paper-scale 2 × 1 run without this peaked
  // at 5,115 MB on rank 0 (which assembles) against 3,465 MB on rank 1.
  releaseDem();
  // Disk bound: the lattice heights and the bucketed samples (8 GB at the paper scale) serve
  // the levels and the textures only, and a resumed build samples them again: they go before
  // the face files are written beside the checkpoint.
  minHeightMeters_ = grid_->minHeightMeters();
  maxHeightMeters_ = grid_->maxHeightMeters();
  {
    std::lock_guard lock(residentMutex_);
    grid_.reset();
  }
  if (root()) {
    std::error_code ignored;
    fs::remove(checkpoint_.heightsFile(), ignored);
    for (std::uint32_t k = 0; k < static_cast<std::uint32_t>(comm_.size()); ++k) {
      fs::remove(checkpoint_.samplesFile(k), ignored);
    }
  }

  // ---- Face files, then the manifest (rank 0).
  if (root()) {
    if (auto r = assemble(summary); !r) return fail("writing the dataset", r.error());
    clock.mark(summary, "assembly");
  }
  return summary;
}

Result<BuildSummary> buildDataset(const BuildOptions& o) {
  const auto start = Clock::now();
  StageClock clock;
  LocalCommunicator local;
  Communicator& comm = o.communicator ? *o.communicator : local;
  auto inputs = prepareInputs(o);
  if (auto agreed = agree(comm, inputs ? Result<void>{} : Result<void>{inputs.error()}); !agreed) {
    return std::move(agreed).error();
  }

  tbb::task_arena arena(o.threads > 0 ? o.threads : tbb::task_arena::automatic);
  Result<BuildSummary> result = Error{};
  arena.execute([&] {
    BuildSummary inputsCpu;
    clock.mark(inputsCpu, "inputs");
    DatasetBuild build(o, comm, *inputs);
    result = build.run(clock);
    if (result) result->cpuSeconds.insert(result->cpuSeconds.begin(), inputsCpu.cpuSeconds[0]);
  });
  if (!result) return withResumeHint(std::move(result).error());
  result->seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace pbdam::builder
