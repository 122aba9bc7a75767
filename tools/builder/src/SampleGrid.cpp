// Resampling of the DEM onto the cube-map lattice and bucketing of the source samples
// (SampleGrid.h). Parallel over rows with TBB; every value depends only on its own inputs, so
// the result is the same for any thread count.
#include "pbdam/builder/SampleGrid.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace pbdam::builder {

glm::dvec3 SampleGrid::terrainPoint(const glm::dvec3& direction,
                                    double heightMeters) const noexcept {
  if (planet_.isSphere()) {
    return (planet_.equatorialRadiusMeters() + heightMeters) * direction;
  }
  const GeodeticPosition g = planet_.directionToGeodetic(direction);
  return planet_.geodeticToEcef(g.latDegrees, g.lonDegrees, heightMeters);
}

glm::dvec3 SampleGrid::terrainPoint(int face, LatticeXY p) const noexcept {
  return terrainPoint(lattice_.direction(face, p), static_cast<double>(height(face, p)));
}

glm::dvec3 SampleGrid::surfaceNormal(int face, LatticeXY p) const noexcept {
  const glm::dvec3 d = lattice_.direction(face, p);
  if (planet_.isSphere()) return d;
  const GeodeticPosition g = planet_.directionToGeodetic(d);
  return planet_.surfaceNormal(g.latDegrees, g.lonDegrees);
}

std::span<const SourceSample> SampleGrid::bucket(int face, std::uint32_t bx,
                                                 std::uint32_t by) const noexcept {
  const auto& start = bucketStart_[static_cast<std::size_t>(face)];
  const std::size_t b = static_cast<std::size_t>(by) * bucketsPerSide_ + bx;
  const auto& s = samples_[static_cast<std::size_t>(face)];
  return {s.data() + start[b], s.data() + start[b + 1]};
}

std::size_t SampleGrid::sourceSampleCount() const noexcept {
  std::size_t n = 0;
  for (const auto& s : samples_) n += s.size();
  return n;
}

SampleGrid SampleGrid::build(const HeightGrid& dem, const Planet& planet, const Lattice& lattice,
                             std::uint32_t bucketCells,
                             const std::function<void(std::size_t, std::size_t)>& progress,
                             const RowShare* share) {
  SampleGrid grid(lattice, planet);
  const std::uint32_t n = lattice.sideCells();
  const std::size_t n1 = static_cast<std::size_t>(n) + 1;
  grid.heights_.assign(6, std::vector<float>(n1 * n1, 0.0f));
  std::atomic<std::uint64_t> noData{0};

  // 1. Heights at lattice points. Shared edge/corner points are computed from their canonical
  // direction, so every face stores the same value.
  const std::size_t totalRows = 6 * n1;
  const std::size_t beginRow = share ? share->beginRow : 0;
  const std::size_t endRow = share ? share->endRow : totalRows;
  std::atomic<std::size_t> rowsDone{0};
  for (int face = 0; face < 6; ++face) {
    auto& heights = grid.heights_[static_cast<std::size_t>(face)];
    const std::size_t faceRow = static_cast<std::size_t>(face) * n1;
    const std::size_t j0 = std::clamp(beginRow, faceRow, faceRow + n1) - faceRow;
    const std::size_t j1 = std::clamp(endRow, faceRow, faceRow + n1) - faceRow;
    if (j0 >= j1) continue;
    tbb::parallel_for(j0, j1, [&](std::size_t j) {
      std::uint64_t missing = 0;
      for (std::size_t i = 0; i < n1; ++i) {
        const glm::dvec3 d = lattice.direction(
            face, LatticeXY{static_cast<std::int32_t>(i), static_cast<std::int32_t>(j)});
        const GeodeticPosition g = planet.directionToGeodetic(d);
        auto h = dem.sampleBicubic(g.latDegrees, g.lonDegrees);
        if (!h) h = dem.sampleBilinear(g.latDegrees, g.lonDegrees);
        if (!h) ++missing;
        heights[j * n1 + i] = h ? static_cast<float>(*h) : 0.0f;
      }
      noData += missing;
      ++rowsDone;
    });
    if (progress) progress(rowsDone.load(), endRow - beginRow);
  }
  grid.noDataPoints_ = noData.load();
  if (share && share->exchange) share->exchange(grid.heights_, grid.noDataPoints_);
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  for (const auto& heights : grid.heights_) {
    const auto [mn, mx] = std::minmax_element(heights.begin(), heights.end());
    lo = std::min(lo, *mn);
    hi = std::max(hi, *mx);
  }
  grid.minHeight_ = lo;
  grid.maxHeight_ = hi;

  // 2. Source samples bucketed per face (counting sort: deterministic order within buckets).
  grid.bucketCells_ = std::max<std::uint32_t>(1, std::min(bucketCells, n));
  grid.bucketsPerSide_ = n / grid.bucketCells_;
  const std::size_t buckets = static_cast<std::size_t>(grid.bucketsPerSide_) * grid.bucketsPerSide_;
  const auto w = static_cast<std::size_t>(dem.width());
  const auto h = static_cast<std::size_t>(dem.height());
  struct Placed {
    std::uint8_t face;
    std::uint32_t bucket;
    SourceSample sample;
  };
  std::vector<Placed> placed(w * h);
  std::vector<std::uint8_t> valid(w * h, 0);
  const double nd = static_cast<double>(n);
  const double bpsMinus1 = static_cast<double>(grid.bucketsPerSide_ - 1);
  tbb::parallel_for(std::size_t{0}, h, [&](std::size_t row) {
    const double lat = dem.latOfRowDegrees(static_cast<std::int64_t>(row));
    for (std::size_t col = 0; col < w; ++col) {
      const float value = dem.at(static_cast<std::int64_t>(row), static_cast<std::int64_t>(col));
      if (std::isnan(value) || lat < -90.0 || lat > 90.0) continue;
      const double lon = dem.lonOfColumnDegrees(static_cast<std::int64_t>(col));
      const glm::dvec3 d = planet.geodeticToDirection(lat, lon);
      const FaceUv fuv = CubeMap::directionToFaceUv(d);
      const double bx = std::clamp(std::floor(fuv.uv.x * nd / grid.bucketCells_), 0.0, bpsMinus1);
      const double by = std::clamp(std::floor(fuv.uv.y * nd / grid.bucketCells_), 0.0, bpsMinus1);
      Placed& p = placed[row * w + col];
      p.face = static_cast<std::uint8_t>(cubeFaceIndex(fuv.face));
      p.bucket =
          static_cast<std::uint32_t>(by) * grid.bucketsPerSide_ + static_cast<std::uint32_t>(bx);
      p.sample = SourceSample{static_cast<float>(fuv.uv.x), static_cast<float>(fuv.uv.y), value};
      valid[row * w + col] = 1;
    }
  });
  grid.bucketStart_.assign(6, std::vector<std::uint32_t>(buckets + 1, 0));
  grid.samples_.assign(6, {});
  for (std::size_t k = 0; k < placed.size(); ++k) {
    if (valid[k] == 0) continue;
    ++grid.bucketStart_[placed[k].face][placed[k].bucket + 1];
  }
  for (int face = 0; face < 6; ++face) {
    auto& start = grid.bucketStart_[static_cast<std::size_t>(face)];
    for (std::size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
    grid.samples_[static_cast<std::size_t>(face)].resize(start[buckets]);
  }
  std::vector<std::vector<std::uint32_t>> cursor = grid.bucketStart_;
  for (std::size_t k = 0; k < placed.size(); ++k) {
    if (valid[k] == 0) continue;
    const Placed& p = placed[k];
    grid.samples_[p.face][cursor[p.face][p.bucket]++] = p.sample;
  }
  return grid;
}

}  // namespace pbdam::builder
