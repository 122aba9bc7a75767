// The heights of a DEM's band in metres (nodata as NaN; scale, offset and length unit applied),
// read into memory or, for a large grid, out of core: row blocks straight into an unnamed
// scratch mapping whose pages are dropped from the process as they are written. Private to
// pbdam_formats (readDem, DemReader.cpp). Thread-safety: one band per thread.
#pragma once

#include <gdal.h>

#include <filesystem>

#include "GdalErrorCapture.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// Reads `band`'s heights for a grid of `geometry`, into a scratch mapping in
/// options.scratchDirectory when one is named and the heights take at least
/// options.mapAtBytes, into memory otherwise (also when no scratch file can be made: a full
/// disk, a filesystem without unnamed files). The band's nodata value and unit are recorded in
/// `source`, which the grid keeps. Errors name `path`: an unknown height unit
/// (UnsupportedFormat), samples GDAL cannot read (CorruptData, with GDAL's messages from
/// `capture`).
Result<HeightGrid> readDemHeights(GDALRasterBandH band, const GridGeometry& geometry,
                                  GridSource source, const std::filesystem::path& path,
                                  const DemReadOptions& options, const GdalErrorCapture& capture);

}  // namespace pbdam::formats
