// Opening a dataset's six faces against its manifest (DatasetView.h).
#include "pbdam/runtime/DatasetView.h"

#include <algorithm>
#include <numbers>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

Error mismatch(const std::string& context, const std::string& what) {
  return makeError(ErrorCode::CorruptData, context + ": " + what + " differs from manifest.json");
}

}  // namespace

Result<DatasetView> DatasetView::open(const Manifest& manifest,
                                      const std::array<std::span<const std::byte>, 6>& faceBytes,
                                      const std::string& directory,
                                      const FaceViewOptions& faceOptions) {
  auto planet = Planet::fromSpec(manifest.planetSpec);
  if (!planet) {
    return makeError(ErrorCode::CorruptData,
                     directory + "/manifest.json: planet: " + planet.error().message);
  }
  if (manifest.textureLevels == 0 || manifest.depth > kMaxBintreeDepth) {
    return makeError(ErrorCode::CorruptData,
                     directory + "/manifest.json: depth or texture levels out of range");
  }
  DatasetView view;
  view.manifest_ = manifest;
  view.planet_ = std::move(planet).value();
  view.textureErrorOfLevel_.assign(manifest.textureLevels, 0.0);
  for (int f = 0; f < 6; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    const std::string context = directory + "/" + manifest.faces[fi].file;
    if (faceBytes[fi].size() != manifest.faces[fi].bytes) {
      const bool shorter = faceBytes[fi].size() < manifest.faces[fi].bytes;
      return makeError(ErrorCode::CorruptData,
                       context + ": " + (shorter ? "truncated" : "extended") + " at offset " +
                           std::to_string(faceBytes[fi].size()) + " (" +
                           std::to_string(faceBytes[fi].size()) + " bytes, manifest.json says " +
                           std::to_string(manifest.faces[fi].bytes) + ")");
    }
    auto face = FaceView::open(faceBytes[fi], context, faceOptions);
    if (!face) return std::move(face).error();
    const FaceHeader& h = face->header();
    if (h.face != fi) return mismatch(context, "face index");
    if (h.latticeCells != manifest.latticeCells) return mismatch(context, "lattice_cells");
    if (h.leafCells != manifest.leafCells) return mismatch(context, "leaf_cells");
    if (h.depth != manifest.depth) return mismatch(context, "depth");
    if (h.textureLevels != manifest.textureLevels) return mismatch(context, "texture levels");
    if (h.textureTileTexels != manifest.textureTileTexels ||
        h.textureBorderTexels != manifest.textureBorderTexels) {
      return mismatch(context, "texture tile size");
    }
    for (std::uint64_t k = 0; k < h.nodeCount; ++k) {
      const NodeRecord n = face->nodeAt(k);
      view.maxPatchVertices_ = std::max(view.maxPatchVertices_, n.vertexCount);
      view.maxPatchTriangles_ = std::max(view.maxPatchTriangles_, n.triangleCount);
    }
    for (std::uint64_t k = 0; k < h.textureNodeCount; ++k) {
      const TextureRecord r = face->textureAt(k);
      double& e = view.textureErrorOfLevel_[textureLevelOfHeap(r.heapIndex)];
      e = std::max(e, static_cast<double>(r.errorMeters));
    }
    if (auto damage = face->damage()) return std::move(*damage);
    view.faces_[fi] = std::move(face).value();
  }
  const auto depth = static_cast<int>(manifest.depth);
  view.textureTerm_.assign(static_cast<std::size_t>(depth) + 1, 0.0);
  for (int level = depth; level >= 0; --level) {
    const std::uint32_t t = view.textureLevelOf(level);
    double term = t + 1 < manifest.textureLevels ? view.textureErrorOfLevel_[t] : 0.0;
    if (level < depth) {
      term = std::max(term, (1.0 + manifest.errorMargin) *
                                view.textureTerm_[static_cast<std::size_t>(level) + 1]);
    }
    view.textureTerm_[static_cast<std::size_t>(level)] = term;
  }
  return view;
}

std::optional<formats::Error> DatasetView::damage() const {
  for (const FaceView& face : faces_) {
    if (auto damage = face.damage()) return damage;
  }
  return std::nullopt;
}

std::uint64_t DatasetView::nodeChunkReads() const noexcept {
  std::uint64_t reads = 0;
  for (const FaceView& face : faces_) reads += face.nodeChunkReads();
  return reads;
}

std::uint32_t DatasetView::textureLevelOf(int level) const noexcept {
  return std::min(static_cast<std::uint32_t>(level / 2), manifest_.textureLevels - 1);
}

TileKey DatasetView::tileOf(const NodeKey& key) const noexcept {
  const BinTriangle t = triangle(key);
  const std::int32_t minX = std::min({t.apex.x, t.left.x, t.right.x});
  const std::int32_t minY = std::min({t.apex.y, t.left.y, t.right.y});
  const formats::FaceView& face = faces_[key.face];
  for (auto tl = static_cast<std::int32_t>(textureLevelOf(t.level));; --tl) {
    const auto side = static_cast<std::int32_t>(manifest_.latticeCells >> tl);
    const std::uint64_t heap =
        textureHeapIndex(static_cast<std::uint32_t>(tl), static_cast<std::uint32_t>(minX / side),
                         static_cast<std::uint32_t>(minY / side));
    // The root tile always exists (FaceView::open).
    if (tl == 0 || face.findTexture(heap)) return TileKey{key.face, heap};
  }
}

double DatasetView::latticeSpacingMeters() const noexcept {
  return std::numbers::pi / 2.0 * planet().equatorialRadiusMeters() /
         static_cast<double>(latticeCells());
}

}  // namespace pbdam::runtime
