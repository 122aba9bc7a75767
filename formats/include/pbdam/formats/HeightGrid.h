// HeightGrid: a regular latitude/longitude grid of heights in metres, the one in-memory form of
// every elevation input (MOLA PDS3, ETOPO NetCDF, SRTM .hgt, GeoTIFF, raw), with its georeference,
// nodata handling and bilinear/bicubic sampling that is correct across the longitude seam and the
// poles. The heights are held in memory or, for large grids, in a mapped scratch file
// (DemReader.h). Thread-safety: immutable after construction; all const members may be called
// from any number of threads; copies share the heights.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace pbdam::formats {

/// Where the samples of a grid sit. Row 0 is the northernmost row; rows go south, columns east.
/// Sample (row, col) has its centre at (firstLatDegrees − row·latSpacingDegrees,
/// firstLonDegrees + col·lonSpacingDegrees).
struct GridGeometry final {
  std::int64_t width = 0;          ///< columns
  std::int64_t height = 0;         ///< rows
  double firstLatDegrees = 0.0;    ///< latitude of the centre of row 0
  double firstLonDegrees = 0.0;    ///< longitude of the centre of column 0 (any range)
  double latSpacingDegrees = 0.0;  ///< > 0
  double lonSpacingDegrees = 0.0;  ///< > 0
  bool pixelIsArea = true;         ///< samples stand for cells (true) or for points (false)
};

/// Area bounds in degrees: south ≤ north, west < east (east may exceed 180 or 360).
struct LatLonBounds final {
  double southDegrees = 0.0;  ///< latitude of the south edge
  double westDegrees = 0.0;   ///< longitude of the west edge
  double northDegrees = 0.0;  ///< latitude of the north edge
  double eastDegrees = 0.0;   ///< longitude of the east edge
};

/// Descriptive facts about where a grid came from.
struct GridSource final {
  std::string path;       ///< the file that was read, as the caller named it
  std::string labelPath;  ///< the detached PDS label read for an image named alone, else empty
  std::string format;     ///< GDAL driver short name and long name, e.g. "PDS (NASA ...)"
  std::string crs;        ///< CRS name as the file states it, or "none"
  std::string body;       ///< "mars", "earth", "moon", or "" when the CRS does not say
  double semiMajorMeters = 0.0;  ///< of the CRS's ellipsoid; 0 when there is no CRS
  double flattening = 0.0;       ///< of the CRS's ellipsoid
  std::string verticalDatum;     ///< the vertical CRS of a compound CRS, else empty
  std::string units = "m";       ///< heights are converted to metres; this is what the file said
  std::optional<double> noDataValue;  ///< the file's nodata value, if it declares one
  bool warped = false;                ///< true when a projected CRS was warped to geographic
};

/// Extremes and mean of the valid samples, with where the extremes are.
struct GridStats final {
  double minMeters = 0.0;        ///< the lowest valid height
  double minLatDegrees = 0.0;    ///< latitude of the lowest sample's centre
  double minLonDegrees = 0.0;    ///< longitude of the lowest sample's centre
  double maxMeters = 0.0;        ///< the highest valid height
  double maxLatDegrees = 0.0;    ///< latitude of the highest sample's centre
  double maxLonDegrees = 0.0;    ///< longitude of the highest sample's centre
  double meanMeters = 0.0;       ///< mean of the valid heights
  std::int64_t validCount = 0;   ///< samples with a height
  std::int64_t noDataCount = 0;  ///< nodata (NaN) samples
};

/// A regular lat/lon grid of heights in metres; nodata samples are NaN.
class HeightGrid final {
 public:
  HeightGrid() = default;
  /// Takes `heightsMeters` in row-major order (row 0 north). `geometry` must have positive
  /// size and spacing and heightsMeters.size() must equal width·height.
  HeightGrid(GridGeometry geometry, std::vector<float> heightsMeters, GridSource source);
  /// The same over heights held elsewhere: `heightsMeters` points at width·height floats and
  /// owns them (its deleter frees them when the last copy of the grid goes). With `fileBacked`,
  /// they are a shared file mapping whose pages releaseResident may drop from the process.
  HeightGrid(GridGeometry geometry, std::shared_ptr<const float> heightsMeters, bool fileBacked,
             GridSource source);

  /// The same grid (sharing its heights) described by `source`.
  HeightGrid withSource(GridSource source) const {
    HeightGrid copy = *this;
    copy.source_ = std::move(source);
    return copy;
  }

  /// Where the samples are.
  const GridGeometry& geometry() const noexcept { return geometry_; }
  /// Where the grid came from.
  const GridSource& source() const noexcept { return source_; }
  /// Columns (samples west to east).
  std::int64_t width() const noexcept { return geometry_.width; }
  /// Rows (samples north to south).
  std::int64_t height() const noexcept { return geometry_.height; }

  /// The stored height of (row, col) in metres, NaN for nodata. Indices must be in range.
  float at(std::int64_t row, std::int64_t col) const noexcept;
  /// All heights in metres, row-major from the north row, NaN for nodata.
  std::span<const float> heightsMeters() const noexcept { return heights_; }

  /// True when the heights are a mapped file rather than process memory.
  bool fileBacked() const noexcept { return fileBacked_; }
  /// Drops this process's page-table entries of file-backed heights (their pages stay in the
  /// page cache; a later read is a minor fault), so that reading a large grid once does not
  /// leave it in the process's RSS. No effect on heights held in memory. Thread-safe.
  void releaseResident() const noexcept;

  /// Latitude of the centre of row `row`.
  double latOfRowDegrees(std::int64_t row) const noexcept;
  /// Longitude of the centre of column `col` (in the grid's own range, not wrapped).
  double lonOfColumnDegrees(std::int64_t col) const noexcept;

  /// True when the columns cover the full 360° of longitude (sampling then wraps the seam).
  bool wrapsLongitude() const noexcept { return wrapsLongitude_; }
  /// True when the rows reach both poles (sampling then continues over the pole).
  bool coversPoles() const noexcept { return coversNorthPole_ && coversSouthPole_; }

  /// The area the grid covers: cell edges for pixel-is-area grids, outermost sample centres for
  /// pixel-is-point grids.
  LatLonBounds bounds() const noexcept;

  /// True when (lat, lon) lies inside bounds() (longitude taken modulo 360).
  bool contains(double latDegrees, double lonDegrees) const noexcept;

  /// Bilinear height at (lat, lon). Longitude is taken modulo 360. Nodata neighbours are left
  /// out and the remaining weights renormalised. A pole covered by the grid is one point (the
  /// mean of the outermost row); between it and the outermost row centres heights blend
  /// linearly in latitude. Returns nullopt outside the grid, for a
  /// non-finite or out-of-range latitude, or when every neighbour is nodata.
  std::optional<double> sampleBilinear(double latDegrees, double lonDegrees) const noexcept;

  /// Bicubic (Catmull-Rom) height at (lat, lon); falls back to bilinear where any of the 16
  /// neighbours is nodata or beyond the first/last row (the polar caps). Same nullopt rules as
  /// sampleBilinear.
  std::optional<double> sampleBicubic(double latDegrees, double lonDegrees) const noexcept;

  /// Extremes, mean and nodata count over all samples.
  GridStats computeStats() const noexcept;

 private:
  /// Fetches sample (row, col): columns wrap (global) or clamp (regional), rows clamp, pole rows
  /// of pixel-is-point grids give the pole value; nullopt for nodata.
  std::optional<float> fetch(std::int64_t row, std::int64_t col) const noexcept;
  /// Bilinear blend of the 2×2 samples at (row0, col0) with fractions (fr, fc), nodata left out.
  std::optional<double> interpolate(std::int64_t row0, double fr, std::int64_t col0,
                                    double fc) const noexcept;
  /// Mean of the valid samples of one turn of a row; nullopt when all are nodata.
  std::optional<float> rowMean(std::int64_t row) const noexcept;
  /// Fractional (row, col) of (lat, lon); nullopt outside the grid.
  bool toGrid(double latDegrees, double lonDegrees, double& row, double& col) const noexcept;

  /// Pole means and seam facts from the geometry and the heights (both constructors).
  void init();

  GridGeometry geometry_;
  std::shared_ptr<const float> storage_;  ///< keeps heights_ alive
  std::span<const float> heights_;
  bool fileBacked_ = false;
  GridSource source_;
  std::int64_t wrapColumns_ = 0;  ///< columns in one turn of longitude, 0 if regional
  bool wrapsLongitude_ = false;
  bool coversNorthPole_ = false;
  bool coversSouthPole_ = false;
  std::optional<float> poleNorthMeters_;
  std::optional<float> poleSouthMeters_;
};

}  // namespace pbdam::formats
