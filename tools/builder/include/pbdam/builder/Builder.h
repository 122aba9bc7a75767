// `pbdam build`: a DEM (and optional imagery) into a P-BDAM dataset directory — resampling onto
// the cube-map lattice, leaf patches, bottom-up block simplification level by level, measured and
// saturated errors and spheres, the texture quadtree, and atomic writing of the six face files
// and the manifest (paper 004 §3–5; docs/builder.md). Parallel with TBB; the output does not
// depend on the thread count. Thread-safety: buildDataset may run concurrently for different
// output directories.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/Result.h"
#include "pbdam/formats/TextureTile.h"

namespace pbdam::builder {

struct BuildOptions final {
  std::filesystem::path demPath;
  std::optional<RawLayout> rawLayout;  ///< read the DEM as a raw grid
  std::filesystem::path texturePath;   ///< equirectangular imagery; empty: shaded relief
  std::string planetSpec;              ///< Planet::fromSpec
  std::filesystem::path outDir;
  std::uint32_t leafVertices = 33;        ///< leaf leg vertices (2^k + 1)
  std::uint32_t patchVertices = 512;      ///< target vertices of interior patches
  std::uint32_t textureTileTexels = 256;  ///< texture tile side, border included
  std::optional<std::uint32_t> depth;     ///< bintree depth (even); auto from the DEM density
  TexelFormat textureFormat = TexelFormat::Bc1;
  Bc1Quality bc1Quality = Bc1Quality::Fast;
  double heightStepMeters = 1.0 / 64.0;
  int threads = 0;     ///< 0: all cores
  bool force = false;  ///< replace an existing dataset
  /// Called on the calling thread with the stage name and its fraction done (0..1).
  std::function<void(std::string_view stage, double fraction)> progress;
};

/// What a build did, for the summary the CLI prints.
struct BuildSummary final {
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
  std::uint64_t noDataPoints = 0;
  std::uint64_t simplifyRetries = 0;
  std::uint64_t halvesKeptUnsimplified = 0;
  double rootErrorMeters = 0.0;
  double leafMaxErrorMeters = 0.0;
  double seconds = 0.0;
};

/// Builds the dataset. Errors: bad options (InvalidArgument), unreadable inputs (the reader's
/// error), an existing dataset without `force`, I/O failures. An interrupted build leaves no
/// manifest, so the directory is never taken for a complete dataset.
Result<BuildSummary> buildDataset(const BuildOptions& options);

}  // namespace pbdam::builder
