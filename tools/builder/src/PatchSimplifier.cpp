// Block simplification: the diamond's two halves from its four children, the shared diagonal
// simplified first, then each half with meshoptimizer (PatchBuilder.h; paper 004 §5 "Out-of-core
// Geometric Simplification"; docs/builder.md "Patches").
#include <geos_c.h>
#include <meshoptimizer.h>

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include "IndexedPatch.h"
#include "pbdam/builder/PatchBuilder.h"

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

/// One half of a block: the region of one of the diamond's triangles, on its own face.
struct Half {
  int face = 0;
  BinTriangle triangle;
  IndexedPatch mesh;
  std::vector<std::uint32_t> diagonal;  // vertex indices on left–right, ordered from left
};

/// A valid triangulation of the half: every triangle positive and together exactly its area
/// (positive triangles alone still allow a doubly covered fold).
bool validTriangulation(const Half& h, const std::vector<std::uint32_t>& indices) {
  std::int64_t area = 0;
  for (std::size_t k = 0; k < indices.size(); k += 3) {
    const std::int64_t a = doubleArea(h.mesh.points[indices[k]], h.mesh.points[indices[k + 1]],
                                      h.mesh.points[indices[k + 2]]);
    if (a <= 0) return false;
    area += a;
  }
  const BinTriangle& t = h.triangle;
  return area == std::abs(doubleArea(t.apex, t.left, t.right));
}

/// Half-edge collapses along the diagonal of one half. Each diagonal vertex keeps the list of
/// triangles around it, so a collapse looks only at those; collapsed-away triangles are marked
/// and removed at the end (in order, so the index list is what removing them one collapse at a
/// time would give).
class DiagonalCollapser final {
 public:
  explicit DiagonalCollapser(Half& h) : h_(h), dead_(h.mesh.indices.size() / 3, false) {
    slot_.assign(h.mesh.points.size(), kNone);
    around_.resize(h.diagonal.size());
    for (std::size_t k = 0; k < h.diagonal.size(); ++k) {
      slot_[h.diagonal[k]] = static_cast<std::uint32_t>(k);
    }
    const auto& idx = h.mesh.indices;
    for (std::size_t k = 0; k < idx.size(); ++k) {
      if (slot_[idx[k]] != kNone)
        around_[slot_[idx[k]]].push_back(static_cast<std::uint32_t>(k / 3));
    }
  }

  /// Whether collapsing diagonal vertex v onto diagonal vertex w keeps every remaining triangle
  /// of the half positive.
  bool canCollapse(std::uint32_t v, std::uint32_t w) const {
    const auto& idx = h_.mesh.indices;
    for (const std::uint32_t tri : around_[slot_[v]]) {
      if (dead_[tri]) continue;
      const std::size_t first = std::size_t{3} * tri;
      std::array<std::uint32_t, 3> t = {idx[first], idx[first + 1], idx[first + 2]};
      if (t[0] != v && t[1] != v && t[2] != v) continue;  // v was moved off it earlier
      if (t[0] == w || t[1] == w || t[2] == w) continue;  // becomes degenerate and is removed
      for (auto& i : t) {
        if (i == v) i = w;
      }
      if (doubleArea(h_.mesh.points[t[0]], h_.mesh.points[t[1]], h_.mesh.points[t[2]]) <= 0) {
        return false;
      }
    }
    return true;
  }

  void collapse(std::uint32_t v, std::uint32_t w) {
    auto& idx = h_.mesh.indices;
    auto& onW = around_[slot_[w]];
    for (const std::uint32_t tri : around_[slot_[v]]) {
      if (dead_[tri]) continue;
      std::uint32_t* t = &idx[std::size_t{3} * tri];
      const bool hasV = t[0] == v || t[1] == v || t[2] == v;
      if (!hasV) continue;
      const bool hasW = t[0] == w || t[1] == w || t[2] == w;
      if (hasW) {
        dead_[tri] = true;
        continue;
      }
      for (int k = 0; k < 3; ++k) {
        if (t[k] == v) t[k] = w;
      }
      onW.push_back(tri);
    }
    around_[slot_[v]].clear();
  }

  /// Removes the collapsed-away triangles from the half's index list.
  void finish() {
    auto& idx = h_.mesh.indices;
    std::size_t out = 0;
    for (std::size_t tri = 0; tri < dead_.size(); ++tri) {
      if (dead_[tri]) continue;
      for (std::size_t k = 0; k < 3; ++k) idx[out + k] = idx[3 * tri + k];
      out += 3;
    }
    idx.resize(out);
  }

 private:
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  Half& h_;
  std::vector<bool> dead_;
  std::vector<std::uint32_t> slot_;                 // point → its diagonal position, or kNone
  std::vector<std::vector<std::uint32_t>> around_;  // diagonal position → triangles
};

Half makeHalf(const BinTriangle& t, const std::array<const WorkPatch*, 2>& children) {
  Half h;
  h.face = t.face;
  h.triangle = t;
  h.mesh = IndexedPatch(children[0]->points.size() + children[1]->points.size());
  h.mesh.indices.reserve(children[0]->indices.size() + children[1]->indices.size());
  for (const WorkPatch* child : children) {
    for (std::uint32_t i : child->indices) h.mesh.indices.push_back(h.mesh.add(child->points[i]));
  }
  const LatticeXY dir = t.right - t.left;
  const std::int64_t len2 =
      static_cast<std::int64_t>(dir.x) * dir.x + static_cast<std::int64_t>(dir.y) * dir.y;
  std::vector<std::pair<std::int64_t, std::uint32_t>> onDiagonal;
  for (std::uint32_t i = 0; i < h.mesh.points.size(); ++i) {
    const LatticeXY p = h.mesh.points[i];
    if (doubleArea(t.left, t.right, p) != 0) continue;
    const LatticeXY d = p - t.left;
    const std::int64_t s =
        static_cast<std::int64_t>(d.x) * dir.x + static_cast<std::int64_t>(d.y) * dir.y;
    if (s >= 0 && s <= len2) onDiagonal.emplace_back(s, i);
  }
  std::sort(onDiagonal.begin(), onDiagonal.end());
  for (const auto& [s, i] : onDiagonal) h.diagonal.push_back(i);
  return h;
}

/// Simplifies the shared diagonal of both halves as a polyline to about half its vertices by
/// collapses along it, never flipping a triangle in either half.
void simplifyDiagonal(const SampleGrid& grid, Half& a, Half& b, BlockStats& stats) {
  const std::size_t n = a.diagonal.size();
  stats.diagonalBefore = static_cast<std::uint32_t>(n);
  stats.diagonalAfter = static_cast<std::uint32_t>(n);
  // Half b's diagonal runs the other way (its left is a's right); match by canonical key.
  const Lattice& lattice = grid.lattice();
  if (b.diagonal.size() != n) return;
  std::vector<std::uint32_t> bIndex(n);
  for (std::size_t k = 0; k < n; ++k) {
    bIndex[k] = b.diagonal[n - 1 - k];
    if (lattice.key(a.face, a.mesh.points[a.diagonal[k]]) !=
        lattice.key(b.face, b.mesh.points[bIndex[k]])) {
      assert(false && "block halves disagree on the diagonal");
      return;
    }
  }
  if (n <= 2) return;
  const std::size_t target = (n - 1 + 1) / 2 + 1;
  std::vector<double> height(n);
  std::vector<double> param(n);
  const LatticeXY dir = a.triangle.right - a.triangle.left;
  for (std::size_t k = 0; k < n; ++k) {
    const LatticeXY p = a.mesh.points[a.diagonal[k]];
    height[k] = static_cast<double>(grid.height(a.face, p));
    const LatticeXY d = p - a.triangle.left;
    param[k] = static_cast<double>(static_cast<std::int64_t>(d.x) * dir.x +
                                   static_cast<std::int64_t>(d.y) * dir.y);
  }
  std::vector<bool> alive(n, true);
  std::vector<bool> stuck(n, false);
  std::size_t aliveCount = n;
  DiagonalCollapser collapseA(a);
  DiagonalCollapser collapseB(b);
  while (aliveCount > target) {
    std::size_t best = n;
    double bestError = std::numeric_limits<double>::infinity();
    std::size_t bestPrev = 0;
    std::size_t bestNext = 0;
    std::size_t prev = 0;
    for (std::size_t k = 1; k + 1 < n; ++k) {
      if (!alive[k]) continue;
      std::size_t next = k + 1;
      while (!alive[next]) ++next;
      if (!stuck[k]) {
        const double f = (param[k] - param[prev]) / (param[next] - param[prev]);
        const double err = std::abs(height[k] - (height[prev] + f * (height[next] - height[prev])));
        if (err < bestError) {
          bestError = err;
          best = k;
          bestPrev = prev;
          bestNext = next;
        }
      }
      prev = k;
    }
    if (best == n) break;
    bool done = false;
    for (std::size_t onto : {bestPrev, bestNext}) {
      const std::uint32_t va = a.diagonal[best];
      const std::uint32_t wa = a.diagonal[onto];
      const std::uint32_t vb = bIndex[best];
      const std::uint32_t wb = bIndex[onto];
      if (collapseA.canCollapse(va, wa) && collapseB.canCollapse(vb, wb)) {
        collapseA.collapse(va, wa);
        collapseB.collapse(vb, wb);
        done = true;
        break;
      }
    }
    if (done) {
      alive[best] = false;
      --aliveCount;
    } else {
      stuck[best] = true;
    }
  }
  collapseA.finish();
  collapseB.finish();
  stats.diagonalAfter = static_cast<std::uint32_t>(aliveCount);
}

/// Removes triangles that are degenerate in (u,v) — meshopt may collapse an interior vertex onto
/// a straight border and leave a sliver whose three vertices lie on the border line (vertical in
/// 3D, so its normal test passes) — by flipping each with its neighbour across its long edge:
/// (a, w, b) with w between a and b, and (a, b, x) become (a, w, x) and (w, b, x), which cover
/// the neighbour's area exactly.
void repairDegenerate(const std::vector<LatticeXY>& points, std::vector<std::uint32_t>& idx) {
  const auto isDegenerate = [&](std::size_t t) {
    return doubleArea(points[idx[3 * t]], points[idx[3 * t + 1]], points[idx[3 * t + 2]]) == 0;
  };
  const std::size_t triangles = idx.size() / 3;
  std::vector<std::uint32_t> before;
  std::vector<bool> touched;
  std::vector<std::uint32_t> firstAt;
  std::vector<std::uint32_t> around;
  std::vector<std::uint32_t> cursor;
  for (int pass = 0; pass < 8; ++pass) {
    std::size_t firstDegenerate = 0;
    while (firstDegenerate < triangles && !isDegenerate(firstDegenerate)) ++firstDegenerate;
    if (firstDegenerate == triangles) return;
    bool changed = false;
    // A degenerate triangle's neighbour is looked up among the triangles as they were at the
    // start of the pass, through the triangles around each vertex (a counting sort: sorting
    // every edge of the half cost more than the whole repair). Triangles around a vertex are in
    // increasing order.
    before.assign(idx.begin(), idx.end());
    touched.assign(triangles, false);
    firstAt.assign(points.size() + 1, 0);
    for (const std::uint32_t i : before) ++firstAt[i + 1];
    for (std::size_t i = 0; i < points.size(); ++i) firstAt[i + 1] += firstAt[i];
    around.resize(before.size());
    cursor.assign(firstAt.begin(), firstAt.end() - 1);
    for (std::size_t k = 0; k < before.size(); ++k) {
      around[cursor[before[k]]++] = static_cast<std::uint32_t>(k / 3);
    }
    for (std::size_t t = firstDegenerate; t < triangles; ++t) {
      if (touched[t]) continue;
      const std::array<std::uint32_t, 3> v = {idx[3 * t], idx[3 * t + 1], idx[3 * t + 2]};
      if (doubleArea(points[v[0]], points[v[1]], points[v[2]]) != 0) continue;
      // The middle vertex w of the three collinear ones. In t's cyclic order (prev, w, next) the
      // long edge is next→prev, so the neighbour across it must hold prev→next (a consistently
      // oriented neighbour; anything else is a fold and is left for the caller to reject).
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t w = v[static_cast<std::size_t>(k)];
        const std::uint32_t next = v[static_cast<std::size_t>((k + 1) % 3)];
        const std::uint32_t prev = v[static_cast<std::size_t>((k + 2) % 3)];
        const LatticeXY da = points[next] - points[w];
        const LatticeXY db = points[prev] - points[w];
        if (static_cast<std::int64_t>(da.x) * db.x + static_cast<std::int64_t>(da.y) * db.y >= 0) {
          continue;  // w is not between the other two
        }
        // The last (highest-numbered) triangle that had the edge prev–next at the start of the
        // pass and now holds it as prev→next.
        std::size_t n = idx.size();
        std::uint32_t x = 0;
        for (std::uint32_t c = firstAt[prev]; c < firstAt[prev + 1]; ++c) {
          const std::size_t u = around[c];
          if (u == t) continue;
          const std::uint32_t* s = &before[3 * u];
          bool hadEdge = false;
          for (int e = 0; e < 3; ++e) {
            const std::uint32_t i = s[e];
            const std::uint32_t j = s[(e + 1) % 3];
            hadEdge = hadEdge || (i == prev && j == next) || (i == next && j == prev);
          }
          if (!hadEdge) continue;
          for (int q = 0; q < 3; ++q) {
            if (idx[3 * u + static_cast<std::size_t>(q)] == prev &&
                idx[3 * u + static_cast<std::size_t>((q + 1) % 3)] == next) {
              n = u;
              x = idx[3 * u + static_cast<std::size_t>((q + 2) % 3)];
            }
          }
        }
        if (n == idx.size() || touched[n]) break;
        const std::array<std::uint32_t, 3> t1 = {prev, w, x};
        const std::array<std::uint32_t, 3> t2 = {w, next, x};
        if (doubleArea(points[t1[0]], points[t1[1]], points[t1[2]]) <= 0 ||
            doubleArea(points[t2[0]], points[t2[1]], points[t2[2]]) <= 0) {
          break;
        }
        std::copy(t1.begin(), t1.end(), idx.begin() + static_cast<std::ptrdiff_t>(3 * t));
        std::copy(t2.begin(), t2.end(), idx.begin() + static_cast<std::ptrdiff_t>(3 * n));
        touched[t] = touched[n] = true;
        changed = true;
        break;
      }
    }
    if (!changed) return;
  }
}

/// Delaunay triangulation (GEOS) of the vertices a folded meshopt result kept. The half is a
/// convex triangle whose border vertices are all kept, so the triangulation of the kept points
/// covers it exactly and follows its border; it can never fold. Returns false if GEOS fails.
bool delaunayOfKept(const std::vector<LatticeXY>& points, const std::vector<std::uint32_t>& kept,
                    std::vector<std::uint32_t>& out) {
  std::vector<bool> used(points.size(), false);
  for (std::uint32_t i : kept) used[i] = true;
  std::unordered_map<std::uint64_t, std::uint32_t> byPoint;
  // The sites go to GEOS as one line string rather than a multipoint of point geometries: the
  // triangulation takes the sorted unique coordinates of whatever geometry it is given, so the
  // result is the same and GEOS allocates one object instead of one per point.
  std::vector<double> xy;
  xy.reserve(2 * kept.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    if (!used[i]) continue;
    byPoint.emplace(packXY(points[i]), i);
    xy.push_back(points[i].x);
    xy.push_back(points[i].y);
  }
  GEOSContextHandle_t ctx = GEOS_init_r();
  GEOSCoordSequence* sites =
      GEOSCoordSeq_copyFromBuffer_r(ctx, xy.data(), static_cast<unsigned>(xy.size() / 2), 0, 0);
  GEOSGeometry* multi = sites != nullptr ? GEOSGeom_createLineString_r(ctx, sites) : nullptr;
  GEOSGeometry* tris = multi != nullptr ? GEOSDelaunayTriangulation_r(ctx, multi, 0.0, 0) : nullptr;
  bool ok = tris != nullptr;
  out.clear();
  if (ok) {
    const int n = GEOSGetNumGeometries_r(ctx, tris);
    for (int t = 0; t < n && ok; ++t) {
      const GEOSGeometry* poly = GEOSGetGeometryN_r(ctx, tris, t);
      const GEOSGeometry* ring = GEOSGetExteriorRing_r(ctx, poly);
      const GEOSCoordSequence* seq = GEOSGeom_getCoordSeq_r(ctx, ring);
      std::array<std::uint32_t, 3> tri{};
      for (unsigned k = 0; k < 3 && ok; ++k) {
        double x = 0, y = 0;
        GEOSCoordSeq_getXY_r(ctx, seq, k, &x, &y);
        const auto it = byPoint.find(packXY(LatticeXY{static_cast<std::int32_t>(std::lround(x)),
                                                      static_cast<std::int32_t>(std::lround(y))}));
        if (it == byPoint.end())
          ok = false;
        else
          tri[k] = it->second;
      }
      const std::int64_t area = doubleArea(points[tri[0]], points[tri[1]], points[tri[2]]);
      if (area == 0) continue;
      if (area < 0) std::swap(tri[1], tri[2]);
      out.insert(out.end(), tri.begin(), tri.end());
    }
    GEOSGeom_destroy_r(ctx, tris);
  }
  if (multi != nullptr) GEOSGeom_destroy_r(ctx, multi);
  GEOS_finish_r(ctx);
  return ok && !out.empty();
}

/// Marks the vertices on the border of `patch`: the ends of edges used by one triangle. Edges
/// are grouped by their smaller vertex (a counting sort), each group sorted: an edge that
/// appears once is a border edge.
std::vector<bool> borderVertices(const WorkPatch& patch) {
  const std::size_t vertexCount = patch.points.size();
  std::vector<std::uint32_t> firstEdge(vertexCount + 1, 0);
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    for (std::size_t e = 0; e < 3; ++e) {
      ++firstEdge[std::min(patch.indices[k + e], patch.indices[k + (e + 1) % 3]) + 1];
    }
  }
  for (std::size_t v = 0; v < vertexCount; ++v) firstEdge[v + 1] += firstEdge[v];
  std::vector<std::uint32_t> otherEnd(patch.indices.size());
  {
    std::vector<std::uint32_t> cursor(firstEdge.begin(), firstEdge.end() - 1);
    for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
      for (std::size_t e = 0; e < 3; ++e) {
        const std::uint32_t i = patch.indices[k + e];
        const std::uint32_t j = patch.indices[k + (e + 1) % 3];
        otherEnd[cursor[std::min(i, j)]++] = std::max(i, j);
      }
    }
  }
  std::vector<bool> onBorder(vertexCount, false);
  for (std::size_t v = 0; v < vertexCount; ++v) {
    const auto first = otherEnd.begin() + firstEdge[v];
    const auto last = otherEnd.begin() + firstEdge[v + 1];
    std::sort(first, last);
    for (auto k = first; k != last;) {
      auto end = k + 1;
      while (end != last && *end == *k) ++end;
      if (end - k == 1) {  // used by one triangle: a border edge
        onBorder[v] = true;
        onBorder[*k] = true;
      }
      k = end;
    }
  }
  return onBorder;
}

/// The triangle count that leaves `targetVertices` vertices with the border locked: Euler for a
/// triangulated disk gives T = 2V − B − 2 (clamped to [1, the current count]).
std::int64_t targetTriangleCount(const WorkPatch& patch, std::uint32_t targetVertices) {
  const std::vector<bool> onBorder = borderVertices(patch);
  const auto border = static_cast<std::int64_t>(std::count(onBorder.begin(), onBorder.end(), true));
  const std::int64_t targetTriangles = 2 * static_cast<std::int64_t>(targetVertices) - border - 2;
  const auto currentTriangles = static_cast<std::int64_t>(patch.indices.size() / 3);
  return std::clamp<std::int64_t>(targetTriangles, 1, currentTriangles);
}

/// Positions for the quadric: the half as a height field over its face's lattice plane — x, y
/// in metres along the face (cells times the mean cell size), z the height. The block's error
/// is radial height error, and a height field keeps meshopt's normal-flip test equivalent to
/// the (u,v) orientation test that matters for drawing with barycentrics.
std::vector<float> heightFieldPositions(const SampleGrid& grid, int face, const WorkPatch& patch) {
  const double cellMeters = 0.5 * 3.14159265358979323846 * grid.planet().equatorialRadiusMeters() /
                            static_cast<double>(grid.lattice().sideCells());
  // Heights are scaled so that the height span is at most 1% of the half's extent: the quadric
  // then only sees height error (uniform z scaling keeps the collapse order), and every normal
  // stays within a few degrees of vertical, which makes meshopt's normal-flip test reject every
  // collapse that would fold the triangulation in (u,v).
  const LatticeXY origin = patch.points[0];
  LatticeXY lo = origin;
  LatticeXY hi = origin;
  float hMin = std::numeric_limits<float>::infinity();
  float hMax = -std::numeric_limits<float>::infinity();
  for (const LatticeXY& p : patch.points) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
    const float z = grid.height(face, p);
    hMin = std::min(hMin, z);
    hMax = std::max(hMax, z);
  }
  const double extent = static_cast<double>(std::max(hi.x - lo.x, hi.y - lo.y)) * cellMeters;
  const double zScale =
      std::min(1.0, 0.0005 * extent / std::max(1.0, static_cast<double>(hMax - hMin)));
  const std::size_t vertexCount = patch.points.size();
  std::vector<float> positions(vertexCount * 3);
  for (std::size_t v = 0; v < vertexCount; ++v) {
    const LatticeXY p = patch.points[v] - origin;
    positions[3 * v] = static_cast<float>(p.x * cellMeters);
    positions[3 * v + 1] = static_cast<float>(p.y * cellMeters);
    positions[3 * v + 2] =
        static_cast<float>(static_cast<double>(grid.height(face, patch.points[v]) - hMin) * zScale);
  }
  return positions;
}

/// One half being simplified with meshopt: its compacted patch, the quadric positions, and the
/// half (triangle and points) the results are checked against.
struct HalfSimplification {
  HalfSimplification(const SampleGrid& grid, const Half& h, const WorkPatch& compacted)
      : patch(compacted), positions(heightFieldPositions(grid, h.face, compacted)) {
    check.triangle = h.triangle;
    check.mesh.points = compacted.points;
  }
  const WorkPatch& patch;
  std::vector<float> positions;
  Half check;

  /// meshopt_simplify of `indices` towards `targetTriangles` with the border locked; the
  /// result's indices, or nothing when meshopt could not reduce them.
  std::optional<std::vector<std::uint32_t>> simplify(const std::vector<std::uint32_t>& indices,
                                                     std::int64_t targetTriangles) const {
    std::vector<std::uint32_t> result(indices.size());
    const std::size_t count = meshopt_simplify(
        result.data(), indices.data(), indices.size(), positions.data(), patch.points.size(),
        sizeof(float) * 3, static_cast<std::size_t>(targetTriangles) * 3, 1.0f,
        meshopt_SimplifyLockBorder, nullptr);
    if (count == 0 || count >= indices.size()) return std::nullopt;
    result.resize(count);
    return result;
  }
};

/// The whole simplification in one meshopt call: kept when it has no folded or degenerate
/// triangle in (u,v) (about three halves in four), a retry counted otherwise.
std::optional<std::vector<std::uint32_t>> simplifyInOneCall(const HalfSimplification& half,
                                                            std::int64_t targetTriangles,
                                                            BlockStats& stats) {
  auto whole = half.simplify(half.patch.indices, targetTriangles);
  if (!whole) return std::nullopt;
  repairDegenerate(half.patch.points, *whole);
  if (validTriangulation(half.check, *whole)) return whole;
  ++stats.simplifyRetries;
  return std::nullopt;
}

/// One step of the stepwise simplification from `current`: the first of 15%, 7% and 3% fewer
/// triangles whose result does not fold (meshopt's, or a Delaunay triangulation of the vertices
/// it kept); nothing when every size folds or meshopt makes no progress.
std::optional<std::vector<std::uint32_t>> simplifyOneStep(const HalfSimplification& half,
                                                          const std::vector<std::uint32_t>& current,
                                                          std::int64_t targetTriangles,
                                                          BlockStats& stats) {
  const std::size_t currentTriangleCount = current.size() / 3;
  const auto currentTris = static_cast<double>(currentTriangleCount);
  for (const double keep : {0.85, 0.93, 0.97}) {
    const auto stepTarget = std::max<std::int64_t>(
        targetTriangles, static_cast<std::int64_t>(std::floor(currentTris * keep)));
    auto step = half.simplify(current, stepTarget);
    if (!step) return std::nullopt;  // no progress possible
    repairDegenerate(half.patch.points, *step);
    if (!validTriangulation(half.check, *step)) {
      // Keep meshopt's choice of vertices, triangulate them without folds.
      std::vector<std::uint32_t> retriangulated;
      if (delaunayOfKept(half.patch.points, *step, retriangulated) &&
          retriangulated.size() < current.size() &&
          validTriangulation(half.check, retriangulated)) {
        ++stats.delaunayFallbacks;
        *step = std::move(retriangulated);
      }
    }
    if (validTriangulation(half.check, *step)) return step;
    ++stats.simplifyRetries;
  }
  return std::nullopt;
}

/// Simplifies one half with meshopt_simplify (locked border) towards `targetVertices`.
WorkPatch simplifyHalf(const SampleGrid& grid, const Half& h, std::uint32_t targetVertices,
                       BlockStats& stats) {
  WorkPatch patch = compact(h.mesh.points, h.mesh.indices);
  if (patch.points.size() <= targetVertices) return patch;
  const std::int64_t targetTriangles = targetTriangleCount(patch, targetVertices);
  const HalfSimplification half(grid, h, patch);
  // meshoptimizer 0.18 checks each collapse for normal flips against the mesh before its pass,
  // so two collapses of one pass can still fold a triangle between them. The half is first
  // simplified in one call to the target: that result is kept if it has no folded or degenerate
  // triangle in (u,v) — about three halves in four — and its quadrics have seen every collapse,
  // so it is also the better mesh (ETOPO5 uniform cuts 3–18% fewer triangles at equal vertical
  // error than stepping; docs/builder.md). Otherwise the half is simplified from the start in
  // steps of at most 15%, each kept only without a fold; a folding step is retried smaller, and
  // the simplification stops where even a 3% step folds.
  if (auto whole = simplifyInOneCall(half, targetTriangles, stats)) {
    return compact(patch.points, *whole);
  }
  std::vector<std::uint32_t> current = patch.indices;
  while (static_cast<std::int64_t>(current.size() / 3) > targetTriangles) {
    auto step = simplifyOneStep(half, current, targetTriangles, stats);
    if (!step) break;
    current = std::move(*step);
  }
  if (current.size() == patch.indices.size()) ++stats.halvesKeptUnsimplified;
  return compact(patch.points, current);
}

}  // namespace

BlockResult simplifyBlock(const SampleGrid& grid, const std::array<BinTriangle, 2>& triangles,
                          const std::array<std::array<const WorkPatch*, 2>, 2>& children,
                          std::uint32_t targetVertices) {
  BlockResult result;
  Half a = makeHalf(triangles[0], children[0]);
  Half b = makeHalf(triangles[1], children[1]);
  simplifyDiagonal(grid, a, b, result.stats);
  result.first = simplifyHalf(grid, a, targetVertices, result.stats);
  result.second = simplifyHalf(grid, b, targetVertices, result.stats);
  return result;
}

}  // namespace pbdam::builder
