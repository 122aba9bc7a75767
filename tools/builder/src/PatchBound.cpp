// A parent's sample error bounded through its children (PatchBound.h).
#include "PatchBound.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

struct ChildTriangle {
  std::array<LatticeXY, 3> p;  // counter-clockwise
  std::array<double, 3> h;     // lattice heights
  double errorMeters;
  LatticeXY lo{0};  // box
  LatticeXY hi{0};
};

/// Whether the interiors of two counter-clockwise triangles meet: no edge line of either has
/// the other triangle wholly on its outer closed side (the separating axis test, exact).
bool interiorsMeet(const std::array<LatticeXY, 3>& a, const std::array<LatticeXY, 3>& b) noexcept {
  const auto separates = [](const std::array<LatticeXY, 3>& s, const std::array<LatticeXY, 3>& o) {
    for (std::size_t k = 0; k < 3; ++k) {
      const LatticeXY from = s[k];
      const LatticeXY to = s[(k + 1) % 3];
      if (doubleArea(from, to, o[0]) <= 0 && doubleArea(from, to, o[1]) <= 0 &&
          doubleArea(from, to, o[2]) <= 0) {
        return true;
      }
    }
    return false;
  };
  return !separates(a, b) && !separates(b, a);
}

/// The child triangles bucketed by box in square cells (a power of two of lattice steps).
class ChildIndex final {
 public:
  explicit ChildIndex(std::vector<ChildTriangle> tris) : tris_(std::move(tris)) {
    x0_ = y0_ = std::numeric_limits<std::int32_t>::max();
    std::int32_t x1 = 0;
    std::int32_t y1 = 0;
    for (const ChildTriangle& t : tris_) {
      for (const LatticeXY p : t.p) {
        x0_ = std::min(x0_, p.x);
        y0_ = std::min(y0_, p.y);
        x1 = std::max(x1, p.x);
        y1 = std::max(y1, p.y);
      }
    }
    if (tris_.empty()) return;
    const double area =
        (static_cast<double>(x1 - x0_) + 1.0) * (static_cast<double>(y1 - y0_) + 1.0);
    while (shift_ < 30 &&
           area / std::ldexp(1.0, 2 * (shift_ + 1)) >= static_cast<double>(tris_.size())) {
      ++shift_;
    }
    columns_ = ((x1 - x0_) >> shift_) + 1;
    rows_ = ((y1 - y0_) >> shift_) + 1;
    start_.assign(static_cast<std::size_t>(columns_) * static_cast<std::size_t>(rows_) + 1, 0);
    forEachCellOf([&](std::size_t cell, std::uint32_t) { ++start_[cell + 1]; });
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    entries_.resize(start_.back());
    std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
    forEachCellOf([&](std::size_t cell, std::uint32_t t) { entries_[fill[cell]++] = t; });
    stamp_.assign(tris_.size(), 0);
  }

  /// Calls f(child) once for every child triangle whose box meets the box of `p`.
  template <class F>
  void forEachNear(const std::array<LatticeXY, 3>& p, F&& f) {
    if (tris_.empty()) return;
    ++visit_;
    const auto [c0, r0, c1, r1] = cellsOf(p);
    for (std::int32_t r = r0; r <= r1; ++r) {
      for (std::int32_t c = c0; c <= c1; ++c) {
        const std::size_t cell = static_cast<std::size_t>(r) * static_cast<std::size_t>(columns_) +
                                 static_cast<std::size_t>(c);
        for (std::uint32_t k = start_[cell]; k < start_[cell + 1]; ++k) {
          const std::uint32_t t = entries_[k];
          if (stamp_[t] == visit_) continue;
          stamp_[t] = visit_;
          f(tris_[t]);
        }
      }
    }
  }

 private:
  std::array<std::int32_t, 4> cellsOf(const std::array<LatticeXY, 3>& p) const noexcept {
    const std::int32_t xMin = std::min({p[0].x, p[1].x, p[2].x});
    const std::int32_t yMin = std::min({p[0].y, p[1].y, p[2].y});
    const std::int32_t xMax = std::max({p[0].x, p[1].x, p[2].x});
    const std::int32_t yMax = std::max({p[0].y, p[1].y, p[2].y});
    return {std::clamp(xMin - x0_, 0, (columns_ << shift_) - 1) >> shift_,
            std::clamp(yMin - y0_, 0, (rows_ << shift_) - 1) >> shift_,
            std::clamp(xMax - x0_, 0, (columns_ << shift_) - 1) >> shift_,
            std::clamp(yMax - y0_, 0, (rows_ << shift_) - 1) >> shift_};
  }
  template <class F>
  void forEachCellOf(F&& f) const {
    for (std::uint32_t t = 0; t < tris_.size(); ++t) {
      const auto [c0, r0, c1, r1] = cellsOf(tris_[t].p);
      for (std::int32_t r = r0; r <= r1; ++r) {
        for (std::int32_t c = c0; c <= c1; ++c) {
          f(static_cast<std::size_t>(r) * static_cast<std::size_t>(columns_) +
                static_cast<std::size_t>(c),
            t);
        }
      }
    }
  }

  std::vector<ChildTriangle> tris_;
  std::vector<std::uint32_t> start_;
  std::vector<std::uint32_t> entries_;
  std::vector<std::uint32_t> stamp_;
  std::uint32_t visit_ = 0;
  std::int32_t x0_ = 0;
  std::int32_t y0_ = 0;
  std::int32_t columns_ = 0;
  std::int32_t rows_ = 0;
  int shift_ = 0;
};

}  // namespace

std::vector<double> childBoundedSampleErrors(const FaceHeights& heights, const WorkPatch& patch,
                                             std::span<const WorkPatch* const> children) {
  std::vector<ChildTriangle> tris;
  for (const WorkPatch* child : children) {
    if (child->sampleErrorMeters.size() != child->indices.size() / 3) return {};
    std::vector<double> h(child->points.size());
    for (std::size_t v = 0; v < h.size(); ++v)
      h[v] = static_cast<double>(heights.at(child->points[v]));
    for (std::size_t k = 0; k + 2 < child->indices.size(); k += 3) {
      ChildTriangle t{};
      for (std::size_t c = 0; c < 3; ++c) {
        t.p[c] = child->points[child->indices[k + c]];
        t.h[c] = h[child->indices[k + c]];
      }
      const std::int64_t area = doubleArea(t.p[0], t.p[1], t.p[2]);
      if (area == 0) continue;  // covers no area: its points are on the others' edges
      if (area < 0) {
        std::swap(t.p[1], t.p[2]);
        std::swap(t.h[1], t.h[2]);
      }
      t.errorMeters = static_cast<double>(child->sampleErrorMeters[k / 3]);
      t.lo = LatticeXY{std::min({t.p[0].x, t.p[1].x, t.p[2].x}),
                       std::min({t.p[0].y, t.p[1].y, t.p[2].y})};
      t.hi = LatticeXY{std::max({t.p[0].x, t.p[1].x, t.p[2].x}),
                       std::max({t.p[0].y, t.p[1].y, t.p[2].y})};
      tris.push_back(t);
    }
  }
  ChildIndex index(std::move(tris));
  std::vector<double> bound(patch.indices.size() / 3, std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k + 2 < patch.indices.size(); k += 3) {
    std::array<LatticeXY, 3> p = {patch.points[patch.indices[k]],
                                  patch.points[patch.indices[k + 1]],
                                  patch.points[patch.indices[k + 2]]};
    const std::int64_t total = doubleArea(p[0], p[1], p[2]);
    if (total <= 0) {
      bound[k / 3] = 0.0;  // no area: measurePatch skips it too
      continue;
    }
    const std::array<double, 3> hp = {static_cast<double>(heights.at(p[0])),
                                      static_cast<double>(heights.at(p[1])),
                                      static_cast<double>(heights.at(p[2]))};
    const double sum = static_cast<double>(total);
    // T's plane at q, extended beyond T: exact integer barycentric weights (negative outside).
    const auto plane = [&](LatticeXY q) {
      return (static_cast<double>(doubleArea(p[1], p[2], q)) * hp[0] +
              static_cast<double>(doubleArea(p[2], p[0], q)) * hp[1] +
              static_cast<double>(doubleArea(p[0], p[1], q)) * hp[2]) /
             sum;
    };
    const LatticeXY lo{std::min({p[0].x, p[1].x, p[2].x}), std::min({p[0].y, p[1].y, p[2].y})};
    const LatticeXY hi{std::max({p[0].x, p[1].x, p[2].x}), std::max({p[0].y, p[1].y, p[2].y})};
    double worst = -1.0;
    index.forEachNear(p, [&](const ChildTriangle& t) {
      // Boxes that only touch leave the interiors apart.
      if (t.hi.x <= lo.x || t.lo.x >= hi.x || t.hi.y <= lo.y || t.lo.y >= hi.y) return;
      if (!interiorsMeet(p, t.p)) return;
      double e = 0.0;
      for (std::size_t c = 0; c < 3; ++c) e = std::max(e, std::abs(plane(t.p[c]) - t.h[c]));
      worst = std::max(worst, e + t.errorMeters);
    });
    if (worst >= 0.0) bound[k / 3] = worst;
  }
  return bound;
}

}  // namespace pbdam::builder
