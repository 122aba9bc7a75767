// Patch measurement and conversion to the stored representation: exact barycentrics and the
// lattice height quantised to the height step, the sample, representation and chord errors,
// the bounding sphere (PatchBuilder.h; [P-BDAM 2003] §4.2; docs/builder.md "Errors").
#include <glm/common.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <span>

#include "DiamondBuilder.h"
#include "PatchBound.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/TerrainPoint.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {

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

/// Calls row(y, lo, hi, w) for every `rowStep`-th row y (multiples of it) holding lattice points
/// inside or on the counter-clockwise triangle (a, b, c): those of x in [lo, hi], where all three
/// edge functions doubleArea(edge, p) are ≥ 0 (each is linear in x along the row), and w their
/// values at lo (the integer barycentric weights); along the row they change by `step`.
template <class Row>
void forEachTriangleRow(LatticeXY a, LatticeXY b, LatticeXY c, int rowStep, Row&& row) {
  const int x0 = std::min({a.x, b.x, c.x});
  const int x1 = std::max({a.x, b.x, c.x});
  const int y0 = std::min({a.y, b.y, c.y});
  const int y1 = std::max({a.y, b.y, c.y});
  // doubleArea(q, r, p) grows by −(r.y − q.y) per step in x.
  const std::array<std::int64_t, 3> step = {-static_cast<std::int64_t>(c.y - b.y),
                                            -static_cast<std::int64_t>(a.y - c.y),
                                            -static_cast<std::int64_t>(b.y - a.y)};
  for (int y = (y0 + rowStep - 1) / rowStep * rowStep; y <= y1; y += rowStep) {
    std::int64_t lo = x0;
    std::int64_t hi = x1;
    clipSpan(step[0], doubleArea(b, c, LatticeXY{0, y}), lo, hi);
    clipSpan(step[1], doubleArea(c, a, LatticeXY{0, y}), lo, hi);
    clipSpan(step[2], doubleArea(a, b, LatticeXY{0, y}), lo, hi);
    if (lo > hi) continue;
    const LatticeXY first{static_cast<int>(lo), y};
    row(y, lo, hi,
        std::array<std::int64_t, 3>{doubleArea(b, c, first), doubleArea(c, a, first),
                                    doubleArea(a, b, first)},
        step);
  }
}

/// The largest |patch − lattice| over the lattice points inside or on triangle (a, b, c)
/// (counter-clockwise, positive doubled area `total`), whose corner heights are ha, hb, hc: the
/// patch's height at p is (w0·ha + w1·hb + w2·hc) / total with w the integer barycentric weights
/// of p (w0 + w1 + w2 = total). Along a row each weight changes by a constant integer step, so
/// the weights are exact and the sum is the same double at every point as a direct evaluation.
double triangleLatticeDeviation(const float* heights, std::size_t rowLength, LatticeXY a,
                                LatticeXY b, LatticeXY c, double ha, double hb, double hc,
                                std::int64_t total) noexcept {
  const double sum = static_cast<double>(total);
  double worst = 0.0;
  forEachTriangleRow(a, b, c, 1,
                     [&](int y, std::int64_t lo, std::int64_t hi, std::array<std::int64_t, 3> w,
                         const std::array<std::int64_t, 3>& step) {
                       const float* row = heights + static_cast<std::size_t>(y) * rowLength;
                       for (std::int64_t x = lo; x <= hi; ++x) {
                         assert(w[0] >= 0 && w[1] >= 0 && w[2] >= 0 && w[0] + w[1] + w[2] == total);
                         const double hp =
                             (static_cast<double>(w[0]) * ha + static_cast<double>(w[1]) * hb +
                              static_cast<double>(w[2]) * hc) /
                             sum;
                         worst = std::max(worst, std::abs(hp - static_cast<double>(row[x])));
                         w[0] += step[0];
                         w[1] += step[1];
                         w[2] += step[2];
                       }
                     });
  return worst;
}

/// triangleLatticeDeviation over the points a sparse lattice stores (each tile at its spacing;
/// rows between multiples of the finest spacing under the triangle hold none).
double triangleTiledDeviation(const FaceHeights& heights, LatticeXY a, LatticeXY b, LatticeXY c,
                              double ha, double hb, double hc, std::int64_t total,
                              std::int32_t spacing) noexcept {
  const double sum = static_cast<double>(total);
  const int rowStep =
      std::max(spacing, heights.tiles->finestSpacingIn(
                            heights.face, std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}),
                            std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y})));
  double worst = 0.0;
  // A triangle inside one tile reads its grid directly (the same points; LatticeTiles.h).
  const std::optional<LatticeTiles::Window> window = heights.tiles->windowHolding(
      heights.face, std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y}), std::max({a.x, b.x, c.x}),
      std::max({a.y, b.y, c.y}));
  forEachTriangleRow(
      a, b, c, rowStep,
      [&](int y, std::int64_t lo, std::int64_t hi, const std::array<std::int64_t, 3>& w,
          const std::array<std::int64_t, 3>& step) {
        if (window) {
          const std::int64_t stride = std::max<std::int64_t>(spacing, window->spacing);
          for (std::int64_t x = (lo + stride - 1) & ~(stride - 1); x <= hi; x += stride) {
            const std::int64_t dx = x - lo;
            const double hp = (static_cast<double>(w[0] + step[0] * dx) * ha +
                               static_cast<double>(w[1] + step[1] * dx) * hb +
                               static_cast<double>(w[2] + step[2] * dx) * hc) /
                              sum;
            worst =
                std::max(worst, std::abs(hp - static_cast<double>(window->at(heights.data, x, y))));
          }
          return;
        }
        heights.tiles->forEachInRow(
            heights.face, y, lo, hi, spacing, [&](std::int64_t x, std::uint64_t at) {
              const std::int64_t dx = x - lo;
              const double hp = (static_cast<double>(w[0] + step[0] * dx) * ha +
                                 static_cast<double>(w[1] + step[1] * dx) * hb +
                                 static_cast<double>(w[2] + step[2] * dx) * hc) /
                                sum;
              worst = std::max(worst, std::abs(hp - static_cast<double>(heights.data[at])));
            });
      });
  return worst;
}

/// Calls f(k, a, b, c) for every triangle k of `patch` with positive area, (a, b, c) its
/// corners and `total` its doubled area.
template <class F>
void forEachTriangle(const WorkPatch& patch, F&& f) {
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY a = patch.points[patch.indices[k]];
    const LatticeXY b = patch.points[patch.indices[k + 1]];
    const LatticeXY c = patch.points[patch.indices[k + 2]];
    const std::int64_t total = doubleArea(a, b, c);
    if (total > 0) f(k / 3, a, b, c, total);
  }
}

/// The largest |patch − lattice| over the lattice points of triangle k, for every k.
void latticeDeviations(const SampleGrid& grid, int face, const WorkPatch& patch,
                       std::vector<double>& error, std::int32_t spacing = 1) {
  if (!grid.tiles().isDense()) {
    const FaceHeights heights = grid.heightsOf(face);
    forEachTriangle(
        patch, [&](std::size_t k, LatticeXY a, LatticeXY b, LatticeXY c, std::int64_t total) {
          error[k] = std::max(
              error[k], triangleTiledDeviation(heights, a, b, c, static_cast<double>(heights.at(a)),
                                               static_cast<double>(heights.at(b)),
                                               static_cast<double>(heights.at(c)), total, spacing));
        });
    return;
  }
  const float* heights = grid.faceHeights(face);
  const std::size_t rowLength = std::size_t{grid.lattice().sideCells()} + 1;
  forEachTriangle(
      patch, [&](std::size_t k, LatticeXY a, LatticeXY b, LatticeXY c, std::int64_t total) {
        error[k] = std::max(
            error[k], triangleLatticeDeviation(heights, rowLength, a, b, c,
                                               static_cast<double>(grid.height(face, a)),
                                               static_cast<double>(grid.height(face, b)),
                                               static_cast<double>(grid.height(face, c)), total));
      });
}

}  // namespace

std::int32_t candidateSpacing(const SampleGrid& grid, const BinTriangle& t) {
  if (grid.tiles().isDense()) return 1;
  const std::int32_t extent = std::max(
      std::max({t.apex.x, t.left.x, t.right.x}) - std::min({t.apex.x, t.left.x, t.right.x}),
      std::max({t.apex.y, t.left.y, t.right.y}) - std::min({t.apex.y, t.left.y, t.right.y}));
  return static_cast<std::int32_t>(
      std::bit_floor(static_cast<std::uint32_t>(std::max(1, extent / 512))));
}

double maxLatticeDeviation(const SampleGrid& grid, int face, const WorkPatch& patch) {
  std::vector<double> error(patch.indices.size() / 3, 0.0);
  latticeDeviations(grid, face, patch, error);
  return error.empty() ? 0.0 : *std::max_element(error.begin(), error.end());
}

namespace {

/// The corner triangle of a node that a patch's barycentrics refer to: its legs in lattice
/// steps, its corner positions (the records' P_k) and canonical corner keys.
class CornerTriangle final {
 public:
  CornerTriangle(const SampleGrid& grid, const BinTriangle& t)
      : t_(t),
        e1_(t.left - t.apex),
        e2_(t.right - t.apex),
        len2_(static_cast<std::int64_t>(e1_.x) * e1_.x + static_cast<std::int64_t>(e1_.y) * e1_.y) {
    const NodeCorners corners = nodeCorners(grid, t);
    const std::array<LatticeXY, 3> xy{t.apex, t.left, t.right};
    for (std::size_t k = 0; k < 3; ++k) {
      positions_[k] = corners.positions[k];
      normals_[k] = corners.normals[k];
      keys_[k] = grid.lattice().key(t.face, xy[k]);
    }
  }

  /// The barycentric numerators of `p` along the legs apex→left and apex→right (over len2()).
  std::pair<std::int64_t, std::int64_t> numerators(LatticeXY p) const noexcept {
    const LatticeXY d = p - t_.apex;
    return {static_cast<std::int64_t>(d.x) * e1_.x + static_cast<std::int64_t>(d.y) * e1_.y,
            static_cast<std::int64_t>(d.x) * e2_.x + static_cast<std::int64_t>(d.y) * e2_.y};
  }
  std::int64_t len2() const noexcept { return len2_; }

  /// The flat point and interpolated normal the runtime splits the terrain point over
  /// (runtime::patchVertexBase, from the corners and normals the node record stores).
  PatchVertexBase base(std::uint16_t b1, std::uint16_t b2) const noexcept {
    return patchVertexBase(positions_, normals_, keys_, b1, b2);
  }

 private:
  BinTriangle t_;
  LatticeXY e1_;
  LatticeXY e2_;
  std::int64_t len2_;
  std::array<glm::dvec3, 3> positions_{};
  std::array<glm::vec3, 3> normals_{};
  std::array<PointKey, 3> keys_{};
};

/// Places every vertex of `patch`: its exact barycentrics and its lattice height quantised to
/// the height step in `out.mesh`, where it is drawn (its terrain point at that height, the
/// function the runtime decodes with) in `rendered`, and the patch's height range; copies the
/// indices. Returns the representation error (docs/builder.md "Errors"): the largest height
/// quantisation plus the largest float rounding of a GPU vertex's sideways offset
/// o = float(T − Pflat − h·N) (runtime/PatchDraw.h; each component rounds by at most 2^-24 of
/// itself, so the vector by at most 2^-24·|o|; h is exact in float or its rounding is in o).
double placeVertices(const SampleGrid& grid, const BinTriangle& t, const WorkPatch& patch,
                     double heightStepMeters, MeasuredPatch& out,
                     std::vector<glm::dvec3>& rendered) {
  const CornerTriangle corners(grid, t);
  const std::int64_t len2 = corners.len2();
  constexpr std::int64_t one = kPatchBarycentricOne;
  const Planet& planet = grid.planet();
  const std::uint32_t cells = grid.lattice().sideCells();
  out.mesh.vertices.resize(patch.points.size());
  rendered.resize(patch.points.size());
  double minH = std::numeric_limits<double>::infinity();
  double maxH = -std::numeric_limits<double>::infinity();
  double quantisation = 0.0;
  double offsetRounding = 0.0;
  for (std::size_t v = 0; v < patch.points.size(); ++v) {
    const LatticeXY p = patch.points[v];
    const auto [n1, n2] = corners.numerators(p);
    // b = n·2^15 / len2, both powers of two: divided first where the leg is longer than 2^15
    // steps (n·2^15 would overflow past 2^23 cells a face), the vertex then on the sub-lattice
    // the barycentrics address (the candidates' spacing, bit_floor(extent/512), ensures it).
    const auto barycentric = [&](std::int64_t n) {
      if (len2 >= one) {
        assert(n % (len2 / one) == 0);
        return n / (len2 / one);
      }
      assert((n * one) % len2 == 0);
      return n * one / len2;
    };
    const double height = static_cast<double>(grid.height(t.face, p));
    const double steps = std::round(height / heightStepMeters);
    const auto stepsInt = static_cast<std::int32_t>(std::clamp(steps, -2147483647.0, 2147483647.0));
    const double stored = static_cast<double>(stepsInt) * heightStepMeters;
    const PatchVertex vertex{static_cast<std::uint16_t>(barycentric(n1)),
                             static_cast<std::uint16_t>(barycentric(n2)), stepsInt};
    rendered[v] = latticeTerrainPoint(planet, cells, t.face, p, stored);
    out.mesh.vertices[v] = vertex;
    quantisation = std::max(quantisation, std::abs(stored - height));
    const PatchVertexBase base = corners.base(vertex.b1, vertex.b2);
    const PatchVertexDisplacement split =
        patchVertexDisplacement(base, rendered[v], heightStepMeters);
    offsetRounding = std::max(offsetRounding,
                              glm::length(rendered[v] - base.flat -
                                          static_cast<double>(split.heightMeters) * base.normal));
    minH = std::min(minH, height);
    maxH = std::max(maxH, height);
  }
  out.minHeightMeters = minH;
  out.maxHeightMeters = maxH;
  out.mesh.indices.resize(patch.indices.size());
  for (std::size_t k = 0; k < patch.indices.size(); ++k) {
    out.mesh.indices[k] = static_cast<std::uint16_t>(patch.indices[k]);
  }
  return quantisation + std::ldexp(offsetRounding, -24);
}

/// Bounding sphere of the rendered vertices (box centre; deterministic).
void boundingSphere(const std::vector<glm::dvec3>& rendered, MeasuredPatch& out) {
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
}

/// Chord bound of each triangle: a flat triangle between three points of a sphere of radius R
/// sags below it by (rc² − ρ²)/(2R) at distance ρ from its circumcentre (rc the circumradius):
/// at most rc²/(2R) where the circumcentre is inside (acute triangles), else c²/(8R) at the
/// midpoint of the longest edge c. (The longest-edge bound alone is 3/4 of the truth for an
/// equilateral triangle.) Below, `worst` is 4rc² or c², so the bound is worst/(8R).
std::vector<double> chordErrors(const SampleGrid& grid, const WorkPatch& patch,
                                const std::vector<glm::dvec3>& rendered) {
  const Planet& planet = grid.planet();
  const double rMin =
      std::max(1.0, planet.polarRadiusMeters() + static_cast<double>(grid.minHeightMeters()));
  std::vector<double> sag(patch.indices.size() / 3);
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
    const double worst = acute ? 4.0 * sq[0] * sq[1] * sq[2] / area16 : sq[2];
    sag[k / 3] = worst / (8.0 * rMin);
  }
  return sag;
}

/// The triangles' bounding boxes' areas together, in lattice cells (each at least one cell a
/// side: a triangle's walk reads at least the bucket it lies in).
std::int64_t boxCells(std::span<const std::array<LatticeXY, 3>> triangles) noexcept {
  std::int64_t cells = 0;
  for (const auto& c : triangles) {
    const std::int64_t w = std::max({c[0].x, c[1].x, c[2].x}) - std::min({c[0].x, c[1].x, c[2].x});
    const std::int64_t h = std::max({c[0].y, c[1].y, c[2].y}) - std::min({c[0].y, c[1].y, c[2].y});
    cells += std::max<std::int64_t>(w, 1) * std::max<std::int64_t>(h, 1);
  }
  return cells;
}

/// Triangles are walked one by one (each over the buckets of its box) while their boxes cover
/// less than this fraction of the patch's: a box holds about twice its triangle's samples, and
/// the binned walk reads every sample under the patch once, with a dearer test per sample.
constexpr std::int64_t kBinnedWalkShare = 4;

/// Sample error of each triangle: the largest |patch − sample| over the lattice samples and the
/// source DEM's own samples inside or on it.
std::vector<double> sampleErrors(const SampleGrid& grid, const BinTriangle& t,
                                 const WorkPatch& patch) {
  const int face = t.face;
  const std::size_t count = patch.indices.size() / 3;
  std::vector<double> error(count, 0.0);
  // A triangle of doubled area 1 (half a lattice cell) covers only its corners, where the patch
  // is exact: only larger ones need the lattice scan. Source samples are read once per patch
  // and tested against the triangles near each.
  std::vector<std::array<LatticeXY, 3>> corners(count);
  bool unitTriangles = true;
  for (std::size_t k = 0; k < count; ++k) {
    corners[k] = {patch.points[patch.indices[3 * k]], patch.points[patch.indices[3 * k + 1]],
                  patch.points[patch.indices[3 * k + 2]]};
    unitTriangles = unitTriangles && doubleArea(corners[k][0], corners[k][1], corners[k][2]) == 1;
  }
  if (!unitTriangles) latticeDeviations(grid, face, patch, error, candidateSpacing(grid, t));
  std::vector<std::array<double, 3>> heights(count);
  for (std::size_t k = 0; k < count; ++k) {
    for (std::size_t c = 0; c < 3; ++c)
      heights[k][c] = static_cast<double>(grid.height(face, corners[k][c]));
  }
  auto visit = [&](std::size_t k, double l0, double l1, double l2, const SourceSample& s) {
    const double hp = l0 * heights[k][0] + l1 * heights[k][1] + l2 * heights[k][2];
    error[k] = std::max(error[k], std::abs(hp - static_cast<double>(s.heightMeters)));
  };
  // A few triangles of a large patch (those whose bound through the children left doubt) read
  // only the buckets under each of them: the binned walk reads every sample under the outline,
  // which for a scattered tenth of the triangles is most of the work. Both make the same visits
  // (forEachSourceSampleInTriangles is forEachSourceSampleIn of each triangle), so the errors are
  // the same either way.
  const std::array<std::array<LatticeXY, 3>, 1> outline = {{{t.apex, t.left, t.right}}};
  if (boxCells(corners) * kBinnedWalkShare < boxCells(outline)) {
    for (std::size_t k = 0; k < count; ++k) {
      grid.forEachSourceSampleIn(
          face, corners[k][0], corners[k][1], corners[k][2],
          [&](double l0, double l1, double l2, const SourceSample& s) { visit(k, l0, l1, l2, s); });
    }
    return error;
  }
  if (unitTriangles) {
    grid.forEachSourceSampleInCells(face, {t.apex, t.left, t.right}, corners, visit);
    return error;
  }
  grid.forEachSourceSampleInTriangles(face, {t.apex, t.left, t.right}, corners, visit);
  return error;
}

}  // namespace

namespace {

/// The patch error from its per-triangle sample errors (docs/builder.md "Errors"): a point of
/// triangle k is off the terrain by at most its sample error plus k's sag, so the two terms add
/// per triangle, not as the patch's two maxima.
void combine(const std::vector<double>& sample, const std::vector<double>& sag,
             MeasuredPatch& out) {
  double worst = 0.0;
  out.triangleSampleErrors.resize(sag.size());
  for (std::size_t k = 0; k < sag.size(); ++k) {
    out.chordErrorMeters = std::max(out.chordErrorMeters, sag[k]);
    out.sampleErrorMeters = std::max(out.sampleErrorMeters, sample[k]);
    out.triangleSampleErrors[k] = roundUpToFloat(sample[k]);
    worst = std::max(worst, sample[k] + sag[k]);
  }
  out.errorMeters = worst + out.representationErrorMeters;
}

}  // namespace

MeasuredPatch measurePatch(const SampleGrid& grid, const BinTriangle& t, const WorkPatch& patch,
                           double heightStepMeters) {
  MeasuredPatch out;
  std::vector<glm::dvec3> rendered;
  out.representationErrorMeters = placeVertices(grid, t, patch, heightStepMeters, out, rendered);
  boundingSphere(rendered, out);
  const std::vector<double> sag = chordErrors(grid, patch, rendered);
  const std::vector<double> sample = sampleErrors(grid, t, patch);
  out.trianglesMeasuredAgainstSamples = static_cast<std::uint32_t>(sag.size());
  combine(sample, sag, out);
  return out;
}

MeasuredPatch measurePatchFromChildren(const SampleGrid& grid, const BinTriangle& t,
                                       const WorkPatch& patch,
                                       const std::array<const WorkPatch*, 2>& children,
                                       double heightStepMeters, double targetMeters) {
  MeasuredPatch out;
  std::vector<glm::dvec3> rendered;
  out.representationErrorMeters = placeVertices(grid, t, patch, heightStepMeters, out, rendered);
  boundingSphere(rendered, out);
  const std::vector<double> sag = chordErrors(grid, patch, rendered);
  std::vector<double> sample = childBoundedSampleErrors(grid.heightsOf(t.face), patch, children);
  if (sample.empty()) {
    sample = sampleErrors(grid, t, patch);  // a child without bounds: measure it all
    out.trianglesMeasuredAgainstSamples = static_cast<std::uint32_t>(sag.size());
    combine(sample, sag, out);
    return out;
  }
  // Where the bound would lift the diamond's error above what it stores anyway, the samples
  // decide: those triangles alone are measured, and the smaller of the two bounds is kept.
  WorkPatch doubtful;
  doubtful.points = patch.points;
  std::vector<std::size_t> which;
  for (std::size_t k = 0; k < sag.size(); ++k) {
    if (sample[k] + sag[k] + out.representationErrorMeters <= targetMeters) continue;
    which.push_back(k);
    doubtful.indices.insert(doubtful.indices.end(),
                            patch.indices.begin() + static_cast<std::ptrdiff_t>(3 * k),
                            patch.indices.begin() + static_cast<std::ptrdiff_t>(3 * k + 3));
  }
  if (!which.empty()) {
    const std::vector<double> exact = sampleErrors(grid, t, doubtful);
    for (std::size_t j = 0; j < which.size(); ++j) {
      sample[which[j]] = std::min(sample[which[j]], exact[j]);
    }
  }
  out.trianglesMeasuredAgainstSamples = static_cast<std::uint32_t>(which.size());
  combine(sample, sag, out);
  return out;
}

}  // namespace pbdam::builder
