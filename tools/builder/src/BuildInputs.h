// What every rank of a build prepares identically before the distributed work
// (docs/builder.md "Distributed build"): the options checked, the DEM and imagery read, the
// lattice size chosen, and the fingerprint that ties a checkpoint to its build. Private to the
// builder.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/builder/Builder.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/builder/Lattice.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// Everything every rank prepares identically before the distributed work.
struct BuildInputs final {
  std::optional<runtime::Planet> planet;
  std::optional<formats::HeightGrid> dem;  ///< released between resampling and the textures
  formats::GridSource demSource;
  std::optional<formats::GeoImage> imagery;
  std::uint32_t leafCells = 0;
  std::uint32_t depth = 0;      ///< the deepest leaves' level
  std::uint32_t baseDepth = 0;  ///< the leaves' level outside deep regions (= depth without)
  std::uint32_t n = 0;          ///< lattice cells per face side (of the deepest leaves)
  /// The options' deep regions, then one per inset (over its grid, at its density's level).
  std::vector<DeepRegion> deepRegions;
  /// With insets: the base and the insets as one surface (sharing the base's heights).
  std::optional<CompositeSurface> composite;
  /// Per inset of the composite (its order): its imagery, or nullopt for shaded relief.
  std::vector<std::optional<formats::GeoImage>> insetImagery;
};

class ForestPlan;

/// What the build did with each inset surface (its name, tiles and voids), in the manifest's
/// order; empty without insets.
std::vector<InsetSurfaceSummary> insetSummaries(const BuildOptions& o, const BuildInputs& in);

/// The manifest's record of each inset, in the order of the options (empty without insets).
std::vector<formats::ManifestInset> manifestInsets(const BuildOptions& o, const BuildInputs& in);

/// With insets: a leaf's sources (formats::NodeRecord::sources) from which source defines the
/// composite at each point of its regular patch: an inset's bit where it has a weight, the
/// base's where it has less than 1. Null without insets. Keeps references to its arguments.
std::function<std::uint32_t(const runtime::BinTriangle&)> leafSources(const BuildOptions& o,
                                                                      const BuildInputs& in,
                                                                      const ForestPlan& plan,
                                                                      const Lattice& lattice);

/// Each inset's imagery (InsetSpec::texturePath), in the composite's order: nullopt for shaded
/// relief; an image without a georeference takes its inset's footprint. Errors: unreadable
/// images, a georeferenced one that does not overlap its inset.
formats::Result<std::vector<std::optional<formats::GeoImage>>> readInsetImagery(
    const CompositeSurface& composite);

/// The even leaf level whose lattice is at least as dense as `grid`'s samples, for leaves of
/// `leafCells` cells.
std::uint32_t levelOfDensity(const formats::HeightGrid& grid, std::uint32_t leafCells);

/// How the builder reads the DEM: a large one goes to an unnamed scratch file on the output's
/// filesystem (the nearest existing directory of --out) and is mapped, so it is not held in
/// memory (DemReader.h; the ResidentTrimmer drops its pages).
formats::DemReadOptions demReadOptions(const BuildOptions& o);

/// Checks the options, reads the DEM (and imagery) and sizes the lattice. Errors: bad options
/// (naming the option), unreadable inputs, an output directory that holds a dataset.
formats::Result<BuildInputs> prepareInputs(const BuildOptions& o);

/// The DEM's identity in the fingerprint: the CRC-32 of its heights, in hex.
std::string demCrc32(const formats::HeightGrid& dem);

/// The version of how the levels are made and what their carry holds, in the fingerprint: 2
/// since each level is made from the level below (docs/decisions.md "Builder"); checkpoints
/// without it were written by the builder that made every level from the lattice.
inline constexpr int kBuilderLevelsVersion = 2;

/// The options and inputs that decide the output bytes (the checkpoint's fingerprint). Thread
/// and rank counts are not among them: they do not change the output.
std::vector<std::pair<std::string, std::string>> fingerprintOf(const BuildOptions& o,
                                                               const BuildInputs& in);

}  // namespace pbdam::builder
