// What `pbdam query viewshed` and `/viewshed` give back: the mask as a georeferenced GeoTIFF
// (the observer's azimuthal equidistant projection, 1 visible, 0 hidden, 255 nodata, with a
// colour table) and the figures as JSON.
#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuViewshed.h"

namespace pbdam::tools {

/// The mask's GeoTIFF file bytes.
formats::Result<std::vector<std::byte>> viewshedGeoTiff(const gpu::TerrainViewshed& viewshed);

/// The figures: observer, grid, visible cells and area, the farthest visible point, timings.
nlohmann::ordered_json viewshedJson(const gpu::TerrainViewshed& viewshed,
                                    double heightAboveGroundMeters);

}  // namespace pbdam::tools
