// Elevation ingest through GDAL: any raster GDAL reads (PDS3 MOLA MEGDR, NetCDF ETOPO, SRTM .hgt,
// GeoTIFF, ...; a headerless image through the PDS label beside it) and raw grids described on
// the command line, turned into a geographic HeightGrid.
// Projected CRSs are converted exactly when the projection is a linear lat/lon scaling
// (equirectangular) and warped to geographic at native resolution otherwise.
// Thread-safety: readDem may be called from several threads at once (GDAL handles are per call).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// Sample types of raw grids.
enum class RawSampleType { UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

/// How a headerless raw grid is laid out: rows north to south, no padding after `headerBytes`.
struct RawLayout final {
  std::int64_t width = 0;                     ///< samples per row
  std::int64_t height = 0;                    ///< rows
  RawSampleType type = RawSampleType::Int16;  ///< each sample's type
  bool bigEndian = false;                     ///< byte order of multi-byte samples
  LatLonBounds bounds;                        ///< area bounds of the whole grid (pixel-is-area)
  std::int64_t headerBytes = 0;               ///< bytes to skip before the first sample
};

/// Parses a raw type name: uint8, int16be, int16le, uint16be, uint16le, int32be, int32le,
/// uint32be, uint32le, float32be, float32le, float64be, float64le.
Result<RawLayout> parseRawType(std::string_view name);

/// Parses "W,H" into the layout's size and "S,W,N,E" into its bounds; checks them.
/// @{
Result<void> parseRawSize(std::string_view text, RawLayout& layout);
Result<void> parseRawBounds(std::string_view text, RawLayout& layout);
/// @}

/// Options for readDem.
struct DemReadOptions final {
  /// Read the file as a raw grid with this layout instead of letting GDAL identify it.
  std::optional<RawLayout> raw;
  /// Refuse grids with more samples than this (they must be read tile by tile).
  std::int64_t maxSamples = std::int64_t{1} << 31;
  /// Large grids out of core: when not empty and the heights take at least `mapAtBytes`, they
  /// are read in row blocks into an unnamed scratch file in this directory (on its filesystem;
  /// its space is freed when the last copy of the grid goes) and mapped, so the process holds
  /// only the pages it touches (HeightGrid::releaseResident drops those). Where no such file
  /// can be made (a full disk, no unnamed-file support), the grid is read into memory instead.
  std::filesystem::path scratchDirectory;
  /// The heights' size in bytes from which a grid is mapped (with `scratchDirectory`).
  std::uint64_t mapAtBytes = std::uint64_t{256} << 20;
};

/// The detached PDS3 label to read for `image` when GDAL does not recognise `image` alone (a
/// headerless .img) but a label with the same stem (.lbl or .LBL) sits beside it and names it;
/// nullopt otherwise. readDem reads such an image through its label (GridSource::labelPath).
std::optional<std::filesystem::path> pdsLabelFor(const std::filesystem::path& image);

/// Reads the first band of an elevation raster into a geographic HeightGrid in metres. An image
/// without a header is read through the PDS label beside it that names it (pdsLabelFor).
/// Returns an error naming the file and the problem for a missing, unrecognised, truncated or
/// inconsistent file, a CRS that cannot be made geographic, or georeferencing beyond the poles.
Result<HeightGrid> readDem(const std::filesystem::path& path, const DemReadOptions& options = {});

}  // namespace pbdam::formats
