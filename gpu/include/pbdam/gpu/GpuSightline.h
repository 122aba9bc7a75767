// Line of sight on the device: whether the segment between two points crosses a triangle mesh
// (a cut's mesh, `pbdam query los`), one compute invocation per triangle (sightline.comp). The
// vertices are taken relative to the observer in double and rounded to float there, so the
// rounding scales with the distance to the observer, not the planet. Thread-safety: none; the
// context must outlive it.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::gpu {

class VulkanContext;

/// Whether a segment is clear of a mesh, and where it first crosses it.
struct SightlineResult final {
  bool visible = true;           ///< no triangle crosses the segment
  std::uint64_t crossings = 0;   ///< triangles the segment crosses
  double nearestFraction = 1.0;  ///< of the segment, to the first crossing (1 when visible)
};

/// Tests the segment `from`–`to` (planetocentric metres) against the triangles `indices` (three
/// a triangle) of `vertices`. Crossings within `endMeters` of either end are ignored (an
/// observer standing on the ground). InvalidArgument for an index out of range or a segment of
/// length 0; DeviceError for Vulkan failures.
formats::Result<SightlineResult> testSightline(VulkanContext& context,
                                               const std::vector<glm::dvec3>& vertices,
                                               const std::vector<std::uint32_t>& indices,
                                               const glm::dvec3& from, const glm::dvec3& to,
                                               double endMeters = 1.0);

/// A point `heightAboveGroundMeters` above the rendered terrain at (lat, lon).
struct GroundPoint final {
  double latDegrees = 0.0;               ///< latitude
  double lonDegrees = 0.0;               ///< longitude
  double heightAboveGroundMeters = 0.0;  ///< above the rendered terrain
};

/// The line of sight between two points above a dataset's terrain.
struct TerrainSightline final {
  SightlineResult result;  ///< the test of the segment from–to
  glm::dvec3 from{0.0};    ///< planetocentric metres
  glm::dvec3 to{0.0};      ///< planetocentric metres
  /// The rendered terrain's height under each point.
  /// @{
  double groundFromMeters = 0.0;
  double groundToMeters = 0.0;
  /// @}
  std::uint64_t triangles = 0;  ///< of the mesh tested
};

/// testSightline against the mesh of the cut with leaves along the segment's ground track (two
/// leaf legs wide, closed upward; runtime/Selection.h) and coarse patches elsewhere.
/// InvalidArgument naming the point for a latitude outside ±90°, a longitude outside ±360°, a
/// point underground (height above ground < 0) or outside the data, or two equal points.
formats::Result<TerrainSightline> sightlineOverTerrain(VulkanContext& context,
                                                       const runtime::DatasetView& view,
                                                       const GroundPoint& from,
                                                       const GroundPoint& to);

}  // namespace pbdam::gpu
