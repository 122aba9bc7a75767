// The voids of an inset filled from its own samples (docs/builder.md "Insets: voids and tile
// sets"). A void is an 8-connected region of nodata samples that does not reach the grid's edge
// (nodata reaching the edge, a coastline or a country clip, stays outside the footprint; a clip's
// staircase touches the outside at corners, hence 8-connected). A void
// is filled from its rim by GDAL's fill-nodata (formats/NodataFill.h) when that reaches every
// sample of it within `maxDistanceSamples`; a larger void (a lake or sea masked as nodata, a
// missing tile) takes the surface below — the base or a coarser inset — plus the inset's offset
// from it along the rim, fading to nothing across a band of half the void's inscribed radius
// (at most `maxDistanceSamples`). Either way the inset's valid samples keep their heights and
// the transition to what lies below happens only where the inset's data ends. Thread-safety:
// free functions; the `below` callback is called from the calling thread only.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>

#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"
#include "pbdam/formats/VoidMap.h"

namespace pbdam::builder {

struct VoidFillOptions final {
  /// GDAL's search distance: a void is filled from its rim when every sample of it lies within
  /// this many samples of a valid one (gdal_fillnodata.py's default, -md 100).
  double maxDistanceSamples = 100.0;
  /// Where a copy of a large file-backed grid goes (DemReadOptions::scratchDirectory); empty
  /// copies into memory.
  std::filesystem::path scratchDirectory;
};

/// What the voids of a grid were and what became of them.
struct VoidReport final {
  std::int64_t voids = 0;           ///< enclosed nodata regions
  std::int64_t voidSamples = 0;     ///< their samples
  std::int64_t filledVoids = 0;     ///< voids filled from their rims
  std::int64_t filledSamples = 0;   ///< samples of those
  std::int64_t largeVoids = 0;      ///< voids that take the surface below
  std::int64_t belowSamples = 0;    ///< samples of those: where the surface below shows through
  std::int64_t outsideSamples = 0;  ///< nodata reaching the grid's edge (outside the footprint)
  /// The box of the largest void that takes the surface below (degrees); valid when largeVoids.
  formats::LatLonBounds largestBelow;
  std::int64_t largestBelowSamples = 0;
};

/// Finds the voids of `grid` and classifies them as fillVoids would (filled from the rim or
/// left to the surface below), without changing anything. For `pbdam dem info`.
formats::Result<VoidReport> findVoids(const formats::HeightGrid& grid,
                                      const VoidFillOptions& options = {});

/// A grid with its voids filled, and what was done.
struct FilledGrid final {
  formats::HeightGrid grid;  ///< the input itself when it has no voids
  VoidReport report;
  /// Where the voids were on the grid and what each became (sorted by row and column).
  std::vector<formats::VoidRun> runs;
};

/// Fills the voids of `grid` (see the file comment). `below(lat, lon)` is the surface under
/// the inset (nullopt where there is none: such void samples stay nodata). Errors: GDAL's
/// fill failing, no space for the copy.
formats::Result<FilledGrid> fillVoids(
    const formats::HeightGrid& grid, const VoidFillOptions& options,
    const std::function<std::optional<double>(double latDegrees, double lonDegrees)>& below);

}  // namespace pbdam::builder
