// Leaf patches, block simplification (meshoptimizer), and patch measurement/encoding
// (PatchBuilder.h; paper 004 §4.2 displaced triangles, §5 block simplification).
#include "pbdam/builder/PatchBuilder.h"

#include <geos_c.h>
#include <meshoptimizer.h>

#include <glm/common.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <unordered_map>

namespace pbdam::builder {
namespace {

std::uint64_t packXY(LatticeXY p) noexcept {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(p.x)) << 32) |
         static_cast<std::uint32_t>(p.y);
}

/// A patch under construction with a point → index lookup (open addressing with linear
/// probing; points are numbered in first-use order, so the result does not depend on the table).
struct IndexedPatch {
  std::vector<LatticeXY> points;
  std::vector<std::uint32_t> indices;

  explicit IndexedPatch(std::size_t expectedPoints = 64) {
    std::size_t capacity = 64;
    while (capacity < 2 * expectedPoints) capacity *= 2;
    slots_.assign(capacity, kEmpty);
  }

  std::uint32_t add(LatticeXY p) {
    const std::uint64_t key = packXY(p);
    const std::size_t mask = slots_.size() - 1;
    // A multiplicative hash of the packed point (Fibonacci hashing); the top bits pick the slot.
    std::size_t slot = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> 32) & mask;
    while (slots_[slot] != kEmpty) {
      if (packXY(points[slots_[slot]]) == key) return slots_[slot];
      slot = (slot + 1) & mask;
    }
    const auto index = static_cast<std::uint32_t>(points.size());
    points.push_back(p);
    slots_[slot] = index;
    if (2 * points.size() > slots_.size()) grow();
    return index;
  }
  /// Adds a triangle, wound counter-clockwise in (u,v).
  void addTriangle(LatticeXY a, LatticeXY b, LatticeXY c) {
    if (doubleArea(a, b, c) < 0) std::swap(b, c);
    indices.push_back(add(a));
    indices.push_back(add(b));
    indices.push_back(add(c));
  }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  void grow() {
    slots_.assign(slots_.size() * 2, kEmpty);
    const std::size_t mask = slots_.size() - 1;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      std::size_t slot =
          static_cast<std::size_t>((packXY(points[i]) * 0x9E3779B97F4A7C15ULL) >> 32) & mask;
      while (slots_[slot] != kEmpty) slot = (slot + 1) & mask;
      slots_[slot] = i;
    }
  }
  std::vector<std::uint32_t> slots_;
};

void bisectToCells(const BinTriangle& t, IndexedPatch& out) {
  const LatticeXY leg = t.left - t.apex;
  if (std::abs(leg.x) + std::abs(leg.y) == 1) {  // an axis-aligned unit leg: one grid half-cell
    out.addTriangle(t.apex, t.left, t.right);
    return;
  }
  for (const BinTriangle& c : Lattice::children(t)) bisectToCells(c, out);
}

/// Drops unreferenced points and renumbers (first-use order keeps it deterministic).
WorkPatch compact(const std::vector<LatticeXY>& points, const std::vector<std::uint32_t>& indices) {
  WorkPatch out;
  std::vector<std::uint32_t> remap(points.size(), std::numeric_limits<std::uint32_t>::max());
  out.indices.reserve(indices.size());
  for (std::uint32_t i : indices) {
    if (remap[i] == std::numeric_limits<std::uint32_t>::max()) {
      remap[i] = static_cast<std::uint32_t>(out.points.size());
      out.points.push_back(points[i]);
    }
    out.indices.push_back(remap[i]);
  }
  return out;
}

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
      std::array<std::uint32_t, 3> t = {idx[3 * tri], idx[3 * tri + 1], idx[3 * tri + 2]};
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
      std::uint32_t* t = &idx[3 * tri];
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

/// Simplifies one half with meshopt_simplify (locked border) towards `targetVertices`.
WorkPatch simplifyHalf(const SampleGrid& grid, const Half& h, std::uint32_t targetVertices,
                       BlockStats& stats) {
  WorkPatch patch = compact(h.mesh.points, h.mesh.indices);
  const std::size_t vertexCount = patch.points.size();
  if (vertexCount <= targetVertices) return patch;
  // Boundary vertices (on edges used by one triangle) are locked; Euler for a triangulated disk
  // gives the triangle count that leaves `targetVertices` vertices: T = 2V − B − 2.
  // Edges grouped by their smaller vertex (a counting sort), each group sorted: an edge that
  // appears once is a border edge.
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
  const auto border = static_cast<std::int64_t>(std::count(onBorder.begin(), onBorder.end(), true));
  std::int64_t targetTriangles = 2 * static_cast<std::int64_t>(targetVertices) - border - 2;
  const auto currentTriangles = static_cast<std::int64_t>(patch.indices.size() / 3);
  targetTriangles = std::clamp<std::int64_t>(targetTriangles, 1, currentTriangles);

  // Positions for the quadric: the half as a height field over its face's lattice plane — x, y
  // in metres along the face (cells times the mean cell size), z the height. The block's error
  // is radial height error, and a height field keeps meshopt's normal-flip test equivalent to
  // the (u,v) orientation test that matters for drawing with barycentrics.
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
    const float z = grid.height(h.face, p);
    hMin = std::min(hMin, z);
    hMax = std::max(hMax, z);
  }
  const double extent = static_cast<double>(std::max(hi.x - lo.x, hi.y - lo.y)) * cellMeters;
  const double zScale =
      std::min(1.0, 0.0005 * extent / std::max(1.0, static_cast<double>(hMax - hMin)));
  std::vector<float> positions(vertexCount * 3);
  for (std::size_t v = 0; v < vertexCount; ++v) {
    const LatticeXY p = patch.points[v] - origin;
    positions[3 * v] = static_cast<float>(p.x * cellMeters);
    positions[3 * v + 1] = static_cast<float>(p.y * cellMeters);
    positions[3 * v + 2] = static_cast<float>(
        static_cast<double>(grid.height(h.face, patch.points[v]) - hMin) * zScale);
  }
  // meshoptimizer 0.18 checks each collapse for normal flips against the mesh before its pass,
  // so two collapses of one pass can still fold a triangle between them. The half is first
  // simplified in one call to the target: that result is kept if it has no folded or degenerate
  // triangle in (u,v) — about three halves in four — and its quadrics have seen every collapse,
  // so it is also the better mesh (ETOPO5 uniform cuts 3–18% fewer triangles at equal vertical
  // error than stepping; docs/builder.md). Otherwise the half is simplified from the start in
  // steps of at most 15%, each kept only without a fold; a folding step is retried smaller, and
  // the simplification stops where even a 3% step folds.
  std::vector<std::uint32_t> current = patch.indices;
  std::vector<std::uint32_t> result(current.size());
  Half check;
  check.triangle = h.triangle;
  check.mesh.points = patch.points;
  {
    const std::size_t count = meshopt_simplify(result.data(), current.data(), current.size(),
                                               positions.data(), vertexCount, sizeof(float) * 3,
                                               static_cast<std::size_t>(targetTriangles) * 3, 1.0f,
                                               meshopt_SimplifyLockBorder, nullptr);
    if (count > 0 && count < current.size()) {
      std::vector<std::uint32_t> whole(result.begin(),
                                       result.begin() + static_cast<std::ptrdiff_t>(count));
      repairDegenerate(patch.points, whole);
      if (validTriangulation(check, whole)) return compact(patch.points, whole);
      ++stats.simplifyRetries;
    }
  }
  while (static_cast<std::int64_t>(current.size() / 3) > targetTriangles) {
    const auto currentTris = static_cast<double>(current.size() / 3);
    bool accepted = false;
    for (const double keep : {0.85, 0.93, 0.97}) {
      const auto stepTarget = std::max<std::int64_t>(
          targetTriangles, static_cast<std::int64_t>(std::floor(currentTris * keep)));
      const std::size_t count =
          meshopt_simplify(result.data(), current.data(), current.size(), positions.data(),
                           vertexCount, sizeof(float) * 3, static_cast<std::size_t>(stepTarget) * 3,
                           1.0f, meshopt_SimplifyLockBorder, nullptr);
      if (count == 0 || count >= current.size()) break;  // no progress possible
      std::vector<std::uint32_t> step(result.begin(),
                                      result.begin() + static_cast<std::ptrdiff_t>(count));
      repairDegenerate(patch.points, step);
      if (!validTriangulation(check, step)) {
        // Keep meshopt's choice of vertices, triangulate them without folds.
        std::vector<std::uint32_t> retriangulated;
        if (delaunayOfKept(patch.points, step, retriangulated) &&
            retriangulated.size() < current.size() && validTriangulation(check, retriangulated)) {
          ++stats.delaunayFallbacks;
          step = std::move(retriangulated);
        }
      }
      if (validTriangulation(check, step)) {
        current = std::move(step);
        accepted = true;
        break;
      }
      ++stats.simplifyRetries;
    }
    if (!accepted) break;
  }
  if (current.size() == patch.indices.size()) ++stats.halvesKeptUnsimplified;
  return compact(patch.points, current);
}

}  // namespace

WorkPatch makeLeafPatch(const BinTriangle& triangle) {
  // The bisection depends only on the triangle's shape (its legs as vectors): leaves of one
  // shape are translates of each other, so each thread builds each shape once and translates it.
  struct Shape {
    LatticeXY toLeft;
    LatticeXY toRight;
    WorkPatch relative;  // points relative to the apex
  };
  thread_local std::vector<Shape> shapes;
  const LatticeXY toLeft = triangle.left - triangle.apex;
  const LatticeXY toRight = triangle.right - triangle.apex;
  const Shape* shape = nullptr;
  for (const Shape& s : shapes) {
    if (s.toLeft == toLeft && s.toRight == toRight) shape = &s;
  }
  if (shape == nullptr) {
    IndexedPatch mesh;
    bisectToCells(triangle, mesh);
    WorkPatch patch = compact(mesh.points, mesh.indices);
    for (LatticeXY& p : patch.points) p -= triangle.apex;
    shapes.push_back(Shape{toLeft, toRight, std::move(patch)});
    shape = &shapes.back();
  }
  WorkPatch out;
  out.indices = shape->relative.indices;
  out.points.resize(shape->relative.points.size());
  for (std::size_t k = 0; k < out.points.size(); ++k) {
    out.points[k] = shape->relative.points[k] + triangle.apex;
  }
  return out;
}

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

NodeCorners nodeCorners(const SampleGrid& grid, const BinTriangle& t) {
  NodeCorners c;
  const std::array<LatticeXY, 3> corners = {t.apex, t.left, t.right};
  for (std::size_t k = 0; k < 3; ++k) {
    c.positions[k] = grid.terrainPoint(t.face, corners[k]);
    c.normals[k] = glm::vec3(grid.surfaceNormal(t.face, corners[k]));
  }
  return c;
}

namespace {

/// Position data of one corner or edge endpoint, in double.
struct CornerData {
  glm::dvec3 position;
  glm::dvec3 normal;
};

}  // namespace

namespace {

std::int64_t floorDiv(std::int64_t a, std::int64_t b) noexcept {
  const std::int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

/// Narrows [lo, hi] to the x where the edge function `coefX·x + rest` is ≥ 0 (on one row).
void clipSpan(std::int64_t coefX, std::int64_t rest, std::int64_t& lo, std::int64_t& hi) noexcept {
  if (coefX > 0) {
    lo = std::max(lo, -floorDiv(rest, coefX));  // x ≥ ceil(−rest / coefX)
  } else if (coefX < 0) {
    hi = std::min(hi, floorDiv(rest, -coefX));  // x ≤ floor(rest / −coefX)
  } else if (rest < 0) {
    hi = lo - 1;
  }
}

}  // namespace

namespace {

/// Calls f(a, b, c, w0, w1, w2, total) for every lattice point inside or on a triangle (a, b, c)
/// of `patch` (vertex indices), with its integer barycentric weights (w0 + w1 + w2 = total).
template <class F>
void forEachLatticePointIn(const WorkPatch& patch, F&& f) {
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const std::uint32_t ia = patch.indices[k];
    const std::uint32_t ib = patch.indices[k + 1];
    const std::uint32_t ic = patch.indices[k + 2];
    const LatticeXY a = patch.points[ia];
    const LatticeXY b = patch.points[ib];
    const LatticeXY c = patch.points[ic];
    const std::int64_t total = doubleArea(a, b, c);
    if (total <= 0) continue;
    const int x0 = std::min({a.x, b.x, c.x});
    const int x1 = std::max({a.x, b.x, c.x});
    const int y0 = std::min({a.y, b.y, c.y});
    const int y1 = std::max({a.y, b.y, c.y});
    for (int y = y0; y <= y1; ++y) {
      // The lattice points of this row inside or on the triangle: where all three edge
      // functions doubleArea(edge, p) are ≥ 0 (each is linear in x along the row).
      std::int64_t lo = x0;
      std::int64_t hi = x1;
      clipSpan(-static_cast<std::int64_t>(c.y - b.y), doubleArea(b, c, LatticeXY{0, y}), lo, hi);
      clipSpan(-static_cast<std::int64_t>(a.y - c.y), doubleArea(c, a, LatticeXY{0, y}), lo, hi);
      clipSpan(-static_cast<std::int64_t>(b.y - a.y), doubleArea(a, b, LatticeXY{0, y}), lo, hi);
      for (auto x = static_cast<int>(lo); x <= hi; ++x) {
        const LatticeXY p{x, y};
        const std::int64_t w0 = doubleArea(b, c, p);
        const std::int64_t w1 = doubleArea(c, a, p);
        const std::int64_t w2 = doubleArea(a, b, p);
        assert(w0 >= 0 && w1 >= 0 && w2 >= 0);
        f(ia, ib, ic, p, static_cast<double>(w0), static_cast<double>(w1), static_cast<double>(w2),
          static_cast<double>(total));
      }
    }
  }
}

/// The lattice heights of `face` interpolated bilinearly at (x, y) in cells, clamped to the face.
double latticeHeightAt(const SampleGrid& grid, int face, glm::dvec2 xy) noexcept {
  const auto n = static_cast<std::int32_t>(grid.lattice().sideCells());
  xy = glm::clamp(xy, glm::dvec2(0.0), glm::dvec2(static_cast<double>(n)));
  const double fx = std::floor(xy.x);
  const double fy = std::floor(xy.y);
  const auto x0 = std::min(static_cast<std::int32_t>(fx), n - 1);
  const auto y0 = std::min(static_cast<std::int32_t>(fy), n - 1);
  const double tx = xy.x - static_cast<double>(x0);
  const double ty = xy.y - static_cast<double>(y0);
  const double h00 = static_cast<double>(grid.height(face, LatticeXY{x0, y0}));
  const double h10 = static_cast<double>(grid.height(face, LatticeXY{x0 + 1, y0}));
  const double h01 = static_cast<double>(grid.height(face, LatticeXY{x0, y0 + 1}));
  const double h11 = static_cast<double>(grid.height(face, LatticeXY{x0 + 1, y0 + 1}));
  return (1.0 - ty) * ((1.0 - tx) * h00 + tx * h10) + ty * ((1.0 - tx) * h01 + tx * h11);
}

}  // namespace

double maxLatticeDeviation(const SampleGrid& grid, int face, const WorkPatch& patch) {
  double worst = 0.0;
  forEachLatticePointIn(patch, [&](std::uint32_t ia, std::uint32_t ib, std::uint32_t ic,
                                   LatticeXY p, double w0, double w1, double w2, double total) {
    const double ha = static_cast<double>(grid.height(face, patch.points[ia]));
    const double hb = static_cast<double>(grid.height(face, patch.points[ib]));
    const double hc = static_cast<double>(grid.height(face, patch.points[ic]));
    const double hp = (w0 * ha + w1 * hb + w2 * hc) / total;
    worst = std::max(worst, std::abs(hp - static_cast<double>(grid.height(face, p))));
  });
  return worst;
}

MeasuredPatch measurePatch(const SampleGrid& grid, const BinTriangle& t, const WorkPatch& patch,
                           double heightStepMeters) {
  MeasuredPatch out;
  const Lattice& lattice = grid.lattice();
  const NodeCorners corners = nodeCorners(grid, t);
  const std::array<LatticeXY, 3> cornerXY = {t.apex, t.left, t.right};
  std::array<CornerData, 3> cd;
  for (std::size_t k = 0; k < 3; ++k) {
    cd[k] = CornerData{corners.positions[k], glm::dvec3(corners.normals[k])};
  }
  const LatticeXY e1 = t.left - t.apex;
  const LatticeXY e2 = t.right - t.apex;
  const std::int64_t len2 =
      static_cast<std::int64_t>(e1.x) * e1.x + static_cast<std::int64_t>(e1.y) * e1.y;
  constexpr std::int64_t one = kPatchBarycentricOne;

  // Data of an edge endpoint pair in canonical key order (so both patches on the edge compute
  // the same numbers) and the parameter from the first.
  auto edgePoint = [&](std::size_t from, std::size_t to, std::int64_t numerator, glm::dvec3& pflat,
                       glm::dvec3& nb) {
    std::size_t first = from;
    std::size_t second = to;
    std::int64_t num = numerator;
    if (lattice.key(t.face, cornerXY[from]) > lattice.key(t.face, cornerXY[to])) {
      std::swap(first, second);
      num = len2 - numerator;
    }
    if (num == 0) {
      pflat = cd[first].position;
      nb = cd[first].normal;
    } else if (num == len2) {
      pflat = cd[second].position;
      nb = cd[second].normal;
    } else {
      const double s = static_cast<double>(num) / static_cast<double>(len2);
      pflat = cd[first].position + s * (cd[second].position - cd[first].position);
      nb = cd[first].normal + s * (cd[second].normal - cd[first].normal);
    }
  };

  out.mesh.vertices.resize(patch.points.size());
  std::vector<glm::dvec3> rendered(patch.points.size());
  double minH = std::numeric_limits<double>::infinity();
  double maxH = -std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < patch.points.size(); ++v) {
    const LatticeXY p = patch.points[v];
    const LatticeXY d = p - t.apex;
    const std::int64_t n1 =
        static_cast<std::int64_t>(d.x) * e1.x + static_cast<std::int64_t>(d.y) * e1.y;
    const std::int64_t n2 =
        static_cast<std::int64_t>(d.x) * e2.x + static_cast<std::int64_t>(d.y) * e2.y;
    assert((n1 * one) % len2 == 0 && (n2 * one) % len2 == 0);
    glm::dvec3 pflat;
    glm::dvec3 nb;
    if (n2 == 0) {
      edgePoint(0, 1, n1, pflat, nb);  // apex–left
    } else if (n1 == 0) {
      edgePoint(0, 2, n2, pflat, nb);  // apex–right
    } else if (n1 + n2 == len2) {
      edgePoint(1, 2, n2, pflat, nb);  // left–right
    } else {
      const double b1 = static_cast<double>(n1) / static_cast<double>(len2);
      const double b2 = static_cast<double>(n2) / static_cast<double>(len2);
      pflat = cd[0].position + b1 * (cd[1].position - cd[0].position) +
              b2 * (cd[2].position - cd[0].position);
      nb = cd[0].normal + b1 * (cd[1].normal - cd[0].normal) + b2 * (cd[2].normal - cd[0].normal);
    }
    const glm::dvec3 terrain = grid.terrainPoint(t.face, p);
    const double h = glm::dot(terrain - pflat, nb) / glm::dot(nb, nb);
    const double steps = std::round(h / heightStepMeters);
    const auto stepsInt = static_cast<std::int32_t>(std::clamp(steps, -2147483647.0, 2147483647.0));
    rendered[v] = pflat + (static_cast<double>(stepsInt) * heightStepMeters) * nb;
    out.mesh.vertices[v] = PatchVertex{static_cast<std::uint16_t>(n1 * one / len2),
                                       static_cast<std::uint16_t>(n2 * one / len2), stepsInt};
    const double height = static_cast<double>(grid.height(t.face, p));
    minH = std::min(minH, height);
    maxH = std::max(maxH, height);
  }
  out.minHeightMeters = minH;
  out.maxHeightMeters = maxH;
  out.mesh.indices.resize(patch.indices.size());
  for (std::size_t k = 0; k < patch.indices.size(); ++k) {
    out.mesh.indices[k] = static_cast<std::uint16_t>(patch.indices[k]);
  }

  // Bounding sphere of the rendered vertices (box centre; deterministic).
  glm::dvec3 lo(std::numeric_limits<double>::infinity());
  glm::dvec3 hi(-std::numeric_limits<double>::infinity());
  for (const auto& r : rendered) {
    lo = glm::min(lo, r);
    hi = glm::max(hi, r);
  }
  out.sphereCenter = 0.5 * (lo + hi);
  for (const auto& r : rendered) {
    out.sphereRadiusMeters = std::max(out.sphereRadiusMeters, glm::length(r - out.sphereCenter));
  }

  // Chord bound: a flat triangle between three points of a sphere of radius R sags below it by
  // (rc² − ρ²)/(2R) at distance ρ from its circumcentre (rc the circumradius): at most rc²/(2R)
  // where the circumcentre is inside (acute triangles), else c²/(8R) at the midpoint of the
  // longest edge c. (The longest-edge bound alone is 3/4 of the truth for an equilateral
  // triangle.) Below, `worst` is 4rc² or c², so the bound is worst/(8R).
  const Planet& planet = grid.planet();
  const double rMin =
      std::max(1.0, planet.polarRadiusMeters() + static_cast<double>(grid.minHeightMeters()));
  double worst = 0.0;
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const glm::dvec3& a = rendered[patch.indices[k]];
    const glm::dvec3& b = rendered[patch.indices[k + 1]];
    const glm::dvec3& c = rendered[patch.indices[k + 2]];
    std::array<double, 3> sq = {glm::dot(b - a, b - a), glm::dot(c - b, c - b),
                                glm::dot(a - c, a - c)};
    std::sort(sq.begin(), sq.end());
    // 16·area² by Heron's formula in squared sides.
    const double area16 = 2.0 * (sq[0] * sq[1] + sq[1] * sq[2] + sq[2] * sq[0]) -
                          (sq[0] * sq[0] + sq[1] * sq[1] + sq[2] * sq[2]);
    const bool acute = sq[0] + sq[1] > sq[2] && area16 > 0.0;
    worst = std::max(worst, acute ? 4.0 * sq[0] * sq[1] * sq[2] / area16 : sq[2]);
  }
  out.chordErrorMeters = worst / (8.0 * rMin);

  // Representation error (docs/builder.md "Errors"). A vertex is drawn at its lattice
  // barycentrics on the flat corner triangle, displaced along the interpolated normal: on the
  // tangent-adjusted cube map that lands beside its lattice point, by a shift δ that is smooth
  // over the patch (kilometres on coarse patches, zero at the corners). Textures are looked up
  // by the drawn point's own direction (patch.vert), so the shift is seen only through heights:
  // above lattice point q + δ(q) the surface has the patch's height for q, and the terrain
  // H(q + δ). The term is max |H(q + δ(q)) − H(q)| over every lattice point the patch covers (δ
  // exact at the vertices, interpolated in between), plus each vertex's own height difference
  // (displacement quantisation and the tilt of the interpolated normal).
  {
    const double n = static_cast<double>(lattice.sideCells());
    const CubeFace face = cubeFaceFromIndex(t.face);
    std::vector<glm::dvec2> shift(patch.points.size());
    double vertexError = 0.0;
    for (std::size_t v = 0; v < patch.points.size(); ++v) {
      double drawnHeight = 0.0;
      glm::dvec3 direction;
      if (planet.isSphere()) {
        const double r = glm::length(rendered[v]);
        drawnHeight = r - planet.equatorialRadiusMeters();
        direction = rendered[v] / r;
      } else {
        const GeodeticPosition g = planet.ecefToGeodetic(rendered[v]);
        drawnHeight = g.heightMeters;
        direction = planet.geodeticToDirection(g.latDegrees, g.lonDegrees);
      }
      const LatticeXY q = patch.points[v];
      const glm::dvec2 qd(static_cast<double>(q.x), static_cast<double>(q.y));
      const std::optional<glm::dvec2> uv = CubeMap::directionToUvOnFace(face, direction);
      shift[v] = uv ? *uv * n - qd : glm::dvec2(0.0);
      vertexError = std::max(vertexError,
                             std::abs(drawnHeight - static_cast<double>(grid.height(t.face, q))));
    }
    double shiftError = 0.0;
    forEachLatticePointIn(patch, [&](std::uint32_t ia, std::uint32_t ib, std::uint32_t ic,
                                     LatticeXY q, double w0, double w1, double w2, double total) {
      const glm::dvec2 d = (w0 * shift[ia] + w1 * shift[ib] + w2 * shift[ic]) / total;
      const glm::dvec2 qd(static_cast<double>(q.x), static_cast<double>(q.y));
      shiftError = std::max(shiftError, std::abs(latticeHeightAt(grid, t.face, qd + d) -
                                                 static_cast<double>(grid.height(t.face, q))));
    });
    out.representationErrorMeters = vertexError + shiftError;
  }

  // Sample error: lattice samples, then the source DEM's own samples.
  double sampleError = maxLatticeDeviation(grid, t.face, patch);
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY la = patch.points[patch.indices[k]];
    const LatticeXY lb = patch.points[patch.indices[k + 1]];
    const LatticeXY lc = patch.points[patch.indices[k + 2]];
    const double ha = static_cast<double>(grid.height(t.face, la));
    const double hb = static_cast<double>(grid.height(t.face, lb));
    const double hc = static_cast<double>(grid.height(t.face, lc));
    grid.forEachSourceSampleIn(
        t.face, la, lb, lc, [&](double l0, double l1, double l2, const SourceSample& s) {
          const double hp = l0 * ha + l1 * hb + l2 * hc;
          sampleError = std::max(sampleError, std::abs(hp - static_cast<double>(s.heightMeters)));
        });
  }
  out.sampleErrorMeters = sampleError;
  out.errorMeters = out.sampleErrorMeters + out.representationErrorMeters + out.chordErrorMeters;
  return out;
}

}  // namespace pbdam::builder
