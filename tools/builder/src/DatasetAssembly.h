// The last stage of the build (docs/builder.md "Distributed build"): rank 0 writes the six face
// files and the manifest from the checkpointed levels and texture tiles, read through mappings
// so that the blobs are never all in memory at once. Private to the builder.
#pragma once

#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/VoidMap.h"

#include "ForestPlan.h"

#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "pbdam/builder/Builder.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/streaming/MappedFile.h"

namespace pbdam::builder {

/// The texture quadtree's levels for a lattice of `latticeCells` per face side and tiles of
/// `tileTexels` with `borderTexels` on each side: enough that the finest tiles have about one
/// texel per lattice cell.
std::uint32_t textureLevelCount(std::uint32_t latticeCells, std::uint32_t tileTexels,
                                std::uint32_t borderTexels);

/// The texture tile border, in texels, on each side.
inline constexpr std::uint32_t kTextureBorderTexels = 2;

/// Mappings that the ResidentTrimmer releases while the assembly walks them. Thread-safe.
class AssemblyMappings final {
 public:
  void add(const streaming::MappedFile* mapping) {
    std::lock_guard lock(mutex_);
    mappings_.push_back(mapping);
  }
  void clear() {
    std::lock_guard lock(mutex_);
    mappings_.clear();
  }
  void releaseResident() const {
    std::lock_guard lock(mutex_);
    for (const streaming::MappedFile* m : mappings_) (void)m->releaseResident();
  }

 private:
  mutable std::mutex mutex_;
  std::vector<const streaming::MappedFile*> mappings_;
};

/// What the assembly needs from the build.
struct AssemblyInputs final {
  const BuildOptions& options;
  const ForestPlan& plan;  ///< which nodes exist and which are leaves
  const Checkpoint& checkpoint;
  const CheckpointState& state;  ///< the part counts of the levels and the textures
  const runtime::Planet& planet;
  std::uint32_t latticeCells = 0;
  std::uint32_t leafCells = 0;
  std::uint32_t depth = 0;
  bool hasImagery = false;
  std::string sourceFormat;
  double minHeightMeters = 0.0;
  double maxHeightMeters = 0.0;
  std::vector<formats::ManifestInset> insets;  ///< in the manifest's order
  /// With insets: a leaf's sources (NodeRecord::sources) from its triangle.
  std::function<std::uint32_t(const runtime::BinTriangle&)> leafSources;
  /// The insets' voids (written as voids.bin when it lists surfaces).
  formats::VoidMap voids;
  /// Where the assembly registers its mappings while it reads them (cleared before it returns).
  AssemblyMappings& mappings;
  /// Called with the fraction of the face files written.
  std::function<void(double)> progress;
  /// Called with a line for the build's log (the decision to free the checkpoint's pages).
  std::function<void(const std::string&)> log;
};

/// Writes the face files and the manifest from the checkpoint, fills the dataset's figures in
/// `summary` (its sourceSamples must be set), and removes the checkpoint. Errors: a damaged or
/// incomplete checkpoint, a failed write.
formats::Result<void> assembleDataset(const AssemblyInputs& inputs, BuildSummary& summary);

}  // namespace pbdam::builder
