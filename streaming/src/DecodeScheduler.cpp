// Parallel decoding of a pass's missing patches and tiles into caller-provided memory
// (DecodeScheduler.h; docs/architecture.md "Streaming").
#include "pbdam/streaming/DecodeScheduler.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstring>
#include <string>
#include <vector>

#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {
namespace {

std::string blobContext(const FaceView& face, std::uint64_t offset) {
  return face.context() + "@" + std::to_string(offset);
}

std::uint64_t alignUp(std::uint64_t value, std::uint64_t alignment) {
  return (value + alignment - 1) / alignment * alignment;
}

TexelFormat datasetNormalTexels(const DatasetView& dataset) noexcept {
  return dataset.manifest().textureNormalFormat == "bc5" ? TexelFormat::Bc5 : TexelFormat::Rg8;
}

}  // namespace

DecodeScheduler::DecodeScheduler(const DatasetView& dataset, TexelFormat tileTexels,
                                 double exaggeration) noexcept
    : dataset_(&dataset),
      tileTexels_(tileTexels),
      exaggeration_(exaggeration),
      normalOffset_(normalTileOffset(dataset, tileTexels)),
      tileBytes_(normalOffset_ + textureTileDataBytes(dataset.manifest().normalTileTexels(),
                                                      normalTexels(tileTexels))) {}

std::uint64_t DecodeScheduler::normalTileOffset(const DatasetView& dataset,
                                                TexelFormat tileTexels) noexcept {
  return alignUp(textureTileDataBytes(dataset.manifest().textureTileTexels, tileTexels),
                 kAlignment);
}

TexelFormat DecodeScheduler::datasetTexels(const DatasetView& dataset) noexcept {
  return dataset.manifest().textureFormat == "bc1" ? TexelFormat::Bc1 : TexelFormat::Rgba8;
}

std::uint64_t DecodeScheduler::layout(std::span<DecodeJob> jobs) const {
  std::uint64_t total = 0;
  for (DecodeJob& job : jobs) {
    job.offset = alignUp(total, kAlignment);
    if (job.key.kind() == ResidentKind::Patch) {
      const NodeRecord n = dataset_->node(job.node);
      job.vertexBytes = std::uint64_t{sizeof(PatchGpuVertex)} * n.vertexCount;
      job.bytes = job.vertexBytes + std::uint64_t{6} * n.triangleCount;
    } else {
      job.vertexBytes = 0;
      job.bytes = tileBytes_;
    }
    total = job.offset + job.bytes;
  }
  return total;
}

Result<void> DecodeScheduler::decode(std::span<const DecodeJob> jobs,
                                     std::span<std::byte> out) const {
  std::vector<Error> errors(jobs.size());
  std::vector<char> failed(jobs.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, jobs.size()),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t j = range.begin(); j != range.end(); ++j) {
                        const DecodeJob& job = jobs[j];
                        const std::span<std::byte> dst = out.subspan(job.offset, job.bytes);
                        Result<void> r = job.key.kind() == ResidentKind::Patch
                                             ? decodePatch(job.node, dst)
                                             : decodeTile(job.tile, dst);
                        if (!r) {
                          errors[j] = std::move(r).error();
                          failed[j] = 1;
                        }
                      }
                    });
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    if (failed[j] != 0) return std::move(errors[j]);
  }
  return {};
}

Result<void> DecodeScheduler::decodePatch(const NodeKey& key, std::span<std::byte> out) const {
  thread_local PatchMesh mesh;
  const FaceView& face = dataset_->face(key.face);
  const NodeRecord record = dataset_->node(key);
  const std::string context = blobContext(face, record.blobOffset);
  thread_local std::vector<std::byte> blob;  // the blobs copied out of the mapping, guarded
  thread_local std::vector<std::int32_t> targets;
  auto bytes = face.readPatchBlobs(record, blob);
  if (!bytes) return std::move(bytes).error();
  if (Result<void> r = pbdam::formats::decodePatch(bytes->patch, mesh, context); !r) {
    return std::move(r).error();
  }
  if (Result<void> r = decodeMorphTargets(bytes->morph, mesh, targets, context); !r) {
    return std::move(r).error();
  }
  if (mesh.vertices.size() != record.vertexCount || mesh.triangleCount() != record.triangleCount) {
    return makeError(ErrorCode::CorruptData,
                     context + ": patch has " + std::to_string(mesh.vertices.size()) +
                         " vertices and " + std::to_string(mesh.triangleCount()) +
                         " triangles, its node record says " + std::to_string(record.vertexCount) +
                         " and " + std::to_string(record.triangleCount));
  }
  const runtime::PatchVertexPlacement placement(*dataset_, key, record, exaggeration_);
  std::byte* dst = out.data();
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const PatchVertex& pv = mesh.vertices[v];
    PatchVertexDisplacement d;
    if (!placement.displacement(pv, d)) {
      return makeError(ErrorCode::CorruptData,
                       context + ": patch vertex " + std::to_string(v) + " (b1 " +
                           std::to_string(pv.b1) + ", b2 " + std::to_string(pv.b2) +
                           ") is not a lattice point of its node's triangle");
    }
    // The target's displacement over the same base (so that both patches on an edge get the
    // same float); most vertices are their coarser surface's too.
    float target = d.heightMeters;
    if (targets[v] != pv.heightSteps) {
      PatchVertexDisplacement t;
      (void)placement.displacement(PatchVertex{pv.b1, pv.b2, targets[v]}, t);
      target = t.heightMeters;
    }
    const glm::vec3& o = d.offsetMeters;
    const PatchGpuVertex gpu{pv.b1, pv.b2, d.heightMeters, target, {o.x, o.y, o.z}};
    std::memcpy(dst, &gpu, sizeof gpu);
    dst += sizeof gpu;
  }
  std::memcpy(dst, mesh.indices.data(), mesh.indices.size() * sizeof(std::uint16_t));
  return {};
}

Result<void> DecodeScheduler::decodeTile(const TileKey& key, std::span<std::byte> out) const {
  const FaceView& face = dataset_->face(key.face);
  const TextureRecord record = dataset_->textureNode(key);
  const std::string context = blobContext(face, record.blobOffset);
  thread_local std::vector<std::byte> blob;  // the blobs copied out of the mapping, guarded
  auto bytes = face.readTextureBlobs(record, blob);
  if (!bytes) return std::move(bytes).error();
  Result<TextureTileImage> tile = decodeTextureTile(bytes->colour, context);
  if (!tile) return std::move(tile).error();
  const Manifest& m = dataset_->manifest();
  if (tile->sizeTexels != m.textureTileTexels || tile->borderTexels != m.textureBorderTexels ||
      tile->format != datasetTexels(*dataset_)) {
    return makeError(ErrorCode::CorruptData,
                     context + ": tile of " + std::to_string(tile->sizeTexels) +
                         " texels (border " + std::to_string(tile->borderTexels) +
                         ") does not match manifest.json (" + std::to_string(m.textureTileTexels) +
                         ", border " + std::to_string(m.textureBorderTexels) + ", " +
                         m.textureFormat + ")");
  }
  if (tile->format != tileTexels_) {
    tile = expandToRgba8(*tile);
    if (!tile) return makeError(ErrorCode::CorruptData, context + ": " + tile.error().message);
  }
  if (tile->data.size() > normalOffset_ || out.size() != tileBytes_) {
    return makeError(ErrorCode::Internal, context + ": tile data size differs from its slot");
  }
  std::memcpy(out.data(), tile->data.data(), tile->data.size());

  // The normal map, stored right after the colour tile.
  const std::string normalContext = blobContext(face, record.blobOffset + record.blobBytes);
  Result<TextureTileImage> normals = decodeTextureTile(bytes->normal, normalContext);
  if (!normals) return std::move(normals).error();
  if (normals->sizeTexels != m.normalTileTexels() ||
      normals->borderTexels != m.normalBorderTexels() ||
      normals->format != datasetNormalTexels(*dataset_)) {
    return makeError(ErrorCode::CorruptData,
                     normalContext + ": normal-map tile of " + std::to_string(normals->sizeTexels) +
                         " texels (border " + std::to_string(normals->borderTexels) +
                         ") does not match manifest.json (" + std::to_string(m.normalTileTexels()) +
                         ", border " + std::to_string(m.normalBorderTexels()) + ", " +
                         m.textureNormalFormat + ")");
  }
  if (normals->format != normalTexels(tileTexels_)) {
    normals = expandToRg8(*normals);
    if (!normals) {
      return makeError(ErrorCode::CorruptData, normalContext + ": " + normals.error().message);
    }
  }
  if (normals->data.size() != tileBytes_ - normalOffset_) {
    return makeError(ErrorCode::Internal,
                     normalContext + ": normal-map data size differs from its slot");
  }
  std::memcpy(out.data() + normalOffset_, normals->data.data(), normals->data.size());
  return {};
}

}  // namespace pbdam::streaming
