// Line of sight on the device (GpuSightline.h).
#include "pbdam/gpu/GpuSightline.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <string>

#include "ComputeProgram.h"
#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/CutMesh.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/runtime/SurfaceQuery.h"

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

const uint32_t kSightlineComp[] =
#include "sightline.comp.inc"
    ;

struct SegmentPush final {
  std::array<float, 4> direction;
  std::uint32_t triangles;
  float tMin;
  float tMax;
};

}  // namespace

Result<SightlineResult> testSightline(VulkanContext& context,
                                      const std::vector<glm::dvec3>& vertices,
                                      const std::vector<std::uint32_t>& indices,
                                      const glm::dvec3& from, const glm::dvec3& to,
                                      double endMeters) {
  const double length = glm::length(to - from);
  if (!(length > 0.0)) {
    return makeError(ErrorCode::InvalidArgument, "line of sight: the two points are the same");
  }
  for (const std::uint32_t i : indices) {
    if (i >= vertices.size()) {
      return makeError(ErrorCode::InvalidArgument, "line of sight: a vertex index out of range");
    }
  }
  SightlineResult result;
  const std::uint32_t triangles = static_cast<std::uint32_t>(indices.size() / 3);
  if (triangles == 0) return result;
  const auto hostBuffer = [&](std::uint64_t bytes, MemoryUse use, const char* name) {
    return createBuffer(context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, use, name);
  };
  auto vertexBuffer = hostBuffer(vertices.size() * 16, MemoryUse::HostUpload, "sightline vertices");
  if (!vertexBuffer) return std::move(vertexBuffer).error();
  auto indexBuffer =
      hostBuffer(std::uint64_t{triangles} * 12, MemoryUse::HostUpload, "sightline indices");
  if (!indexBuffer) return std::move(indexBuffer).error();
  auto resultBuffer = hostBuffer(8, MemoryUse::HostReadback, "sightline result");
  if (!resultBuffer) return std::move(resultBuffer).error();
  std::byte* v = vertexBuffer->mappedBytes().data();
  for (const glm::dvec3& x : vertices) {
    const glm::dvec3 relative = x - from;
    const std::array<float, 4> f = {static_cast<float>(relative.x), static_cast<float>(relative.y),
                                    static_cast<float>(relative.z), 0.0f};
    std::memcpy(v, f.data(), sizeof f);
    v += sizeof f;
  }
  std::memcpy(indexBuffer->mappedBytes().data(), indices.data(), std::size_t{triangles} * 12);
  const std::array<std::uint32_t, 2> start = {0, std::bit_cast<std::uint32_t>(2.0f)};
  std::memcpy(resultBuffer->mappedBytes().data(), start.data(), sizeof start);
  for (const GpuBuffer* b : {&*vertexBuffer, &*indexBuffer, &*resultBuffer}) {
    if (auto r = b->flushHostWrites(); !r) return std::move(r).error();
  }
  auto program =
      ComputeProgram::create(context, kSightlineComp, "sightline.comp",
                             {&*vertexBuffer, &*indexBuffer, &*resultBuffer}, sizeof(SegmentPush));
  if (!program) return std::move(program).error();
  const glm::dvec3 d = to - from;
  const SegmentPush push{
      {static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z), 0.0f},
      triangles,
      static_cast<float>(endMeters / length),
      static_cast<float>(1.0 - endMeters / length)};
  const Result<void> done = context.submitAndWait(
      [&](VkCommandBuffer cmd) {
        program->bind(cmd);
        program->push(cmd, std::as_bytes(std::span(&push, 1)));
        dispatchLinear(cmd, triangles, 64);
        computeBarrier(cmd, true);
      },
      "line of sight");
  if (!done) return done.error();
  if (auto r = resultBuffer->invalidateForHostRead(); !r) return std::move(r).error();
  std::array<std::uint32_t, 2> out{};
  std::memcpy(out.data(), resultBuffer->mappedBytes().data(), sizeof out);
  result.crossings = out[0];
  result.visible = out[0] == 0;
  if (!result.visible) result.nearestFraction = static_cast<double>(std::bit_cast<float>(out[1]));
  return result;
}

namespace {

Result<glm::dvec3> aboveGround(const runtime::DatasetView& view, const char* name,
                               const GroundPoint& p, double& ground) {
  const std::string which(name);
  if (!(std::fabs(p.latDegrees) <= 90.0) || !(std::fabs(p.lonDegrees) <= 360.0)) {
    return makeError(ErrorCode::InvalidArgument,
                     which + ": latitude must be in [-90, 90] and longitude in [-360, 360]");
  }
  if (!(p.heightAboveGroundMeters >= 0.0) || !std::isfinite(p.heightAboveGroundMeters)) {
    return makeError(ErrorCode::InvalidArgument,
                     which + ": the point is underground (height above ground < 0)");
  }
  auto h = runtime::surfaceHeightAt(view, p.latDegrees, p.lonDegrees);
  if (!h) return makeError(ErrorCode::InvalidArgument, which + ": " + h.error().message);
  ground = h->heightMeters;
  return view.planet().geodeticToEcef(p.latDegrees, p.lonDegrees,
                                      h->heightMeters + p.heightAboveGroundMeters);
}

}  // namespace

Result<TerrainSightline> sightlineOverTerrain(VulkanContext& context,
                                              const runtime::DatasetView& view,
                                              const GroundPoint& from, const GroundPoint& to) {
  TerrainSightline line;
  auto a = aboveGround(view, "--from", from, line.groundFromMeters);
  if (!a) return std::move(a).error();
  auto b = aboveGround(view, "--to", to, line.groundToMeters);
  if (!b) return std::move(b).error();
  line.from = *a;
  line.to = *b;
  if (!(glm::length(line.to - line.from) > 0.0)) {
    return makeError(ErrorCode::InvalidArgument, "--from and --to are the same point");
  }
  const runtime::Planet& planet = view.planet();
  const double leafLeg =
      view.latticeSpacingMeters() * static_cast<double>(view.manifest().leafCells);
  auto track = runtime::focusPath(
      planet, {{from.latDegrees, from.lonDegrees}, {to.latDegrees, to.lonDegrees}}, 2.0 * leafLeg,
      0.0);
  if (!track) return std::move(track).error();
  const runtime::Cut cut = runtime::selectFocus(view, {*track});
  auto mesh = runtime::cutMesh(view, cut);
  if (!mesh) return std::move(mesh).error();
  line.triangles = mesh->indices.size() / 3;
  auto result = testSightline(context, mesh->vertices, mesh->indices, line.from, line.to);
  if (!result) return std::move(result).error();
  line.result = *result;
  return line;
}

}  // namespace pbdam::gpu
