// Nodata samples interpolated from the valid samples around them by GDAL's fill-nodata
// algorithm (GDALFillNodata: inverse-distance weighting of the nearest valid samples found in
// each direction within a search distance, no smoothing) — the algorithm of
// `gdal_fillnodata.py`, used for the voids of survey tiles (tools/builder VoidFill.h).
// Thread-safety: a free function over the caller's buffer; calls on different buffers may run
// concurrently.
#pragma once

#include <cstdint>
#include <span>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// Fills, in place, the NaN samples of the row-major `width` × `height` grid `heightsMeters`
/// that lie within `maxSearchDistanceSamples` of a valid (finite) sample, interpolating from the
/// valid samples only; NaN samples beyond that distance stay NaN. `heightsMeters.size()` must be
/// width·height. Errors: GDAL failing to create its in-memory raster or to run the fill.
Result<void> fillNodata(std::span<float> heightsMeters, std::int64_t width, std::int64_t height,
                        double maxSearchDistanceSamples);

}  // namespace pbdam::formats
