// A viewshed's grid and what it means (docs/architecture.md "Viewshed"): the cells of an
// azimuthal equidistant projection centred on the observer (distances and azimuths from the
// observer are true, so a ray from the observer is a straight line of cells and the radius a
// circle), row 0 north, the observer at the centre of the middle cell. A cell is visible when the
// segment from the observer's eye to the terrain point of its centre passes nowhere below the
// terrain. The device passes (gpu/GpuViewshed.h) decide it on the rendered leaf mesh; the ray
// march here decides it on a source DEM, brute force, to check them. Thread-safety: pure.
#pragma once

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <vector>

#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// What a user asks for. A radius or cell size left out takes the default (viewshedGrid).
struct ViewshedRequest final {
  double latDegrees = 0.0;               ///< of the observer
  double lonDegrees = 0.0;               ///< of the observer
  double heightAboveGroundMeters = 0.0;  ///< of the eye above the rendered terrain
  std::optional<double> radiusMeters;    ///< how far around the observer, along the surface
  std::optional<double> cellMeters;      ///< the side of a grid cell
};

/// The mask's cell values: hidden from the eye, visible, and outside (beyond the radius or
/// without terrain).
/// @{
inline constexpr std::uint8_t kViewshedHidden = 0;
inline constexpr std::uint8_t kViewshedVisible = 1;
inline constexpr std::uint8_t kViewshedOutside = 255;
/// @}

/// The most cells a side of the grid may have.
inline constexpr int kViewshedMaxCells = 4097;

/// The grid of a viewshed around an eye.
struct ViewshedGrid final {
  Planet planet = Planet::mars();  ///< the dataset's planet
  double latDegrees = 0.0;         ///< of the observer (the projection's centre)
  double lonDegrees = 0.0;         ///< of the observer
  double groundMeters = 0.0;       ///< the rendered terrain's height under the observer
  double eyeHeightMeters = 0.0;    ///< above the reference surface: ground + height above ground
  glm::dvec3 eyeEcef{0.0};         ///< the eye, planetocentric metres
  double radiusMeters = 0.0;       ///< the request's or the default (viewshedGrid)
  double cellMeters = 0.0;         ///< the side of a cell in the projection
  int cells = 1;                   ///< per side (odd)
  /// The horizon limit the radius was checked against (see viewshedGrid).
  double horizonLimitMeters = 0.0;

  /// The observer's cell's column and row: (cells − 1) / 2.
  int half() const noexcept { return (cells - 1) / 2; }
  /// East and north metres of a cell's centre in the projection.
  glm::dvec2 cellCentreMeters(int col, int row) const noexcept {
    return {(col - half()) * cellMeters, (half() - row) * cellMeters};
  }
  /// The projection of a geodetic latitude/longitude: east and north metres (the geodesic from
  /// the observer's length along its initial azimuth).
  glm::dvec2 project(double latDegrees, double lonDegrees) const noexcept;
  /// The latitude/longitude of a point of the projection (height 0).
  GeodeticPosition unproject(const glm::dvec2& eastNorthMeters) const noexcept;
  /// The true area of a cell (the projection stretches cells across the radial direction by
  /// ρ / (R sin(ρ / R)) on a sphere of the planet's radius).
  double cellAreaSquareMeters(int col, int row) const noexcept;
  /// True when the cell's centre lies within the radius.
  bool inRadius(int col, int row) const noexcept;
};

/// The grid of `request` over `view`'s terrain. Defaults: a cell of the leaf lattice's spacing
/// (a face's quarter meridian over its lattice cells), a radius of 256 cells or the horizon
/// limit if that is nearer. InvalidArgument naming the value for a latitude outside ±90°, a
/// longitude outside ±360°, a height above ground < 0, an observer outside the data, a radius
/// or cell size ≤ 0 or not finite, a radius beyond the horizon limit — the farthest the planet's
/// highest terrain could stand in view of the eye over the lowest sphere the terrain reaches —
/// and a grid of more than kViewshedMaxCells a side.
formats::Result<ViewshedGrid> viewshedGrid(const DatasetView& view, const ViewshedRequest& request);

/// The DEM's surface as the builder samples it (tools/builder SampleGrid): bicubic
/// (Catmull-Rom), bilinear where a bicubic neighbour is missing; nullopt outside the DEM.
std::optional<double> demHeight(const formats::HeightGrid& dem, double latDegrees,
                                double lonDegrees);

/// Brute force over a source DEM: for each cell in the radius, the segment from `eyeEcef` to the
/// DEM's ground (demHeight) at the cell's centre is marched at `stepMeters` (0: an eighth of the
/// DEM's spacing at the equator or half a cell, whichever is less: coarser steps step over
/// crests within a DEM cell); the cell is hidden when a sample of it up to half a cell before its
/// centre lies below the DEM's ground.
/// Cells outside the radius or the DEM are kViewshedOutside. Parallel over rows (TBB).
std::vector<std::uint8_t> viewshedByRayMarch(const ViewshedGrid& grid,
                                             const formats::HeightGrid& dem,
                                             const glm::dvec3& eyeEcef, double stepMeters = 0.0);

/// Figures of a mask over its grid.
struct ViewshedStats final {
  std::uint64_t cellsInRadius = 0;       ///< with terrain
  std::uint64_t visibleCells = 0;        ///< kViewshedVisible
  double visibleAreaSquareMeters = 0.0;  ///< true area of the visible cells
  double farthestVisibleMeters = 0.0;    ///< along the surface
  GeodeticPosition farthestVisible;      ///< height 0
};
/// The figures of `mask` (cells × cells, row 0 north) over `grid`.
ViewshedStats viewshedStats(const ViewshedGrid& grid, const std::vector<std::uint8_t>& mask);

/// How two masks of one grid agree over the cells both have in their radius.
struct ViewshedAgreement final {
  std::uint64_t compared = 0;             ///< cells both masks have in their radius
  std::uint64_t agree = 0;                ///< of those, cells both call visible or both hidden
  std::uint64_t visibleOnlyInFirst = 0;   ///< visible in the first mask, hidden in the second
  std::uint64_t visibleOnlyInSecond = 0;  ///< visible in the second mask, hidden in the first
  std::uint64_t visibleInBoth = 0;        ///< visible in both
  /// agree / compared (1 when nothing was compared).
  double fraction() const noexcept {
    return compared == 0 ? 1.0 : static_cast<double>(agree) / static_cast<double>(compared);
  }
  /// Of the cells either mask sees, the fraction both see (1 when neither sees any).
  double visibleFraction() const noexcept {
    const std::uint64_t either = visibleInBoth + visibleOnlyInFirst + visibleOnlyInSecond;
    return either == 0 ? 1.0 : static_cast<double>(visibleInBoth) / static_cast<double>(either);
  }
};
/// How `first` and `second`, two masks of one grid, agree.
ViewshedAgreement compareViewsheds(const std::vector<std::uint8_t>& first,
                                   const std::vector<std::uint8_t>& second);

}  // namespace pbdam::runtime
