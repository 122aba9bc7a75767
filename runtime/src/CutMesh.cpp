// The mesh of a cut (CutMesh.h).
#include "pbdam/runtime/CutMesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;

namespace pbdam::runtime {

namespace {

/// One patch decoded and placed: its vertices' lattice points and terrain points, its triangles.
struct PlacedPatch final {
  std::vector<PointKey> keys;
  std::vector<glm::dvec3> points;
  std::vector<std::uint16_t> indices;
  std::optional<Error> error;
};

void placePatch(const DatasetView& view, const CutPatch& p, std::vector<std::byte>& blob,
                PatchMesh& patch, PlacedPatch& out) {
  const NodeRecord record = view.node(p.node);
  if (record.blobBytes == 0) return;
  const formats::FaceView& face = view.face(p.node.face);
  auto bytes = face.readPatchBlob(record, blob);
  if (!bytes) {
    out.error = std::move(bytes).error();
    return;
  }
  if (auto r = decodePatch(*bytes, patch, face.context() + "@" + std::to_string(record.blobOffset));
      !r) {
    out.error = std::move(r).error();
    return;
  }
  const PatchVertexPlacement placement(view, p.node, record);
  out.keys.resize(patch.vertices.size());
  out.points.resize(patch.vertices.size());
  for (std::size_t v = 0; v < patch.vertices.size(); ++v) {
    LatticeXY q{0};
    if (!placement.latticePoint(patch.vertices[v].b1, patch.vertices[v].b2, q)) {
      out.error = makeError(ErrorCode::CorruptData,
                            face.context() + "@" + std::to_string(record.blobOffset) +
                                ": a patch vertex is not a lattice point of its node");
      return;
    }
    out.keys[v] = latticePointKey(view.latticeCells(), p.node.face, q);
    out.points[v] = placement.terrainPoint(q, patch.vertices[v].heightSteps);
  }
  out.indices = patch.indices;
}

/// Lattice point → mesh vertex: open addressing with linear probing, sized for the keys it will
/// hold (a node-based map spent most of a large cut's meshing time allocating and rehashing).
class PointIndex final {
 public:
  explicit PointIndex(std::size_t expected) {
    std::size_t capacity = 16;
    while (capacity < 2 * expected) capacity <<= 1;
    slots_.assign(capacity, Slot{});
    mask_ = capacity - 1;
  }
  /// The vertex of `key`: the one it has, or `next` (and true) when it is new.
  std::pair<std::uint32_t, bool> insert(PointKey key, std::uint32_t next) {
    const std::uint64_t stored = key + 1;  // 0 marks an empty slot
    std::uint64_t h = stored * 0x9E3779B97F4A7C15ULL;
    h ^= h >> 29;
    for (std::size_t at = static_cast<std::size_t>(h) & mask_;; at = (at + 1) & mask_) {
      Slot& slot = slots_[at];
      if (slot.key == 0) {
        slot = {stored, next};
        return {next, true};
      }
      if (slot.key == stored) return {slot.vertex, false};
    }
  }

 private:
  struct Slot {
    std::uint64_t key = 0;
    std::uint32_t vertex = 0;
  };
  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
};

}  // namespace

Result<CutMesh> cutMesh(const DatasetView& view, const Cut& cut) {
  // Decoding and placing in parallel (TBB), welding in cut order: the same mesh for any
  // number of threads, and the first error in cut order.
  std::vector<PlacedPatch> placed(cut.patches.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cut.patches.size(), 4),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<std::byte> blob;
                      PatchMesh patch;
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        placePatch(view, cut.patches[i], blob, patch, placed[i]);
                      }
                    });
  std::size_t placedVertices = 0;
  for (const PlacedPatch& p : placed) placedVertices += p.keys.size();
  CutMesh mesh;
  PointIndex welded(placedVertices);
  std::vector<std::uint32_t> local;
  for (std::size_t i = 0; i < placed.size(); ++i) {
    PlacedPatch& p = placed[i];
    if (p.error) return std::move(*p.error);
    if (p.keys.empty()) continue;
    local.resize(p.keys.size());
    for (std::size_t v = 0; v < p.keys.size(); ++v) {
      const auto [vertex, inserted] =
          welded.insert(p.keys[v], static_cast<std::uint32_t>(mesh.vertices.size()));
      if (inserted) mesh.vertices.push_back(p.points[v]);
      local[v] = vertex;
    }
    for (const std::uint16_t k : p.indices) mesh.indices.push_back(local[k]);
    mesh.minLevel = std::min(mesh.minLevel, cut.patches[i].level);
    mesh.maxLevel = std::max(mesh.maxLevel, cut.patches[i].level);
    p = PlacedPatch();  // its memory goes as soon as it is welded
  }
  return mesh;
}

}  // namespace pbdam::runtime
