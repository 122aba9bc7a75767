// A viewshed on the device (GpuViewshed.h).
#include "pbdam/gpu/GpuViewshed.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "ComputeProgram.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Selection.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

const uint32_t kRasterComp[] =
#include "viewshed_raster.comp.inc"
    ;
const uint32_t kHorizonComp[] =
#include "viewshed_horizon.comp.inc"
    ;
const uint32_t kVisibleComp[] =
#include "viewshed_visible.comp.inc"
    ;

/// The terrain is rasterised at this many cells a side of the mask's cell: bilinear blends of
/// the raster lower the creases between its points by up to a quarter of its cell times the
/// change of slope, and that lets the mask see over crests (at 2 the disagreement with the ray
/// march on the DEM's own surface halves against 1).
constexpr int kSupersample = 2;
/// Vertices are snapped to this fraction of a raster cell, so that the raster's edge functions
/// are exact.
constexpr double kSubcells = 256.0;
/// Samples along a ray, in mask cells.
constexpr float kStepCells = 0.5f;
/// The horizon in front of a cell ends this far before it: nearer samples blend the cell's own
/// point into the terrain that would hide it (a margin of 0.5 agreed best with the ray march on
/// the DEM's own surface; 1 lets the crest's back slope see over it, 0 hides cells by their own
/// rounding).
constexpr float kMarginCells = 0.5f;
/// The largest horizon table; rays are spaced wider at the rim to stay under it.
constexpr std::uint64_t kMaxHorizonBytes = std::uint64_t{256} << 20;

struct RasterVertex final {
  std::array<float, 4> grid;
  std::array<float, 4> enu;
};

struct RasterPush final {
  std::uint32_t triangles;
  std::uint32_t cells;
  float centre;
  float radiusCells;
};

struct MarchPush final {
  std::uint32_t cells;
  std::uint32_t rays;
  std::uint32_t steps;
  float stepCells;
  float centre;
};

struct VisiblePush final {
  std::uint32_t cells;
  std::uint32_t fineCells;
  std::uint32_t rays;
  std::uint32_t steps;
  float stepCells;
  float centre;
  float radiusCells;
  float marginCells;
  float scale;
};

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// The raster's cells (kSupersample a side of the mask's), in which the passes work.
struct RasterFrame final {
  double fineMeters = 0.0;
  double centre = 0.0;  ///< the observer, in raster cells from the corner
  double radiusCells = 0.0;
};

RasterFrame rasterFrame(const ViewshedGrid& grid) {
  const double fineMeters = grid.cellMeters / kSupersample;
  return {fineMeters, (grid.half() + 0.5) * kSupersample, grid.radiusMeters / fineMeters};
}

/// A planetocentric point's place in the projection (east and north metres). On a sphere in
/// closed form — the great-circle distance and the azimuth of the point's direction seen from
/// the observer's — which is what the geodesic gives there, at a tenth of the cost; on an
/// ellipsoid through the geodesic.
glm::dvec2 projectVertex(const ViewshedGrid& grid, const EnuFrame& observer,
                         const glm::dvec3& ecef) {
  if (!grid.planet.isSphere()) {
    const GeodeticPosition g = grid.planet.ecefToGeodetic(ecef);
    return grid.project(g.latDegrees, g.lonDegrees);
  }
  const glm::dvec3 up = observer.axes[2];
  const glm::dvec3 direction = glm::normalize(ecef);
  const double along = glm::dot(direction, up);
  const glm::dvec3 tangent = direction - along * up;
  const double across = glm::length(tangent);
  if (across == 0.0) return glm::dvec2(0.0);
  const double distance = grid.planet.equatorialRadiusMeters() * std::atan2(across, along);
  return distance / across *
         glm::dvec2(glm::dot(tangent, observer.axes[0]), glm::dot(tangent, observer.axes[1]));
}

/// The mesh in raster cells (snapped) and the eye's east-north-up metres, and its triangles
/// whose box meets the disc's, none with a vertex where the projection folds (beyond a quarter
/// meridian of the observer).
struct ProjectedMesh final {
  std::vector<RasterVertex> vertices;
  std::vector<std::uint32_t> indices;
};

ProjectedMesh projectMesh(const ViewshedGrid& grid, const CutMesh& mesh) {
  const Planet& planet = grid.planet;
  const EnuFrame eye = planet.enuFrame(grid.latDegrees, grid.lonDegrees, grid.eyeHeightMeters);
  const RasterFrame frame = rasterFrame(grid);
  const double fineMeters = frame.fineMeters;
  const double centre = frame.centre;
  const double radiusCells = frame.radiusCells;
  const double fold = std::numbers::pi / 2.0 * planet.polarRadiusMeters();
  ProjectedMesh out;
  std::vector<RasterVertex>& vertices = out.vertices;
  vertices.resize(mesh.vertices.size());
  std::vector<std::uint8_t> near(mesh.vertices.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertices.size(), 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const glm::dvec2 en = projectVertex(grid, eye, mesh.vertices[i]);
                        const double distance = glm::length(en);
                        const double u = centre + en.x / fineMeters;
                        const double v = centre - en.y / fineMeters;
                        const glm::dvec3 enu = eye.ecefToEnu(mesh.vertices[i]);
                        vertices[i] = {
                            {static_cast<float>(std::round(u * kSubcells) / kSubcells),
                             static_cast<float>(std::round(v * kSubcells) / kSubcells), 0.0f, 0.0f},
                            {static_cast<float>(enu.x), static_cast<float>(enu.y),
                             static_cast<float>(enu.z), 0.0f}};
                        near[i] = distance < fold ? 1 : 0;
                      }
                    });
  // Triangles whose box meets the disc's, none with a vertex where the projection folds.
  const double lo = centre - radiusCells - 1.0;
  const double hi = centre + radiusCells + 1.0;
  std::vector<std::uint32_t>& indices = out.indices;
  indices.reserve(mesh.indices.size());
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    double minU = std::numeric_limits<double>::infinity(), maxU = -minU, minV = minU, maxV = -minU;
    bool folded = false;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t i = mesh.indices[t + static_cast<std::size_t>(k)];
      folded = folded || near[i] == 0;
      minU = std::min(minU, static_cast<double>(vertices[i].grid[0]));
      maxU = std::max(maxU, static_cast<double>(vertices[i].grid[0]));
      minV = std::min(minV, static_cast<double>(vertices[i].grid[1]));
      maxV = std::max(maxV, static_cast<double>(vertices[i].grid[1]));
    }
    if (folded || maxU < lo || minU > hi || maxV < lo || minV > hi) continue;
    indices.insert(indices.end(), mesh.indices.begin() + static_cast<std::ptrdiff_t>(t),
                   mesh.indices.begin() + static_cast<std::ptrdiff_t>(t + 3));
  }
  return out;
}

}  // namespace

Result<std::vector<std::uint8_t>> computeViewshed(VulkanContext& context, const ViewshedGrid& grid,
                                                  const CutMesh& mesh, ViewshedPassStats* stats) {
  if (!context.caps().shaderFloat64) {
    return makeError(ErrorCode::InvalidArgument,
                     "the viewshed needs 64-bit floats in shaders; the device has none");
  }
  const auto projectStart = std::chrono::steady_clock::now();
  const ProjectedMesh projected = projectMesh(grid, mesh);
  const std::vector<RasterVertex>& vertices = projected.vertices;
  const std::vector<std::uint32_t>& indices = projected.indices;
  const RasterFrame frame = rasterFrame(grid);
  const double centre = frame.centre;
  const double radiusCells = frame.radiusCells;
  const double projectMs = millisecondsSince(projectStart);

  const auto deviceStart = std::chrono::steady_clock::now();
  const std::uint32_t cells = static_cast<std::uint32_t>(grid.cells);
  const std::uint64_t cellCount = std::uint64_t{cells} * cells;
  const std::uint32_t fineCells = cells * kSupersample;
  const float step = kStepCells * kSupersample;
  const std::uint32_t triangles = static_cast<std::uint32_t>(indices.size() / 3);
  const std::uint32_t steps =
      static_cast<std::uint32_t>(std::ceil(radiusCells / static_cast<double>(step))) + 1;
  std::uint64_t rays = std::max<std::uint64_t>(
      8, static_cast<std::uint64_t>(
             std::ceil(2.0 * std::numbers::pi * radiusCells / static_cast<double>(step))));
  rays = std::max<std::uint64_t>(8, std::min(rays, kMaxHorizonBytes / (std::uint64_t{steps} * 4)));
  const auto buffer = [&](std::uint64_t bytes, MemoryUse use, VkBufferUsageFlags extra,
                          const char* name) {
    return createBuffer(context, std::max<std::uint64_t>(bytes, 16),
                        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | extra, use, name);
  };
  auto vertexBuffer =
      buffer(vertices.size() * sizeof(RasterVertex), MemoryUse::HostUpload, 0, "viewshed vertices");
  if (!vertexBuffer) return std::move(vertexBuffer).error();
  auto indexBuffer =
      buffer(indices.size() * sizeof(std::uint32_t), MemoryUse::HostUpload, 0, "viewshed indices");
  if (!indexBuffer) return std::move(indexBuffer).error();
  auto surface = buffer(std::uint64_t{fineCells} * fineCells * 16, MemoryUse::DeviceLocal,
                        VK_BUFFER_USAGE_TRANSFER_DST_BIT, "viewshed surface");
  if (!surface) return std::move(surface).error();
  auto horizons = buffer(rays * steps * 4, MemoryUse::DeviceLocal, 0, "viewshed horizons");
  if (!horizons) return std::move(horizons).error();
  auto maskBuffer = buffer(cellCount * 4, MemoryUse::HostReadback, 0, "viewshed mask");
  if (!maskBuffer) return std::move(maskBuffer).error();
  if (!vertices.empty()) {
    std::memcpy(vertexBuffer->mappedBytes().data(), vertices.data(),
                vertices.size() * sizeof(RasterVertex));
  }
  if (!indices.empty()) {
    std::memcpy(indexBuffer->mappedBytes().data(), indices.data(),
                indices.size() * sizeof(std::uint32_t));
  }
  for (const GpuBuffer* b : {&*vertexBuffer, &*indexBuffer}) {
    if (auto r = b->flushHostWrites(); !r) return std::move(r).error();
  }
  auto raster =
      ComputeProgram::create(context, kRasterComp, "viewshed_raster.comp",
                             {&*vertexBuffer, &*indexBuffer, &*surface}, sizeof(RasterPush));
  if (!raster) return std::move(raster).error();
  auto march = ComputeProgram::create(context, kHorizonComp, "viewshed_horizon.comp",
                                      {&*surface, &*horizons}, sizeof(MarchPush));
  if (!march) return std::move(march).error();
  auto visible = ComputeProgram::create(context, kVisibleComp, "viewshed_visible.comp",
                                        {&*surface, &*horizons, &*maskBuffer}, sizeof(VisiblePush));
  if (!visible) return std::move(visible).error();
  const float centreF = static_cast<float>(centre);
  const float radiusF = static_cast<float>(radiusCells);
  const RasterPush rasterPush{triangles, fineCells, centreF, radiusF};
  const MarchPush marchPush{fineCells, static_cast<std::uint32_t>(rays), steps, step, centreF};
  const VisiblePush visiblePush{cells,
                                fineCells,
                                static_cast<std::uint32_t>(rays),
                                steps,
                                step,
                                centreF,
                                radiusF,
                                kMarginCells * kSupersample,
                                static_cast<float>(kSupersample)};
  const Result<void> done = context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        vkCmdFillBuffer(cmd, surface->buffer(), 0, VK_WHOLE_SIZE, 0);
        transferToComputeBarrier(cmd);
        raster->bind(cmd);
        raster->push(cmd, std::as_bytes(std::span(&rasterPush, 1)));
        dispatchLinear(cmd, triangles, 64);
        computeBarrier(cmd);
        march->bind(cmd);
        march->push(cmd, std::as_bytes(std::span(&marchPush, 1)));
        dispatchLinear(cmd, rays, 64);
        computeBarrier(cmd);
        visible->bind(cmd);
        visible->push(cmd, std::as_bytes(std::span(&visiblePush, 1)));
        vkCmdDispatch(cmd, (cells + 7) / 8, (cells + 7) / 8, 1);
        computeBarrier(cmd, true);
      },
      "viewshed");
  if (!done) return done.error();
  if (auto r = maskBuffer->invalidateForHostRead(); !r) return std::move(r).error();
  std::vector<std::uint8_t> mask(cellCount);
  const std::byte* words = maskBuffer->mappedBytes().data();
  for (std::uint64_t i = 0; i < cellCount; ++i) {
    std::uint32_t m = 0;
    std::memcpy(&m, words + i * 4, 4);
    mask[i] = static_cast<std::uint8_t>(m);
  }
  if (stats != nullptr) {
    stats->triangles = triangles;
    stats->rays = static_cast<std::uint32_t>(rays);
    stats->projectMilliseconds = projectMs;
    stats->deviceMilliseconds = millisecondsSince(deviceStart);
  }
  return mask;
}

Result<TerrainViewshed> viewshedOverTerrain(VulkanContext& context, const DatasetView& view,
                                            const ViewshedRequest& request) {
  auto grid = viewshedGrid(view, request);
  if (!grid) return std::move(grid).error();
  return viewshedOverTerrain(context, view, *grid);
}

Result<TerrainViewshed> viewshedOverTerrain(VulkanContext& context, const DatasetView& view,
                                            const ViewshedGrid& grid) {
  const auto start = std::chrono::steady_clock::now();
  TerrainViewshed out;
  out.grid = grid;
  // Leaves over the disc and two leaf legs around it (closed upward), coarse elsewhere.
  const double leafLeg =
      view.latticeSpacingMeters() * static_cast<double>(view.manifest().leafCells);
  auto disc = focusCircle(view.planet(), grid.latDegrees, grid.lonDegrees,
                          grid.radiusMeters + 2.0 * leafLeg, 0.0);
  if (!disc) return std::move(disc).error();
  const Cut cut = selectFocus(view, {*disc});
  auto mesh = cutMesh(view, cut);
  if (!mesh) return std::move(mesh).error();
  out.patches = cut.patches.size();
  out.extractMilliseconds = millisecondsSince(start);
  auto mask = computeViewshed(context, grid, *mesh, &out.passes);
  if (!mask) return std::move(mask).error();
  out.mask = std::move(*mask);
  out.stats = viewshedStats(out.grid, out.mask);
  out.totalMilliseconds = millisecondsSince(start);
  return out;
}

}  // namespace pbdam::gpu
