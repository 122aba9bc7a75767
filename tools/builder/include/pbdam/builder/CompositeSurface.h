// The one surface a hybrid dataset is built from (docs/builder.md "Insets"): a global base DEM
// and local high-resolution insets, each read through GDAL in any format and projection. One
// function of position: inside an inset's footprint (its valid samples) the inset's heights, in
// a transition band just inside the footprint's edge a blend to what lies below, outside it the
// base unchanged; where insets overlap, the finer wins. Tiles that touch or overlap at one
// spacing are one surface (one grid, no band along their seams), and the voids of a surface
// are filled from its own samples (VoidFill.h), so the band lies only where its data ends. Patch
// errors are measured against the composite's own samples (forEachSample): base samples where no
// inset lies, each inset's samples where it is the finest, with their blended heights in its band.
// Thread-safety: immutable after make(); const members are safe from any thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "pbdam/builder/VoidFill.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/MemoryMapping.h"
#include "pbdam/formats/Result.h"

namespace pbdam::builder {

/// An inset as the command line names it.
struct InsetSpec final {
  /// A DEM file, a VRT, or a set of tiles: a directory or a glob (formats/DemTileSet.h).
  std::filesystem::path path;
  /// Added to the inset's heights (metres), for an inset on another vertical datum.
  std::optional<double> offsetMeters;
  /// Imagery for the inset's texels (any image readImage reads: georeferenced, or else taken
  /// to cover the inset's footprint); empty for shaded relief.
  std::filesystem::path texturePath;
};

/// The transition band's width in inset samples: at least 16, and at least one sample spacing
/// of the surface below (`below`: the base, or a coarser inset containing this one), so the
/// blend spans several inset samples and a whole cell of what it blends into (wider would eat
/// small insets: two ETOPO5 spacings leave 30 of Luxembourg's samples outside the band) — but
/// at most a quarter of the inset's smaller side (when that exceeds 16), so that an inset
/// smaller than a cell below it (4 km of lidar on ETOPO5's 9 km) keeps its middle half at its
/// own samples.
std::int64_t transitionBandSamples(const formats::HeightGrid& below,
                                   const formats::HeightGrid& inset) noexcept;

/// Checks an inset read from `spec.path` against the base and the planet: on the same body
/// (when its CRS says), on the same vertical datum as the base when both declare one (or
/// `offsetMeters` given), finer than the base, with valid samples. InvalidArgument naming the
/// file and what is wrong.
formats::Result<void> checkInset(const InsetSpec& spec, const formats::HeightGrid& inset,
                                 const formats::HeightGrid& base, const std::string& planetSpec);

/// The most inset surfaces a dataset joins: a leaf's sources (formats::NodeRecord::sources)
/// give the base bit 0 and each surface one of the other 31 bits.
inline constexpr std::size_t kMaxInsetSurfaces = 31;

/// Which source defines the composite at a point.
struct SourceAt final {
  int inset = -1;       ///< index into the composite's insets, −1 for the base
  double weight = 0.0;  ///< of that inset there: 1 inside its band, 0 < w < 1 in the band
};

/// One surface of inset samples before it joins the composite: the tiles of one or more specs
/// that touch or overlap at one spacing, read as one grid (formats::readDemMosaic).
struct InsetSurfaceInput final {
  formats::HeightGrid grid;
  std::vector<std::size_t> specs;  ///< indices of the specs whose tiles it holds, ascending
  std::size_t tiles = 1;           ///< how many files it was read from
  /// The footprint of each of `specs` (the box of its own tiles), for its imagery.
  std::vector<formats::LatLonBounds> specBounds;
};

class CompositeSurface final {
 public:
  /// One inset surface: its grid (voids filled), its height offset and its band.
  struct Inset final {
    formats::HeightGrid grid;
    double offsetMeters = 0.0;
    std::int64_t bandSamples = 16;
    /// Per sample (row-major), the Chebyshev distance to the nearest sample outside the
    /// footprint, capped at band + 1: the inset weight before smoothing is (d − 1)/band, 0 on
    /// the footprint's outer ring (valid samples next to nodata or the grid's edge), 1 beyond
    /// the band. Held like the grid's heights: a mapped scratch file beside a file-backed grid
    /// (when the fill options name a scratch directory), so a tile set's surface is never
    /// whole in memory; `edgeDistanceOwner` keeps it alive.
    std::span<const std::uint16_t> edgeDistance;
    std::shared_ptr<const void> edgeDistanceOwner;
    /// The scratch mapping behind edgeDistance, or null when it is in memory.
    std::shared_ptr<const formats::MemoryMapping> edgeDistanceFile;
    std::vector<std::size_t> specs;                 ///< the specs (indices into specs()) it joins
    std::vector<formats::LatLonBounds> specBounds;  ///< the footprint of each of those
    std::size_t tiles = 1;                          ///< the files it was read from
    VoidReport voids;                               ///< what its voids were and became
    std::vector<formats::VoidRun> voidRuns;         ///< where they were (its grid's rows)
    /// Its position among the surfaces ordered by their first spec (the manifest's order).
    std::size_t manifestIndex = 0;
  };

  /// Reads the insets of `specs` (files, VRTs, directories or globs of tiles) and joins them to
  /// `base`: every tile is probed, tiles that touch or overlap at one spacing and CRS with the
  /// same height offset become one surface whatever spec or order they came in, each surface is
  /// checked against the base (checkInset, naming its first spec), its voids filled
  /// (VoidFill.h) and joined. Errors name the file or spec: unreadable or corrupt tiles, empty
  /// sets, tiles of another body, more surfaces than a leaf's sources can name (31).
  static formats::Result<CompositeSurface> read(formats::HeightGrid base,
                                                std::vector<InsetSpec> specs,
                                                const formats::DemReadOptions& readOptions,
                                                const std::string& planetSpec,
                                                const VoidFillOptions& fill = {});

  /// The composite of `base` and the inset `surfaces` (any order: they are sorted from
  /// coarsest to finest, ties by their first spec). Index i of sourceAt() and forEachSample()
  /// is the position in insets() (that order). Voids are filled coarsest first, each over the
  /// composite of what is below it. Errors: the void fill's.
  static formats::Result<CompositeSurface> make(formats::HeightGrid base,
                                                std::vector<InsetSpec> specs,
                                                std::vector<InsetSurfaceInput> surfaces,
                                                const VoidFillOptions& fill = {});
  /// The same with one surface per spec, `grids` in the order of `specs`.
  static formats::Result<CompositeSurface> make(formats::HeightGrid base,
                                                std::vector<InsetSpec> specs,
                                                std::vector<formats::HeightGrid> grids,
                                                const VoidFillOptions& fill = {});

  const formats::HeightGrid& base() const noexcept { return base_; }
  const std::vector<Inset>& insets() const noexcept { return insets_; }
  /// Lets the insets' mapped pages go from the process (HeightGrid::releaseResident).
  void releaseResident() const {
    for (const Inset& inset : insets_) {
      inset.grid.releaseResident();
      if (inset.edgeDistanceFile) (void)inset.edgeDistanceFile->releaseResident();
    }
  }
  /// The specs as given (the options' order); each inset says which of them it holds.
  const std::vector<InsetSpec>& specs() const noexcept { return specs_; }
  /// The weight of spec `k`'s imagery at (lat, lon): its surface's weight, within the
  /// footprint of its own tiles when the surface joins several specs.
  double specWeight(std::size_t k, double latDegrees, double lonDegrees) const noexcept;
  /// The voids of every surface, in the manifest's order (the dataset's voids.bin); empty
  /// surfaces list when no surface had a void.
  formats::VoidMap voidMap() const;
  /// The footprint of spec `k`'s own tiles (its imagery's box when the imagery has none).
  formats::LatLonBounds specFootprint(std::size_t k) const noexcept;
  /// The index into insets() of the surface at `manifestIndex` (surfaces ordered by their
  /// first spec).
  std::size_t insetOfManifestIndex(std::size_t manifestIndex) const noexcept;

  /// The composite height at (lat, lon): the base's bicubic height (bilinear where bicubic
  /// lacks data), then for each inset from coarsest to finest w·(the inset's height, read the
  /// same way, + offset) + (1 − w)·(what lies below), w the inset's weight there. nullopt where
  /// the base has no data and no inset has weight 1.
  std::optional<double> heightAt(double latDegrees, double lonDegrees) const noexcept;
  /// The weight of inset `i` at (lat, lon): 0 outside its footprint, smoothstep of the
  /// bilinear blend of its samples' band weights inside (C¹ across the band's edges).
  double weightOf(std::size_t i, double latDegrees, double lonDegrees) const noexcept;
  /// The finest inset with a weight above 0 at (lat, lon), or the base.
  SourceAt sourceAt(double latDegrees, double lonDegrees) const noexcept;
  /// Every sample that defines the composite, with its composite height: the base's samples
  /// where no inset has a weight, each inset's samples where no finer inset has one (their
  /// heights blended with what lies below in the band). `source` is −1 for the base.
  void forEachSample(
      const std::function<void(int source, double lat, double lon, double height)>& fn) const;

 private:
  formats::HeightGrid base_;
  std::vector<Inset> insets_;
  std::vector<InsetSpec> specs_;
  /// heightAt restricted to the base and insets [0, upTo).
  std::optional<double> heightBelow(std::size_t upTo, double lat, double lon) const noexcept;
};

}  // namespace pbdam::builder
