// The mesh of a cut (CutMesh.h).
#include "pbdam/runtime/CutMesh.h"

#include <algorithm>
#include <string>
#include <unordered_map>

#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;

namespace pbdam::runtime {

Result<CutMesh> cutMesh(const DatasetView& view, const Cut& cut) {
  CutMesh mesh;
  std::unordered_map<PointKey, std::uint32_t> welded;
  PatchMesh patch;
  std::vector<std::byte> blob;
  std::vector<std::uint32_t> local;
  for (const CutPatch& p : cut.patches) {
    const NodeRecord record = view.node(p.node);
    if (record.blobBytes == 0) continue;
    const formats::FaceView& face = view.face(p.node.face);
    auto bytes = face.readPatchBlob(record, blob);
    if (!bytes) return std::move(bytes).error();
    if (auto r =
            decodePatch(*bytes, patch, face.context() + "@" + std::to_string(record.blobOffset));
        !r) {
      return std::move(r).error();
    }
    const PatchVertexPlacement placement(view, p.node, record);
    local.resize(patch.vertices.size());
    for (std::size_t v = 0; v < patch.vertices.size(); ++v) {
      LatticeXY q{0};
      if (!placement.latticePoint(patch.vertices[v].b1, patch.vertices[v].b2, q)) {
        return makeError(ErrorCode::CorruptData,
                         face.context() + "@" + std::to_string(record.blobOffset) +
                             ": a patch vertex is not a lattice point of its node");
      }
      const PointKey key = latticePointKey(view.latticeCells(), p.node.face, q);
      const auto [it, inserted] =
          welded.try_emplace(key, static_cast<std::uint32_t>(mesh.vertices.size()));
      if (inserted)
        mesh.vertices.push_back(placement.terrainPoint(q, patch.vertices[v].heightSteps));
      local[v] = it->second;
    }
    for (const std::uint16_t i : patch.indices) mesh.indices.push_back(local[i]);
    mesh.minLevel = std::min(mesh.minLevel, p.level);
    mesh.maxLevel = std::max(mesh.maxLevel, p.level);
  }
  return mesh;
}

}  // namespace pbdam::runtime
