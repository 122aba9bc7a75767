// Writing single-band byte rasters as GeoTIFF through GDAL (the viewshed mask of `pbdam query
// viewshed` and `/viewshed`): georeferenced by a geotransform and a CRS in WKT, with a nodata
// value and a colour table so that GIS tools show it as it is meant. Thread-safety: the
// functions are thread-safe (each call has its own GDAL dataset in /vsimem/).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// A single-band byte raster to write as GeoTIFF (encodeByteGeoTiff): its cells, where they
/// lie, and how GIS tools should show them.
struct ByteRaster final {
  int width = 0;                        ///< columns
  int height = 0;                       ///< rows
  std::span<const std::uint8_t> cells;  ///< width·height, row-major, row 0 at the top
  /// GDAL's: x = gt[0] + col·gt[1] + row·gt[2], y = gt[3] + col·gt[4] + row·gt[5] (cell corners).
  std::array<double, 6> geoTransform{0.0, 1.0, 0.0, 0.0, 0.0, -1.0};
  std::string srsWkt;                  ///< the CRS as WKT; empty writes none
  std::optional<std::uint8_t> noData;  ///< the value that means "no data", if any
  /// Colour table entries (value, RGBA); values not listed are transparent black.
  std::vector<std::pair<std::uint8_t, std::array<std::uint8_t, 4>>> colours;
  /// Dataset metadata items (name, value).
  std::vector<std::pair<std::string, std::string>> metadata;
};

/// The WKT of an azimuthal equidistant projection in metres centred on (lat0, lon0) over a body
/// of `semiMajorMeters` and `flattening` (0: a sphere) named `body`. InvalidArgument when GDAL
/// refuses the parameters.
Result<std::string> azimuthalEquidistantWkt(double lat0Degrees, double lon0Degrees,
                                            double semiMajorMeters, double flattening,
                                            const std::string& body);

/// The GeoTIFF file's bytes (deflate-compressed). InvalidArgument for a size that does not match
/// the cells; UnsupportedFormat when GDAL cannot write it.
Result<std::vector<std::byte>> encodeByteGeoTiff(const ByteRaster& raster);

}  // namespace pbdam::formats
