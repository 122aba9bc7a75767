// Rendered-surface height queries (SurfaceQuery.h).
#include "pbdam/runtime/SurfaceQuery.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

// The leaf containing lattice position (x, y) of `face`.
NodeKey leafAt(const DatasetView& view, int face, const glm::dvec2& xy) {
  const std::uint32_t n = view.latticeCells();
  // Tree 0 is the half below the (0,0)–(N,N) diagonal (x ≥ y), tree 1 the other.
  NodeKey key{static_cast<std::uint8_t>(face), static_cast<std::uint8_t>(xy.x >= xy.y ? 0 : 1), 0};
  BinTriangle t = bintreeRoot(n, face, key.tree);
  const FaceView& file = view.face(face);
  for (std::uint64_t row = file.treeFirstNode(key.tree); !file.nodeAt(row).leaf();) {
    const int child = bintreeChildContaining(t, xy);
    row = file.firstChildOf(row) + static_cast<std::uint64_t>(child);
    t = bintreeChildren(t)[static_cast<std::size_t>(child)];
  }
  key.heap = t.index;
  return key;
}

// Line–triangle intersection parameter (Möller–Trumbore, the line not the ray: any sign of t).
std::optional<double> intersect(const glm::dvec3& origin, const glm::dvec3& dir,
                                const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 p = glm::cross(dir, e2);
  const double det = glm::dot(e1, p);
  if (std::abs(det) < 1e-30) return std::nullopt;
  const glm::dvec3 s = origin - a;
  const double u = glm::dot(s, p) / det;
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(dir, q) / det;
  constexpr double eps = 1e-9;
  if (u < -eps || v < -eps || u + v > 1.0 + eps) return std::nullopt;
  return glm::dot(e2, q) / det;
}

}  // namespace

Result<SurfaceHeight> surfaceHeightAt(const DatasetView& view, double lat, double lon) {
  if (!std::isfinite(lat) || !std::isfinite(lon) || std::abs(lat) > 90.0 || std::abs(lon) > 360.0) {
    return makeError(ErrorCode::InvalidArgument,
                     "position must be LAT in [-90, 90] and LON in [-360, 360] degrees");
  }
  const Planet& planet = view.planet();
  const glm::dvec3 origin = planet.geodeticToEcef({lat, lon, 0.0});
  const glm::dvec3 normal = planet.surfaceNormal(lat, lon);
  // Candidate leaves: the one under the point and those a quarter of a deepest leaf away in
  // eight directions (rendered vertices sit slightly sideways of their lattice points, so the
  // surface above a point near a leaf edge can belong to the neighbour, possibly on another
  // face). The lattice cells are those of the deepest leaves; a shallower leaf is larger.
  const EnuFrame enu = planet.enuFrame(lat, lon, 0.0);
  const double n = view.latticeCells();
  const double leafMeters = planet.equatorialRadiusMeters() * (3.14159265358979323846 / 2.0) *
                            static_cast<double>(view.manifest().leafCells) / n;
  std::vector<NodeKey> leaves;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const glm::dvec3 p = origin + 0.25 * leafMeters *
                                        (static_cast<double>(dx) * enu.axes[0] +
                                         static_cast<double>(dy) * enu.axes[1]);
      const FaceUv fuv = CubeMap::directionToFaceUv(p);
      const glm::dvec2 xy = glm::clamp(fuv.uv * n, glm::dvec2(0.0), glm::dvec2(n));
      const NodeKey key = leafAt(view, cubeFaceIndex(fuv.face), xy);
      if (std::find(leaves.begin(), leaves.end(), key) == leaves.end()) leaves.push_back(key);
    }
  }
  std::optional<SurfaceHeight> best;
  PatchMesh mesh;
  std::vector<glm::dvec3> positions;
  std::vector<std::byte> blob;
  for (const NodeKey& key : leaves) {
    const NodeRecord record = view.node(key);
    const FaceView& face = view.face(key.face);
    auto bytes = face.readPatchBlob(record, blob);
    if (!bytes) return std::move(bytes).error();
    auto decoded =
        decodePatch(*bytes, mesh, face.context() + "@" + std::to_string(record.blobOffset));
    if (!decoded) return decoded.error();
    // The vertices where they are drawn: their terrain points (PatchDraw.h).
    const PatchVertexPlacement placement(view, key, record);
    positions.resize(mesh.vertices.size());
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      LatticeXY q{0};
      const PatchVertex& pv = mesh.vertices[v];
      if (!placement.latticePoint(pv.b1, pv.b2, q)) {
        return makeError(ErrorCode::CorruptData,
                         face.context() + "@" + std::to_string(record.blobOffset) +
                             ": patch vertex " + std::to_string(v) +
                             " is not a lattice point of its node's triangle");
      }
      positions[v] = placement.terrainPoint(q, pv.heightSteps);
    }
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const auto hit = intersect(origin, normal, positions[mesh.indices[t]],
                                 positions[mesh.indices[t + 1]], positions[mesh.indices[t + 2]]);
      // The outermost hit: where the line meets the surface coming from above.
      if (hit && (!best || *hit > best->heightMeters)) {
        best = SurfaceHeight{*hit, key, static_cast<double>(record.errorMeters),
                             static_cast<double>(record.measuredErrorMeters), record.sources};
      }
    }
  }
  if (!best) {
    return makeError(ErrorCode::Internal, "no leaf surface found at " + std::to_string(lat) + ", " +
                                              std::to_string(lon));
  }
  return *best;
}

}  // namespace pbdam::runtime
