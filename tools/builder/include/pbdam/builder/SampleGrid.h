// The DEM resampled onto the cube-map lattice (paper 004 §5 "Data preparation and resampling"):
// one height per lattice point of every face, terrain positions and normals derived from them,
// and the source DEM's own samples bucketed by face cell so that patch errors can be measured
// against the original data. Thread-safety: immutable after build(); const members are safe from
// any thread.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <span>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// A source DEM sample placed on a face: (u, v) on that face and its height.
struct SourceSample final {
  float u = 0.0f;
  float v = 0.0f;
  float heightMeters = 0.0f;
};

/// A share of the resampling for a distributed build: this process resamples the lattice rows
/// [beginRow, endRow) of the 6·(N+1) rows (face-major: row r is row r mod (N+1) of face
/// r / (N+1)); `exchange(heights, noDataPoints)` then receives the per-face height arrays with
/// those rows filled and this process's no-data count, and must fill in every other row and
/// make the count the total (docs/builder.md "Distributed build").
struct RowShare final {
  std::size_t beginRow = 0;
  std::size_t endRow = 0;
  std::function<void(std::vector<std::vector<float>>& heights, std::uint64_t& noDataPoints)>
      exchange;
};

class SampleGrid final {
 public:
  /// Resamples `dem` (bicubic, bilinear where bicubic lacks data, 0 m where the DEM has none) at
  /// every lattice point of every face, in parallel, and buckets the DEM's valid samples into
  /// `bucketCells`-sized squares of each face. `progress(done, total)` is called from the calling
  /// thread only. With `share`, only its rows are resampled here and the rest come from its
  /// exchange; every value depends only on its own inputs, so the grid is the same either way.
  static SampleGrid build(const HeightGrid& dem, const Planet& planet, const Lattice& lattice,
                          std::uint32_t bucketCells,
                          const std::function<void(std::size_t, std::size_t)>& progress = {},
                          const RowShare* share = nullptr);

  /// The bucket size that keeps buckets about a lattice cell wide (a patch triangle then tests
  /// only the source samples near it) while bounding the bucket table to 1024² per face.
  static std::uint32_t defaultBucketCells(const Lattice& lattice) noexcept {
    return std::max<std::uint32_t>(1, lattice.sideCells() / 1024);
  }

  const Lattice& lattice() const noexcept { return lattice_; }
  const Planet& planet() const noexcept { return planet_; }

  /// Height of lattice point p of `face` (equal on every face sharing the point).
  float height(int face, LatticeXY p) const noexcept {
    const auto n1 = static_cast<std::size_t>(lattice_.sideCells()) + 1;
    return heights_[static_cast<std::size_t>(face)]
                   [static_cast<std::size_t>(p.y) * n1 + static_cast<std::size_t>(p.x)];
  }
  /// The terrain point (planetocentric, metres) of lattice point p: the surface point of its
  /// direction raised by its height along the surface normal. Bit-identical on every face.
  glm::dvec3 terrainPoint(int face, LatticeXY p) const noexcept;
  /// The terrain point of a direction at a given height.
  glm::dvec3 terrainPoint(const glm::dvec3& direction, double heightMeters) const noexcept;
  /// The planet's unit surface normal at lattice point p. Bit-identical on every face.
  glm::dvec3 surfaceNormal(int face, LatticeXY p) const noexcept;

  /// Source samples of `face` in bucket (bx, by), bx, by in [0, bucketsPerSide()).
  std::uint32_t bucketsPerSide() const noexcept { return bucketsPerSide_; }
  std::uint32_t bucketCells() const noexcept { return bucketCells_; }
  std::span<const SourceSample> bucket(int face, std::uint32_t bx, std::uint32_t by) const noexcept;
  std::size_t sourceSampleCount() const noexcept;

  /// Calls fn(l0, l1, l2, sample) for every source sample inside or on the counter-clockwise
  /// (u,v) triangle (a, b, c) of `face`, with (l0, l1, l2) its barycentric weights (summing to
  /// 1). Degenerate or clockwise triangles visit nothing.
  template <typename Fn>
  void forEachSourceSampleIn(int face, glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, Fn&& fn) const {
    const double total = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(total > 0.0)) return;
    const double eps = -1e-9 * total;
    const double scale = static_cast<double>(lattice_.sideCells()) / bucketCells_;
    const double last = static_cast<double>(bucketsPerSide_ - 1);
    auto bucketOf = [&](double x) {
      return static_cast<std::uint32_t>(std::clamp(std::floor(x * scale), 0.0, last));
    };
    const std::uint32_t bx0 = bucketOf(std::min({a.x, b.x, c.x}));
    const std::uint32_t bx1 = bucketOf(std::max({a.x, b.x, c.x}));
    const std::uint32_t by0 = bucketOf(std::min({a.y, b.y, c.y}));
    const std::uint32_t by1 = bucketOf(std::max({a.y, b.y, c.y}));
    for (std::uint32_t by = by0; by <= by1; ++by) {
      for (std::uint32_t bx = bx0; bx <= bx1; ++bx) {
        for (const SourceSample& s : bucket(face, bx, by)) {
          const double px = static_cast<double>(s.u);
          const double py = static_cast<double>(s.v);
          const double w0 = (c.x - b.x) * (py - b.y) - (c.y - b.y) * (px - b.x);
          const double w1 = (a.x - c.x) * (py - c.y) - (a.y - c.y) * (px - c.x);
          const double w2 = (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
          if (w0 < eps || w1 < eps || w2 < eps) continue;
          fn(w0 / total, w1 / total, w2 / total, s);
        }
      }
    }
  }

  /// Lattice points where the DEM had no data (given height 0).
  std::uint64_t noDataPoints() const noexcept { return noDataPoints_; }
  float minHeightMeters() const noexcept { return minHeight_; }
  float maxHeightMeters() const noexcept { return maxHeight_; }

 private:
  SampleGrid(const Lattice& lattice, const Planet& planet) : lattice_(lattice), planet_(planet) {}
  Lattice lattice_;
  Planet planet_;
  std::vector<std::vector<float>> heights_;  // per face, (N+1)² row-major by j
  std::uint32_t bucketCells_ = 1;
  std::uint32_t bucketsPerSide_ = 1;
  std::vector<std::vector<std::uint32_t>> bucketStart_;  // per face, CSR offsets
  std::vector<std::vector<SourceSample>> samples_;       // per face, grouped by bucket
  std::uint64_t noDataPoints_ = 0;
  float minHeight_ = 0.0f;
  float maxHeight_ = 0.0f;
};

}  // namespace pbdam::builder
