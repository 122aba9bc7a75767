// A viewshed on the device (`pbdam query viewshed`, `/viewshed`): the cut with leaves over the
// viewshed's disc (runtime/Selection.h) is meshed, projected on the host into the grid of
// runtime/Viewshed.h, and three compute passes in one submission decide every cell: the mesh is
// rasterised into the grid (viewshed_raster.comp), rays from the observer record the horizon at
// every step (viewshed_horizon.comp), and each cell is compared with the horizon in front of it
// (viewshed_visible.comp). Thread-safety: none; the context must outlive the call.
#pragma once

#include <cstdint>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/CutMesh.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Viewshed.h"

namespace pbdam::gpu {

class VulkanContext;

/// What the passes took.
struct ViewshedPassStats final {
  std::uint64_t triangles = 0;       ///< rasterised (those near the disc)
  std::uint32_t rays = 0;            ///< rays cast from the observer
  double projectMilliseconds = 0.0;  ///< the mesh into the grid, on the host
  double deviceMilliseconds = 0.0;   ///< buffers, the three passes, readback
};

/// A viewshed and what it took.
struct TerrainViewshed final {
  runtime::ViewshedGrid grid;  ///< the grid the mask covers
  /// cells × cells, row 0 north: runtime::kViewshedVisible, kViewshedHidden or kViewshedOutside.
  std::vector<std::uint8_t> mask;
  runtime::ViewshedStats stats;      ///< the mask's figures
  std::uint64_t patches = 0;         ///< of the cut
  ViewshedPassStats passes;          ///< what the passes took
  double extractMilliseconds = 0.0;  ///< selection and decoding
  double totalMilliseconds = 0.0;    ///< the whole call
};

/// The three passes over `mesh` (the viewshed's grid around `grid.eyeEcef`). Triangles with a
/// vertex farther than a quarter of the planet's circumference from the observer are left out
/// (the projection folds there). DeviceError for Vulkan failures, Unsupported without double
/// arithmetic in shaders.
formats::Result<std::vector<std::uint8_t>> computeViewshed(VulkanContext& context,
                                                           const runtime::ViewshedGrid& grid,
                                                           const runtime::CutMesh& mesh,
                                                           ViewshedPassStats* stats = nullptr);

/// The viewshed of `request` over `view`'s rendered leaves; the errors of runtime::viewshedGrid
/// for a bad request.
formats::Result<TerrainViewshed> viewshedOverTerrain(VulkanContext& context,
                                                     const runtime::DatasetView& view,
                                                     const runtime::ViewshedRequest& request);
/// The same for a grid already made by runtime::viewshedGrid (a caller that checked it first).
formats::Result<TerrainViewshed> viewshedOverTerrain(VulkanContext& context,
                                                     const runtime::DatasetView& view,
                                                     const runtime::ViewshedGrid& grid);

}  // namespace pbdam::gpu
