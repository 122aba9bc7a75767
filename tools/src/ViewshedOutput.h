// What `pbdam query viewshed|los` and `/viewshed`, `/los` give back: the mask as a georeferenced
// GeoTIFF (the observer's azimuthal equidistant projection, 1 visible, 0 hidden, 255 nodata, with
// a colour table), the figures as JSON, and the mask as a drape over the terrain.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/gpu/TerrainRenderer.h"

namespace pbdam::tools {

/// The mask as an overlay to drape over the terrain: visible cells green, hidden ones darkened,
/// both 60% opaque; outside the radius clear.
std::shared_ptr<const gpu::SurfaceOverlay> viewshedOverlay(const gpu::TerrainViewshed& viewshed);

/// The line of sight's answer (`pbdam query los --json`, `/los`).
nlohmann::ordered_json sightlineJson(const runtime::Planet& planet,
                                     const gpu::TerrainSightline& line);

/// The mask's GeoTIFF file bytes.
formats::Result<std::vector<std::byte>> viewshedGeoTiff(const gpu::TerrainViewshed& viewshed);

/// The figures: observer, grid, visible cells and area, the farthest visible point, timings.
nlohmann::ordered_json viewshedJson(const gpu::TerrainViewshed& viewshed,
                                    double heightAboveGroundMeters);

}  // namespace pbdam::tools
