// Imagery ingest: equirectangular colour images (JPEG/PNG/TIFF) read through OpenImageIO into
// RGBA8, with their lat/lon bounds (GDAL's georeference where the file has one, else the whole
// globe from −180° to 180°); images georeferenced in a projected CRS are warped by GDAL to the
// geographic CRS of their datum, alpha 0 outside their footprint. Thread-safety: immutable after
// loading; const members are safe from any thread.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// An RGBA8 image covering `bounds` in equirectangular projection, row 0 at the north edge.
class GeoImage final {
 public:
  GeoImage() = default;
  /// Takes `rgba` (width·height·4 bytes, row 0 north) covering `bounds`; `georeferenced` says
  /// whether the bounds came from the file (georeferenced()).
  GeoImage(std::int64_t width, std::int64_t height, std::vector<std::uint8_t> rgba,
           LatLonBounds bounds, bool georeferenced);

  /// Columns (pixels west to east).
  std::int64_t width() const noexcept { return width_; }
  /// Rows (pixels north to south).
  std::int64_t height() const noexcept { return height_; }
  /// The area the image covers.
  const LatLonBounds& bounds() const noexcept { return bounds_; }
  /// True when the bounds came from the file's georeference rather than the global default.
  bool georeferenced() const noexcept { return georeferenced_; }
  /// The pixels, RGBA8, row-major from the north row.
  const std::vector<std::uint8_t>& rgba() const noexcept { return rgba_; }

  /// The RGBA of the pixel in column x of row y (row 0 at the top), the argument order of every
  /// image type in pbdam (gpu::RgbaImage too); indices must be in range.
  std::array<std::uint8_t, 4> pixel(std::int64_t x, std::int64_t y) const noexcept;

  /// Bilinear RGBA at (lat, lon), channels in [0, 255]; longitude wraps for global images.
  /// nullopt outside the image or for non-finite input.
  std::optional<std::array<float, 4>> sampleBilinear(double latDegrees,
                                                     double lonDegrees) const noexcept;

 private:
  std::int64_t width_ = 0;
  std::int64_t height_ = 0;
  std::vector<std::uint8_t> rgba_;
  LatLonBounds bounds_;
  bool georeferenced_ = false;
};

/// Reads an image (JPEG, PNG, TIFF, ... anything OpenImageIO reads) as RGBA8. Grey images are
/// expanded, alpha defaults to 255. A projected GeoTIFF (8-bit bands) is warped to geographic
/// (bilinear, GDAL's default resolution) with alpha 0 where it has no source pixel. A directory
/// or a glob (DemTileSet.h) is a set of georeferenced imagery tiles, read as one image (a GDAL
/// VRT mosaic, alpha 0 where no tile lies). Errors name the file: missing, unreadable,
/// truncated, a tile of a set without a georeference.
Result<GeoImage> readImage(const std::filesystem::path& path);

}  // namespace pbdam::formats
