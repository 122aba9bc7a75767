// Patch measurement and conversion to the stored representation: exact barycentrics,
// displacement along the interpolated normal, the sample, representation and chord errors,
// the bounding sphere (PatchBuilder.h; paper 004 §4.2; docs/builder.md "Errors").
#include <glm/common.hpp>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>

#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/runtime/CubeMap.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {

namespace {

/// Position data of one corner or edge endpoint, in double.
struct CornerData {
  glm::dvec3 position;
  glm::dvec3 normal;
};

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

namespace {

/// The flat corner triangle of a node that a patch's vertices are placed on: corner positions
/// and normals, the legs in lattice steps, and the lattice points' barycentrics on it.
class CornerTriangle final {
 public:
  CornerTriangle(const SampleGrid& grid, const BinTriangle& t)
      : lattice_(grid.lattice()),
        t_(t),
        cornerXY_{t.apex, t.left, t.right},
        e1_(t.left - t.apex),
        e2_(t.right - t.apex),
        len2_(static_cast<std::int64_t>(e1_.x) * e1_.x + static_cast<std::int64_t>(e1_.y) * e1_.y) {
    const NodeCorners corners = nodeCorners(grid, t);
    for (std::size_t k = 0; k < 3; ++k) {
      cd_[k] = CornerData{corners.positions[k], glm::dvec3(corners.normals[k])};
    }
  }

  /// The barycentric numerators of `p` along the legs apex→left and apex→right (over len2()).
  std::pair<std::int64_t, std::int64_t> numerators(LatticeXY p) const noexcept {
    const LatticeXY d = p - t_.apex;
    return {static_cast<std::int64_t>(d.x) * e1_.x + static_cast<std::int64_t>(d.y) * e1_.y,
            static_cast<std::int64_t>(d.x) * e2_.x + static_cast<std::int64_t>(d.y) * e2_.y};
  }
  std::int64_t len2() const noexcept { return len2_; }

  /// The point of the flat triangle and the interpolated normal at numerators (n1, n2).
  void flatPointAndNormal(std::int64_t n1, std::int64_t n2, glm::dvec3& pflat,
                          glm::dvec3& nb) const {
    if (n2 == 0) {
      edgePoint(0, 1, n1, pflat, nb);  // apex–left
    } else if (n1 == 0) {
      edgePoint(0, 2, n2, pflat, nb);  // apex–right
    } else if (n1 + n2 == len2_) {
      edgePoint(1, 2, n2, pflat, nb);  // left–right
    } else {
      const double b1 = static_cast<double>(n1) / static_cast<double>(len2_);
      const double b2 = static_cast<double>(n2) / static_cast<double>(len2_);
      pflat = cd_[0].position + b1 * (cd_[1].position - cd_[0].position) +
              b2 * (cd_[2].position - cd_[0].position);
      nb = cd_[0].normal + b1 * (cd_[1].normal - cd_[0].normal) +
           b2 * (cd_[2].normal - cd_[0].normal);
    }
  }

 private:
  /// Data of an edge endpoint pair in canonical key order (so both patches on the edge compute
  /// the same numbers) and the parameter from the first.
  void edgePoint(std::size_t from, std::size_t to, std::int64_t numerator, glm::dvec3& pflat,
                 glm::dvec3& nb) const {
    std::size_t first = from;
    std::size_t second = to;
    std::int64_t num = numerator;
    if (lattice_.key(t_.face, cornerXY_[from]) > lattice_.key(t_.face, cornerXY_[to])) {
      std::swap(first, second);
      num = len2_ - numerator;
    }
    if (num == 0) {
      pflat = cd_[first].position;
      nb = cd_[first].normal;
    } else if (num == len2_) {
      pflat = cd_[second].position;
      nb = cd_[second].normal;
    } else {
      const double s = static_cast<double>(num) / static_cast<double>(len2_);
      pflat = cd_[first].position + s * (cd_[second].position - cd_[first].position);
      nb = cd_[first].normal + s * (cd_[second].normal - cd_[first].normal);
    }
  }

  const Lattice& lattice_;
  BinTriangle t_;
  std::array<LatticeXY, 3> cornerXY_;
  std::array<CornerData, 3> cd_;
  LatticeXY e1_;
  LatticeXY e2_;
  std::int64_t len2_;
};

/// Places every vertex of `patch`: its exact barycentrics and quantised displacement in
/// `out.mesh`, where it is drawn in `rendered`, and the patch's height range; copies the indices.
void placeVertices(const SampleGrid& grid, const BinTriangle& t, const WorkPatch& patch,
                   double heightStepMeters, MeasuredPatch& out, std::vector<glm::dvec3>& rendered) {
  const CornerTriangle corners(grid, t);
  const std::int64_t len2 = corners.len2();
  constexpr std::int64_t one = kPatchBarycentricOne;
  out.mesh.vertices.resize(patch.points.size());
  rendered.resize(patch.points.size());
  double minH = std::numeric_limits<double>::infinity();
  double maxH = -std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < patch.points.size(); ++v) {
    const LatticeXY p = patch.points[v];
    const auto [n1, n2] = corners.numerators(p);
    assert((n1 * one) % len2 == 0 && (n2 * one) % len2 == 0);
    glm::dvec3 pflat;
    glm::dvec3 nb;
    corners.flatPointAndNormal(n1, n2, pflat, nb);
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

/// Chord bound: a flat triangle between three points of a sphere of radius R sags below it by
/// (rc² − ρ²)/(2R) at distance ρ from its circumcentre (rc the circumradius): at most rc²/(2R)
/// where the circumcentre is inside (acute triangles), else c²/(8R) at the midpoint of the
/// longest edge c. (The longest-edge bound alone is 3/4 of the truth for an equilateral
/// triangle.) Below, `worst` is 4rc² or c², so the bound is worst/(8R).
double chordError(const SampleGrid& grid, const WorkPatch& patch,
                  const std::vector<glm::dvec3>& rendered) {
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
  return worst / (8.0 * rMin);
}

/// For each vertex, the lattice shift δ of where it is drawn (in cells); returns the largest
/// difference between a vertex's drawn height and its lattice height.
double vertexShifts(const SampleGrid& grid, int faceIndex, const WorkPatch& patch,
                    const std::vector<glm::dvec3>& rendered, std::vector<glm::dvec2>& shift) {
  const Planet& planet = grid.planet();
  const double n = static_cast<double>(grid.lattice().sideCells());
  const CubeFace face = cubeFaceFromIndex(faceIndex);
  shift.resize(patch.points.size());
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
                           std::abs(drawnHeight - static_cast<double>(grid.height(faceIndex, q))));
  }
  return vertexError;
}

/// Representation error (docs/builder.md "Errors"). A vertex is drawn at its lattice
/// barycentrics on the flat corner triangle, displaced along the interpolated normal: on the
/// tangent-adjusted cube map that lands beside its lattice point, by a shift δ that is smooth
/// over the patch (kilometres on coarse patches, zero at the corners). Textures are looked up
/// by the drawn point's own direction (patch.vert), so the shift is seen only through heights:
/// above lattice point q + δ(q) the surface has the patch's height for q, and the terrain
/// H(q + δ). The term is max |H(q + δ(q)) − H(q)| over every lattice point the patch covers (δ
/// exact at the vertices, interpolated in between), plus each vertex's own height difference
/// (displacement quantisation and the tilt of the interpolated normal).
double representationError(const SampleGrid& grid, int face, const WorkPatch& patch,
                           const std::vector<glm::dvec3>& rendered) {
  std::vector<glm::dvec2> shift;
  const double vertexError = vertexShifts(grid, face, patch, rendered, shift);
  double shiftError = 0.0;
  forEachLatticePointIn(patch, [&](std::uint32_t ia, std::uint32_t ib, std::uint32_t ic,
                                   LatticeXY q, double w0, double w1, double w2, double total) {
    const glm::dvec2 d = (w0 * shift[ia] + w1 * shift[ib] + w2 * shift[ic]) / total;
    const glm::dvec2 qd(static_cast<double>(q.x), static_cast<double>(q.y));
    shiftError = std::max(shiftError, std::abs(latticeHeightAt(grid, face, qd + d) -
                                               static_cast<double>(grid.height(face, q))));
  });
  return vertexError + shiftError;
}

/// Sample error: lattice samples, then the source DEM's own samples.
double sampleError(const SampleGrid& grid, int face, const WorkPatch& patch) {
  double error = maxLatticeDeviation(grid, face, patch);
  for (std::size_t k = 0; k < patch.indices.size(); k += 3) {
    const LatticeXY la = patch.points[patch.indices[k]];
    const LatticeXY lb = patch.points[patch.indices[k + 1]];
    const LatticeXY lc = patch.points[patch.indices[k + 2]];
    const double ha = static_cast<double>(grid.height(face, la));
    const double hb = static_cast<double>(grid.height(face, lb));
    const double hc = static_cast<double>(grid.height(face, lc));
    grid.forEachSourceSampleIn(
        face, la, lb, lc, [&](double l0, double l1, double l2, const SourceSample& s) {
          const double hp = l0 * ha + l1 * hb + l2 * hc;
          error = std::max(error, std::abs(hp - static_cast<double>(s.heightMeters)));
        });
  }
  return error;
}

}  // namespace

MeasuredPatch measurePatch(const SampleGrid& grid, const BinTriangle& t, const WorkPatch& patch,
                           double heightStepMeters) {
  MeasuredPatch out;
  std::vector<glm::dvec3> rendered;
  placeVertices(grid, t, patch, heightStepMeters, out, rendered);
  boundingSphere(rendered, out);
  out.chordErrorMeters = chordError(grid, patch, rendered);
  out.representationErrorMeters = representationError(grid, t.face, patch, rendered);
  out.sampleErrorMeters = sampleError(grid, t.face, patch);
  out.errorMeters = out.sampleErrorMeters + out.representationErrorMeters + out.chordErrorMeters;
  return out;
}

}  // namespace pbdam::builder
