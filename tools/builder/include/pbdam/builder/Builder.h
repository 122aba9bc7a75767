// `pbdam build`: a DEM (and optional imagery) into a P-BDAM dataset directory — resampling onto
// the cube-map lattice, leaf patches, bottom-up block simplification level by level, measured and
// saturated errors and spheres, the texture quadtree, and atomic writing of the six face files
// and the manifest ([P-BDAM 2003] §3–5; docs/builder.md). Parallel with TBB and, given a
// Communicator of several ranks (mpirun), distributed level by level across processes; the
// output does not depend on the thread or rank count. Checkpointed per level (--resume).
// Thread-safety: buildDataset may run concurrently for different output directories.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pbdam/builder/Communicator.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/builder/ForestShape.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/Result.h"
#include "pbdam/formats/TextureTile.h"

namespace pbdam::builder {

struct BuildOptions final {
  std::filesystem::path demPath;
  std::optional<formats::RawLayout> rawLayout;  ///< read the DEM as a raw grid
  std::filesystem::path texturePath;            ///< equirectangular imagery; empty: shaded relief
  std::string planetSpec;                       ///< Planet::fromSpec
  std::filesystem::path outDir;
  std::uint32_t leafVertices = 33;  ///< leaf leg vertices (2^k + 1)
  /// The fewest triangles of a simplified patch (unless its block is exact with fewer).
  std::uint32_t minPatchTriangles = 512;
  /// r: each level's saturated error is at least (1 + r) × its children's (docs/builder.md).
  double errorMargin = 0.25;
  std::uint32_t textureTileTexels = 256;  ///< texture tile side, border included
  std::optional<std::uint32_t> depth;     ///< bintree depth (even); auto from the DEM density
  /// Regions that want deeper leaves (even levels above the depth): the forest's shape is then
  /// ForestShape's closed set over a lattice of the deepest region's density, the depth being
  /// the base's (docs/builder.md "Insets: the forest's shape").
  std::vector<DeepRegion> deepRegions;
  /// Local high-resolution DEMs joined to the base (--inset): each makes a deep region over its
  /// grid at the level of its density, and the lattice and errors follow the composite surface
  /// (CompositeSurface.h; docs/builder.md "Insets").
  std::vector<InsetSpec> insets;
  formats::TexelFormat textureFormat = formats::TexelFormat::Bc1;
  formats::Bc1Quality bc1Quality = formats::Bc1Quality::Fast;
  double heightStepMeters = 1.0 / 64.0;
  /// A DEM whose heights take at least this many bytes is read into a mapped scratch file on
  /// the output's filesystem instead of memory (DemReadOptions::mapAtBytes).
  std::uint64_t demMapAtBytes = std::uint64_t{16} << 20;
  int threads = 0;  ///< 0: all cores (per rank)
  /// File pages (the lattice, bucketed samples, checkpoint parts, a mapped DEM) a process keeps
  /// resident before the trimmer drops them (ResidentTrimmer.h); 0: dropped every period.
  std::uint64_t residentBudgetBytes = std::uint64_t{768} << 20;
  bool force = false;   ///< replace an existing dataset
  bool resume = false;  ///< continue from OUT/.build-checkpoint after its last complete level
  /// Whether the assembly frees each checkpoint level file's pages (punches holes) once the
  /// faces whose nodes they hold are written, so that the checkpoint and the face files need
  /// not fit on the disk side by side. The price: an assembly that then fails cannot be resumed
  /// (the levels are built again). Auto frees only when the free space of the output's
  /// filesystem is short of the face files' estimate (docs/builder.md "Disk at assembly").
  enum class FreeCheckpoint { Auto, Always, Never } freeCheckpoint = FreeCheckpoint::Auto;
  /// The ranks of a distributed build; null: this process alone. Every rank calls buildDataset
  /// with the same options; rank 0 writes the dataset (docs/builder.md "Distributed build").
  Communicator* communicator = nullptr;
  /// Called on the calling thread (rank 0 only) with the stage name and its fraction done
  /// (0..1; for a distributed stage, of rank 0's share).
  std::function<void(std::string_view stage, double fraction)> progress;
  /// Called on the calling thread (rank 0 only) with one line per finished stage or level:
  /// its work per rank, throughput and the build's ETA.
  std::function<void(std::string_view line)> log;
  /// Called on every rank, on the calling thread, when a distributed stage starts, with what
  /// every rank works on in it and what the checkpoint holds, e.g. "level 3 (rank 0: diamonds
  /// [0, 48), rank 1: diamonds [48, 96) of 96); checkpointed: levels 6..4" — for the message of
  /// a job stopped because a rank died.
  std::function<void(std::string_view workItems)> stageStarted;
  /// Test aid (PBDAM_TEST_FAIL_RANK/LEVEL/MODE): rank `failRank` fails when it starts bintree
  /// level `failLevel`, by SIGKILL of itself (`failByKill`) or as a reported error.
  struct FaultInjection final {
    int failRank = -1;
    int failLevel = -1;
    bool failByKill = true;
  } fault;
};

/// What a build did, for the summary the CLI prints.
/// One inset surface as the build joined it (the manifest's order).
struct InsetSurfaceSummary final {
  std::string name;       ///< the specs it holds, as the manifest names them
  std::size_t tiles = 1;  ///< files read
  VoidReport voids;       ///< its voids: filled from their rims, or the surface below
};

struct BuildSummary final {
  std::vector<InsetSurfaceSummary> insets;
  std::uint32_t latticeCells = 0;
  std::uint32_t depth = 0;
  std::uint32_t textureLevels = 0;
  std::uint64_t sourceSamples = 0;
  std::uint64_t latticeSamples = 0;
  std::uint64_t patches = 0;
  std::uint64_t leafTriangles = 0;
  std::uint64_t totalTriangles = 0;
  std::uint64_t textureTiles = 0;
  std::uint64_t datasetBytes = 0;
  std::uint64_t patchBytesRaw = 0;  ///< 8 bytes/vertex + 6 bytes/triangle
  std::uint64_t patchBytesCompressed = 0;
  std::uint64_t morphTargetBytes = 0;  ///< the morph-target blobs (compressed)
  std::uint64_t noDataPoints = 0;
  std::uint64_t insertedPoints = 0;
  std::uint64_t halvesOverTarget = 0;
  double rootErrorMeters = 0.0;
  double leafMaxErrorMeters = 0.0;
  double seconds = 0.0;
  /// CPU seconds (user + system) of this process — rank 0's share when there are several —
  /// per stage in build order: "inputs", "resample", "level D" … "level 0" (the levels built
  /// by this run), "textures", "assembly".
  std::vector<std::pair<std::string, double>> cpuSeconds;
  int ranks = 1;
  std::optional<int> resumedAfterLevel;  ///< the checkpoint's last complete level, if resumed
  bool resumedAfterTexture = false;
};

/// Builds the dataset. Errors: bad options (InvalidArgument), unreadable inputs (the reader's
/// error), an existing dataset without `force`, `resume` with a checkpoint of other options
/// (InvalidArgument), I/O failures; a write that finds the disk full or the file-size limit
/// reached (formats/FileWrite.h: space is reserved before anything is written through a
/// mapping, so this is never a SIGBUS) is NoSpace, naming the file and the bytes it needed, and
/// `resume` continues after space is freed (a job of several ranks then exits with code 2). An
/// interrupted build leaves no manifest, so the directory is
/// never taken for a complete dataset. With several ranks, errors found before the build starts
/// are returned on every rank; a rank failing after that prints the failure (rank, host, work
/// item) and stops the whole job through Communicator::abortJob. The summary is complete on
/// rank 0 only.
formats::Result<BuildSummary> buildDataset(const BuildOptions& options);

}  // namespace pbdam::builder
