// A viewshed's grid and the brute-force ray march over a DEM (Viewshed.h).
#include "pbdam/runtime/Viewshed.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>

#include "pbdam/runtime/SurfaceQuery.h"

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

std::string metres(double m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f m", m);
  return text;
}

}  // namespace

std::optional<double> demHeight(const HeightGrid& dem, double latDegrees, double lonDegrees) {
  auto h = dem.sampleBicubic(latDegrees, lonDegrees);
  return h ? h : dem.sampleBilinear(latDegrees, lonDegrees);
}

glm::dvec2 ViewshedGrid::project(double lat, double lon) const noexcept {
  const GeodesicInverse g = planet.geodesicInverse(latDegrees, lonDegrees, lat, lon);
  const double azimuth = g.azimuth1Degrees / kDegrees;
  return {g.distanceMeters * std::sin(azimuth), g.distanceMeters * std::cos(azimuth)};
}

GeodeticPosition ViewshedGrid::unproject(const glm::dvec2& en) const noexcept {
  const double distance = std::hypot(en.x, en.y);
  if (distance == 0.0) return {latDegrees, lonDegrees, 0.0};
  const GeodesicDirect g =
      planet.geodesicDirect(latDegrees, lonDegrees, std::atan2(en.x, en.y) * kDegrees, distance);
  return {g.latDegrees, g.lonDegrees, 0.0};
}

double ViewshedGrid::cellAreaSquareMeters(int col, int row) const noexcept {
  const double rho = glm::length(cellCentreMeters(col, row));
  const double r = planet.equatorialRadiusMeters();
  const double stretch = rho == 0.0 ? 1.0 : r * std::sin(rho / r) / rho;
  return cellMeters * cellMeters * stretch;
}

bool ViewshedGrid::inRadius(int col, int row) const noexcept {
  return glm::length(cellCentreMeters(col, row)) <= radiusMeters;
}

Result<ViewshedGrid> viewshedGrid(const DatasetView& view, const ViewshedRequest& request) {
  const auto bad = [](const std::string& what) {
    return makeError(ErrorCode::InvalidArgument, what);
  };
  if (!(std::fabs(request.latDegrees) <= 90.0) || !(std::fabs(request.lonDegrees) <= 360.0)) {
    return bad("--at: latitude must be in [-90, 90] and longitude in [-360, 360]");
  }
  if (!std::isfinite(request.heightAboveGroundMeters) || request.heightAboveGroundMeters < 0.0) {
    return bad("--at: the observer is underground (height above ground < 0)");
  }
  if (request.radiusMeters &&
      !(std::isfinite(*request.radiusMeters) && *request.radiusMeters > 0.0)) {
    return bad("--radius-m must be a positive number of metres");
  }
  if (request.cellMeters && !(std::isfinite(*request.cellMeters) && *request.cellMeters > 0.0)) {
    return bad("--cell-m must be a positive number of metres");
  }
  auto ground = surfaceHeightAt(view, request.latDegrees, request.lonDegrees);
  if (!ground) return bad("--at: " + ground.error().message);
  ViewshedGrid grid;
  grid.planet = view.planet();
  grid.latDegrees = request.latDegrees;
  grid.lonDegrees = std::remainder(request.lonDegrees, 360.0);
  grid.groundMeters = ground->heightMeters;
  grid.eyeHeightMeters = ground->heightMeters + request.heightAboveGroundMeters;
  grid.eyeEcef = grid.planet.geodeticToEcef(grid.latDegrees, grid.lonDegrees, grid.eyeHeightMeters);

  // The horizon limit: the eye over the lowest sphere the terrain reaches, the highest terrain
  // anywhere on the planet at its own tangent to that sphere, arcs on the largest radius.
  const formats::Manifest& manifest = view.manifest();
  const double low = grid.planet.polarRadiusMeters() + std::min(0.0, manifest.minHeightMeters);
  const double eye = grid.planet.equatorialRadiusMeters() + grid.eyeHeightMeters;
  const double top = grid.planet.equatorialRadiusMeters() + manifest.maxHeightMeters;
  grid.horizonLimitMeters =
      (std::acos(std::min(1.0, low / eye)) + std::acos(std::min(1.0, low / top))) *
      grid.planet.equatorialRadiusMeters();

  grid.cellMeters = request.cellMeters.value_or(view.latticeSpacingMeters());
  grid.radiusMeters =
      request.radiusMeters.value_or(std::min(256.0 * grid.cellMeters, grid.horizonLimitMeters));
  if (grid.radiusMeters > grid.horizonLimitMeters) {
    return bad("--radius-m " + metres(grid.radiusMeters) +
               " is beyond the horizon of the whole planet from this eye (" +
               metres(grid.horizonLimitMeters) +
               ": no terrain of the dataset can be seen farther away)");
  }
  const double halfCells = std::ceil(grid.radiusMeters / grid.cellMeters);
  if (2.0 * halfCells + 1.0 > kViewshedMaxCells) {
    return bad("--radius-m " + metres(grid.radiusMeters) + " at --cell-m " +
               std::to_string(grid.cellMeters) + " makes " +
               std::to_string(static_cast<long long>(2.0 * halfCells + 1.0)) +
               " cells a side; at most " + std::to_string(kViewshedMaxCells) +
               " (raise --cell-m or lower --radius-m)");
  }
  grid.cells = 2 * static_cast<int>(halfCells) + 1;
  return grid;
}

std::vector<std::uint8_t> viewshedByRayMarch(const ViewshedGrid& grid, const HeightGrid& dem,
                                             const glm::dvec3& eyeEcef, double stepMeters) {
  const int n = grid.cells;
  std::vector<std::uint8_t> mask(static_cast<std::size_t>(n) * static_cast<std::size_t>(n),
                                 kViewshedOutside);
  if (!(stepMeters > 0.0)) {
    stepMeters = std::min(
        dem.geometry().lonSpacingDegrees / kDegrees * grid.planet.equatorialRadiusMeters() / 8.0,
        grid.cellMeters / 2.0);
  }
  const Planet& planet = grid.planet;
  tbb::parallel_for(tbb::blocked_range<int>(0, n), [&](const tbb::blocked_range<int>& rows) {
    for (int row = rows.begin(); row != rows.end(); ++row) {
      for (int col = 0; col < n; ++col) {
        if (!grid.inRadius(col, row)) continue;
        const GeodeticPosition at = grid.unproject(grid.cellCentreMeters(col, row));
        const auto ground = demHeight(dem, at.latDegrees, at.lonDegrees);
        if (!ground) continue;
        const glm::dvec3 target = planet.geodeticToEcef(at.latDegrees, at.lonDegrees, *ground);
        const glm::dvec3 d = target - eyeEcef;
        const double length = glm::length(d);
        // The sight line up to the target's own cell (half a cell before its centre).
        const double end = std::max(0.0, 1.0 - 0.5 * grid.cellMeters / length);
        const int samples = std::max(1, static_cast<int>(std::ceil(end * length / stepMeters)));
        std::uint8_t seen = kViewshedVisible;
        for (int s = 1; s <= samples && seen == kViewshedVisible; ++s) {
          const GeodeticPosition p = planet.ecefToGeodetic(eyeEcef + (end * s / samples) * d);
          const auto below = demHeight(dem, p.latDegrees, p.lonDegrees);
          if (below && p.heightMeters < *below) seen = kViewshedHidden;
        }
        mask[static_cast<std::size_t>(row) * static_cast<std::size_t>(n) +
             static_cast<std::size_t>(col)] = seen;
      }
    }
  });
  return mask;
}

ViewshedStats viewshedStats(const ViewshedGrid& grid, const std::vector<std::uint8_t>& mask) {
  ViewshedStats stats;
  int farCol = grid.half(), farRow = grid.half();
  for (int row = 0; row < grid.cells; ++row) {
    for (int col = 0; col < grid.cells; ++col) {
      const std::uint8_t m =
          mask[static_cast<std::size_t>(row) * static_cast<std::size_t>(grid.cells) +
               static_cast<std::size_t>(col)];
      if (m == kViewshedOutside) continue;
      ++stats.cellsInRadius;
      if (m != kViewshedVisible) continue;
      ++stats.visibleCells;
      stats.visibleAreaSquareMeters += grid.cellAreaSquareMeters(col, row);
      const double distance = glm::length(grid.cellCentreMeters(col, row));
      if (distance > stats.farthestVisibleMeters) {
        stats.farthestVisibleMeters = distance;
        farCol = col;
        farRow = row;
      }
    }
  }
  stats.farthestVisible = grid.unproject(grid.cellCentreMeters(farCol, farRow));
  return stats;
}

ViewshedAgreement compareViewsheds(const std::vector<std::uint8_t>& first,
                                   const std::vector<std::uint8_t>& second) {
  ViewshedAgreement a;
  const std::size_t n = std::min(first.size(), second.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (first[i] == kViewshedOutside || second[i] == kViewshedOutside) continue;
    ++a.compared;
    if (first[i] == second[i]) {
      ++a.agree;
      if (first[i] == kViewshedVisible) ++a.visibleInBoth;
    } else if (first[i] == kViewshedVisible) {
      ++a.visibleOnlyInFirst;
    } else {
      ++a.visibleOnlyInSecond;
    }
  }
  return a;
}

}  // namespace pbdam::runtime
