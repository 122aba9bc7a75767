// Rendered-surface height queries (SurfaceQuery.h).
#include "pbdam/runtime/SurfaceQuery.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
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

// Whether the line origin + t·dir (any t) passes within `radius` of `centre`, with a margin far
// above the rounding of these figures and intersect()'s tolerance (1e-9 of a triangle's edges,
// which are shorter than 2·radius): a line that misses this sphere hits no triangle inside it.
bool lineNearSphere(const glm::dvec3& origin, const glm::dvec3& dir, const glm::dvec3& centre,
                    double radius) {
  const glm::dvec3 w = centre - origin;
  const double along = glm::dot(w, dir);
  const double distanceSquared = glm::dot(w, w) - along * along / glm::dot(dir, dir);
  const double reach = radius * (1.0 + 1e-6) + 1.0;
  return distanceSquared <= reach * reach;
}

// Leaf `key`'s triangles where they are drawn: its terrain points (PatchDraw.h), indices and a
// sphere around them.
Result<void> placeLeaf(const DatasetView& view, const NodeKey& key, const NodeRecord& record,
                       SurfaceLeafCache::Leaf& leaf) {
  std::vector<glm::dvec3>& positions = leaf.positions;
  const FaceView& face = view.face(key.face);
  std::vector<std::byte> blob;
  auto bytes = face.readPatchBlob(record, blob);
  if (!bytes) return std::move(bytes).error();
  PatchMesh mesh;
  auto decoded =
      decodePatch(*bytes, mesh, face.context() + "@" + std::to_string(record.blobOffset));
  if (!decoded) return decoded.error();
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
  leaf.indices = std::move(mesh.indices);
  glm::dvec3 low(std::numeric_limits<double>::infinity()), high(-low);
  for (const glm::dvec3& p : positions) {
    low = glm::min(low, p);
    high = glm::max(high, p);
  }
  leaf.centre = positions.empty() ? glm::dvec3(0.0) : 0.5 * (low + high);
  leaf.radius = 0.0;
  for (const glm::dvec3& p : positions) {
    leaf.radius = std::max(leaf.radius, glm::length(p - leaf.centre));
  }
  return {};
}

}  // namespace

Result<SurfaceHeight> surfaceHeightAt(const DatasetView& view, double lat, double lon) {
  // The nine candidate leaves at most (below), each decoded once.
  SurfaceLeafCache once(9);
  return surfaceHeightAt(view, lat, lon, once);
}

Result<SurfaceHeight> surfaceHeightAt(const DatasetView& view, double lat, double lon,
                                      SurfaceLeafCache& cache) {
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
  if (cache.view_ != &view) {
    cache.leaves_.clear();
    cache.view_ = &view;
  }
  // Room for all of this call's leaves: a full cache starts over before the first is looked up,
  // so that none is dropped while in use.
  if (cache.leaves_.size() + leaves.size() > cache.maxLeaves_) cache.leaves_.clear();
  std::optional<SurfaceHeight> best;
  for (const NodeKey& key : leaves) {
    const NodeRecord record = view.node(key);
    auto [it, inserted] = cache.leaves_.try_emplace(packKey(key));
    SurfaceLeafCache::Leaf& leaf = it->second;
    if (inserted) {
      auto placed = placeLeaf(view, key, record, leaf);
      if (!placed) {
        cache.leaves_.erase(it);
        return std::move(placed).error();
      }
      ++cache.decodedLeaves_;
    }
    // Most candidates lie beside the line: none of their triangles can be hit.
    if (!lineNearSphere(origin, normal, leaf.centre, leaf.radius)) continue;
    for (std::size_t t = 0; t + 2 < leaf.indices.size(); t += 3) {
      const auto hit =
          intersect(origin, normal, leaf.positions[leaf.indices[t]],
                    leaf.positions[leaf.indices[t + 1]], leaf.positions[leaf.indices[t + 2]]);
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
