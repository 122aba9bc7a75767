// The viewshed's GeoTIFF and JSON (ViewshedOutput.h).
#include "ViewshedOutput.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <glm/geometric.hpp>
#include <string>

#include "pbdam/formats/GeoTiffWriter.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {

std::shared_ptr<const gpu::SurfaceOverlay> viewshedOverlay(const gpu::TerrainViewshed& viewshed) {
  auto overlay = std::make_shared<gpu::SurfaceOverlay>();
  const ViewshedGrid& grid = viewshed.grid;
  overlay->latDegrees = grid.latDegrees;
  overlay->lonDegrees = grid.lonDegrees;
  overlay->cellMeters = grid.cellMeters;
  overlay->image.widthPixels = static_cast<std::uint32_t>(grid.cells);
  overlay->image.heightPixels = static_cast<std::uint32_t>(grid.cells);
  overlay->image.rgba.resize(viewshed.mask.size() * 4);
  for (std::size_t i = 0; i < viewshed.mask.size(); ++i) {
    std::array<std::uint8_t, 4> rgba{0, 0, 0, 0};
    if (viewshed.mask[i] == kViewshedVisible) rgba = {70, 255, 90, 150};
    if (viewshed.mask[i] == kViewshedHidden) rgba = {15, 10, 45, 150};
    std::copy(rgba.begin(), rgba.end(),
              overlay->image.rgba.begin() + static_cast<std::ptrdiff_t>(4 * i));
  }
  return overlay;
}

nlohmann::ordered_json sightlineJson(const Planet& planet, const gpu::TerrainSightline& line) {
  const gpu::SightlineResult& sight = line.result;
  const double length = glm::length(line.to - line.from);
  nlohmann::ordered_json j;
  j["visible"] = sight.visible;
  j["distance_m"] = length;
  j["from_ground_m"] = line.groundFromMeters;
  j["to_ground_m"] = line.groundToMeters;
  j["triangles_tested"] = line.triangles;
  j["crossings"] = sight.crossings;
  if (!sight.visible) {
    const glm::dvec3 blocked = line.from + sight.nearestFraction * (line.to - line.from);
    const GeodeticPosition at = planet.ecefToGeodetic(blocked);
    j["blocked_at"] = {{"lat", at.latDegrees},
                       {"lon", at.lonDegrees},
                       {"height_m", at.heightMeters},
                       {"distance_m", sight.nearestFraction * length}};
  }
  return j;
}

Result<std::vector<std::byte>> viewshedGeoTiff(const gpu::TerrainViewshed& viewshed) {
  const ViewshedGrid& grid = viewshed.grid;
  auto wkt = azimuthalEquidistantWkt(grid.latDegrees, grid.lonDegrees,
                                     grid.planet.equatorialRadiusMeters(), grid.planet.flattening(),
                                     grid.planet.name());
  if (!wkt) return std::move(wkt).error();
  ByteRaster raster;
  raster.width = grid.cells;
  raster.height = grid.cells;
  raster.cells = viewshed.mask;
  const double corner = (grid.half() + 0.5) * grid.cellMeters;
  raster.geoTransform = {-corner, grid.cellMeters, 0.0, corner, 0.0, -grid.cellMeters};
  raster.srsWkt = std::move(*wkt);
  raster.noData = kViewshedOutside;
  raster.colours = {{kViewshedHidden, {150, 30, 30, 160}}, {kViewshedVisible, {40, 200, 60, 160}}};
  const auto number = [](double v) {
    char text[40];
    std::snprintf(text, sizeof text, "%.10g", v);
    return std::string(text);
  };
  raster.metadata = {{"PBDAM_VIEWSHED", "1 visible, 0 hidden, 255 outside the radius"},
                     {"PBDAM_OBSERVER_LAT", number(grid.latDegrees)},
                     {"PBDAM_OBSERVER_LON", number(grid.lonDegrees)},
                     {"PBDAM_EYE_HEIGHT_M", number(grid.eyeHeightMeters)},
                     {"PBDAM_RADIUS_M", number(grid.radiusMeters)}};
  return encodeByteGeoTiff(raster);
}

nlohmann::ordered_json viewshedJson(const gpu::TerrainViewshed& v, double heightAboveGroundMeters) {
  const ViewshedGrid& grid = v.grid;
  nlohmann::ordered_json j;
  j["observer"] = {{"lat", grid.latDegrees},
                   {"lon", grid.lonDegrees},
                   {"ground_m", grid.groundMeters},
                   {"height_above_ground_m", heightAboveGroundMeters}};
  j["radius_m"] = grid.radiusMeters;
  j["cell_m"] = grid.cellMeters;
  j["cells"] = grid.cells;
  j["horizon_limit_m"] = grid.horizonLimitMeters;
  j["cells_in_radius"] = v.stats.cellsInRadius;
  j["visible_cells"] = v.stats.visibleCells;
  j["visible_fraction"] =
      v.stats.cellsInRadius == 0
          ? 0.0
          : static_cast<double>(v.stats.visibleCells) / static_cast<double>(v.stats.cellsInRadius);
  j["visible_area_km2"] = v.stats.visibleAreaSquareMeters / 1e6;
  j["farthest_visible"] = {{"lat", v.stats.farthestVisible.latDegrees},
                           {"lon", v.stats.farthestVisible.lonDegrees},
                           {"distance_m", v.stats.farthestVisibleMeters}};
  j["patches"] = v.patches;
  j["triangles"] = v.passes.triangles;
  j["rays"] = v.passes.rays;
  j["extract_ms"] = v.extractMilliseconds;
  j["project_ms"] = v.passes.projectMilliseconds;
  j["device_ms"] = v.passes.deviceMilliseconds;
  j["total_ms"] = v.totalMilliseconds;
  return j;
}

}  // namespace pbdam::tools
