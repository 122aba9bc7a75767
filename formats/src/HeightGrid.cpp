// HeightGrid sampling and statistics (HeightGrid.h). Seams: a grid whose columns span 360°
// wraps; a grid whose rows reach a pole treats the pole as one point whose height is the mean of
// the outermost row, so samples are continuous across the seam and single-valued at the poles.
#include "pbdam/formats/HeightGrid.h"

#include "pbdam/formats/MemoryMapping.h"

#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pbdam::formats {
namespace {

constexpr double kEpsilonDegrees = 1e-9;

/// Catmull-Rom weights for the four taps at offsets −1, 0, 1, 2 of a fraction t in [0,1).
std::array<double, 4> catmullRom(double t) noexcept {
  const double t2 = t * t;
  const double t3 = t2 * t;
  return {0.5 * (-t3 + 2.0 * t2 - t), 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
          0.5 * (-3.0 * t3 + 4.0 * t2 + t), 0.5 * (t3 - t2)};
}

std::int64_t positiveModulo(std::int64_t value, std::int64_t period) noexcept {
  const std::int64_t r = value % period;
  return r < 0 ? r + period : r;
}

}  // namespace

HeightGrid::HeightGrid(GridGeometry geometry, std::vector<float> heightsMeters, GridSource source)
    : geometry_(geometry), source_(std::move(source)) {
  auto owned = std::make_shared<const std::vector<float>>(std::move(heightsMeters));
  heights_ = std::span<const float>(*owned);
  storage_ = std::shared_ptr<const float>(owned, owned->data());
  init();
}

HeightGrid::HeightGrid(GridGeometry geometry, std::shared_ptr<const float> heightsMeters,
                       bool fileBacked, GridSource source)
    : geometry_(geometry),
      storage_(std::move(heightsMeters)),
      heights_(storage_.get(), static_cast<std::size_t>(geometry.width * geometry.height)),
      fileBacked_(fileBacked),
      source_(std::move(source)) {
  init();
}

void HeightGrid::releaseResident() const noexcept {
  if (fileBacked_) dropMappedPages(heights_.data(), heights_.size_bytes());
}

void HeightGrid::init() {
  assert(geometry_.width > 0 && geometry_.height > 0);
  assert(geometry_.latSpacingDegrees > 0.0 && geometry_.lonSpacingDegrees > 0.0);
  assert(heights_.size() == static_cast<std::size_t>(geometry_.width * geometry_.height));
  const double dLon = geometry_.lonSpacingDegrees;
  const double dLat = geometry_.latSpacingDegrees;
  const auto w = static_cast<double>(geometry_.width);
  // A pixel-is-point grid may repeat the seam column (0° and 360° both present).
  if (std::abs(w * dLon - 360.0) < 1e-6 * dLon) {
    wrapColumns_ = geometry_.width;
  } else if (!geometry_.pixelIsArea && std::abs((w - 1.0) * dLon - 360.0) < 1e-6 * dLon) {
    wrapColumns_ = geometry_.width - 1;
  }
  wrapsLongitude_ = wrapColumns_ > 0;
  const double half = geometry_.pixelIsArea ? 0.5 * dLat : 0.0;
  const double lastLat = latOfRowDegrees(geometry_.height - 1);
  coversNorthPole_ = wrapsLongitude_ && geometry_.firstLatDegrees + half >= 90.0 - 1e-6 * dLat;
  coversSouthPole_ = wrapsLongitude_ && lastLat - half <= -90.0 + 1e-6 * dLat;
  if (coversNorthPole_) poleNorthMeters_ = rowMean(0);
  if (coversSouthPole_) poleSouthMeters_ = rowMean(geometry_.height - 1);
}

std::optional<float> HeightGrid::rowMean(std::int64_t row) const noexcept {
  double sum = 0.0;
  std::int64_t count = 0;
  for (std::int64_t c = 0; c < wrapColumns_; ++c) {
    const float v = at(row, c);
    if (!std::isnan(v)) {
      sum += static_cast<double>(v);
      ++count;
    }
  }
  if (count == 0) return std::nullopt;
  return static_cast<float>(sum / static_cast<double>(count));
}

float HeightGrid::at(std::int64_t row, std::int64_t col) const noexcept {
  assert(row >= 0 && row < geometry_.height && col >= 0 && col < geometry_.width);
  return heights_[static_cast<std::size_t>(row * geometry_.width + col)];
}

double HeightGrid::latOfRowDegrees(std::int64_t row) const noexcept {
  return geometry_.firstLatDegrees - static_cast<double>(row) * geometry_.latSpacingDegrees;
}

double HeightGrid::lonOfColumnDegrees(std::int64_t col) const noexcept {
  return geometry_.firstLonDegrees + static_cast<double>(col) * geometry_.lonSpacingDegrees;
}

LatLonBounds HeightGrid::bounds() const noexcept {
  const double halfLat = geometry_.pixelIsArea ? 0.5 * geometry_.latSpacingDegrees : 0.0;
  const double halfLon = geometry_.pixelIsArea ? 0.5 * geometry_.lonSpacingDegrees : 0.0;
  LatLonBounds b;
  b.northDegrees = geometry_.firstLatDegrees + halfLat;
  b.southDegrees = latOfRowDegrees(geometry_.height - 1) - halfLat;
  b.westDegrees = geometry_.firstLonDegrees - halfLon;
  b.eastDegrees = lonOfColumnDegrees(geometry_.width - 1) + halfLon;
  return b;
}

bool HeightGrid::contains(double latDegrees, double lonDegrees) const noexcept {
  double row = 0.0;
  double col = 0.0;
  return toGrid(latDegrees, lonDegrees, row, col);
}

bool HeightGrid::toGrid(double latDegrees, double lonDegrees, double& row,
                        double& col) const noexcept {
  if (!std::isfinite(latDegrees) || !std::isfinite(lonDegrees)) return false;
  if (latDegrees < -90.0 - kEpsilonDegrees || latDegrees > 90.0 + kEpsilonDegrees) return false;
  const double h = static_cast<double>(geometry_.height);
  const double w = static_cast<double>(geometry_.width);
  const double edge = geometry_.pixelIsArea ? 0.5 : 0.0;
  const double eps = 1e-9;

  row = (geometry_.firstLatDegrees - latDegrees) / geometry_.latSpacingDegrees;
  const bool rowInside = row >= -edge - eps && row <= h - 1.0 + edge + eps;
  const bool overNorth = row < 0.0 && coversNorthPole_;
  const bool overSouth = row > h - 1.0 && coversSouthPole_;
  if (!rowInside && !overNorth && !overSouth) return false;

  const double dLon = geometry_.lonSpacingDegrees;
  col = (lonDegrees - geometry_.firstLonDegrees) / dLon;
  if (wrapsLongitude_) {
    const double period = static_cast<double>(wrapColumns_);
    // fmod is exact and returns col itself for col in (-period, period): skip it there.
    if (!(col > -period && col < period)) col = std::fmod(col, period);
    if (col < 0.0) col += period;
    return true;
  }
  // Regional grid: bring the longitude into the turn that starts half a cell before column 0.
  const double turn = 360.0 / dLon;
  col -= std::floor((col + edge + eps) / turn) * turn;
  return col >= -edge - eps && col <= w - 1.0 + edge + eps;
}

std::optional<float> HeightGrid::fetch(std::int64_t row, std::int64_t col) const noexcept {
  row = std::min(std::max<std::int64_t>(row, 0), geometry_.height - 1);
  // A pixel-is-point row on a pole is one point: every longitude gets the row's mean.
  if (!geometry_.pixelIsArea) {
    if (row == 0 && coversNorthPole_) return poleNorthMeters_;
    if (row == geometry_.height - 1 && coversSouthPole_) return poleSouthMeters_;
  }
  if (wrapsLongitude_) {
    col = positiveModulo(col, wrapColumns_);
  } else {
    col = std::min(std::max<std::int64_t>(col, 0), geometry_.width - 1);
  }
  const float v = at(row, col);
  if (std::isnan(v)) return std::nullopt;
  return v;
}

std::optional<double> HeightGrid::interpolate(std::int64_t row0, double fr, std::int64_t col0,
                                              double fc) const noexcept {
  const std::array<double, 4> weights = {(1.0 - fr) * (1.0 - fc), (1.0 - fr) * fc, fr * (1.0 - fc),
                                         fr * fc};
  const std::array<std::optional<float>, 4> taps = {
      fetch(row0, col0), fetch(row0, col0 + 1), fetch(row0 + 1, col0), fetch(row0 + 1, col0 + 1)};
  double sum = 0.0;
  double weightSum = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    if (taps[k] && weights[k] > 0.0) {
      sum += weights[k] * static_cast<double>(*taps[k]);
      weightSum += weights[k];
    }
  }
  if (weightSum <= 1e-12) return std::nullopt;
  return sum / weightSum;
}

std::optional<double> HeightGrid::sampleBilinear(double latDegrees,
                                                 double lonDegrees) const noexcept {
  double row = 0.0;
  double col = 0.0;
  if (!toGrid(latDegrees, lonDegrees, row, col)) return std::nullopt;
  const double c0 = std::floor(col);
  const auto ic = static_cast<std::int64_t>(c0);
  const double fc = col - c0;
  const double lastRow = static_cast<double>(geometry_.height - 1);
  // Between the outermost cell centres of a pixel-is-area grid and the pole: blend linearly in
  // latitude towards the pole's single value (the mean of the outermost row).
  const bool northCap = row < 0.0 && coversNorthPole_ && geometry_.pixelIsArea;
  const bool southCap = row > lastRow && coversSouthPole_ && geometry_.pixelIsArea;
  if (northCap || southCap) {
    const std::int64_t edgeRow = northCap ? 0 : geometry_.height - 1;
    const std::optional<float> pole = northCap ? poleNorthMeters_ : poleSouthMeters_;
    const double towardsPole = std::min(1.0, 2.0 * (northCap ? -row : row - lastRow));
    const auto ring = interpolate(edgeRow, 0.0, ic, fc);
    if (!ring) return pole ? std::optional<double>(*pole) : std::nullopt;
    if (!pole) return ring;
    return (1.0 - towardsPole) * *ring + towardsPole * static_cast<double>(*pole);
  }
  const double r0 = std::floor(std::min(std::max(row, 0.0), lastRow));
  const double fr = std::min(std::max(row, 0.0), lastRow) - r0;
  return interpolate(static_cast<std::int64_t>(r0), fr, ic, fc);
}

std::optional<double> HeightGrid::sampleBicubic(double latDegrees,
                                                double lonDegrees) const noexcept {
  double row = 0.0;
  double col = 0.0;
  if (!toGrid(latDegrees, lonDegrees, row, col)) return std::nullopt;
  const double r0 = std::floor(row);
  const double c0 = std::floor(col);
  const auto ir = static_cast<std::int64_t>(r0);
  const auto ic = static_cast<std::int64_t>(c0);
  // Regional grids have no data past their edges: use bilinear (with clamping) there.
  if (!wrapsLongitude_ && (ic - 1 < 0 || ic + 2 >= geometry_.width)) {
    return sampleBilinear(latDegrees, lonDegrees);
  }
  // Next to a pole or a regional grid's north/south edge the stencil would leave the grid.
  if (ir - 1 < 0 || ir + 2 >= geometry_.height) return sampleBilinear(latDegrees, lonDegrees);
  const auto wr = catmullRom(row - r0);
  const auto wc = catmullRom(col - c0);
  // Away from the poles' rows and the longitude seam every tap is a plain read (fetch's
  // clamping, pole values and modulo change nothing there): same taps, same arithmetic.
  const std::int64_t turnColumns = wrapsLongitude_ ? wrapColumns_ : geometry_.width;
  if (ir - 1 >= 1 && ir + 2 <= geometry_.height - 2 && ic - 1 >= 0 && ic + 2 < turnColumns) {
    const float* taps = heights_.data() + (ir - 1) * geometry_.width + (ic - 1);
    // Every tap read and checked first, then the four row sums as four independent chains (each
    // in the order of the loop over the taps below, so the same doubles).
    std::array<std::array<double, 4>, 4> v{};
    bool nodata = false;
    for (std::size_t i = 0; i < 4; ++i) {
      const float* line = taps + static_cast<std::ptrdiff_t>(i) * geometry_.width;
      for (std::size_t j = 0; j < 4; ++j) {
        nodata |= std::isnan(line[j]);
        v[i][j] = static_cast<double>(line[j]);
      }
    }
    if (nodata) return sampleBilinear(latDegrees, lonDegrees);
    std::array<double, 4> rowSum{};
    for (std::size_t j = 0; j < 4; ++j) {
      for (std::size_t i = 0; i < 4; ++i) rowSum[i] += wc[j] * v[i][j];
    }
    double sum = 0.0;
    for (std::size_t i = 0; i < 4; ++i) sum += wr[i] * rowSum[i];
    return sum;
  }
  double sum = 0.0;
  for (std::int64_t i = 0; i < 4; ++i) {
    double rowSum = 0.0;
    for (std::int64_t j = 0; j < 4; ++j) {
      const auto v = fetch(ir - 1 + i, ic - 1 + j);
      if (!v) return sampleBilinear(latDegrees, lonDegrees);
      rowSum += wc[static_cast<std::size_t>(j)] * static_cast<double>(*v);
    }
    sum += wr[static_cast<std::size_t>(i)] * rowSum;
  }
  return sum;
}

GridStats HeightGrid::computeStats() const noexcept {
  GridStats stats;
  double minValue = std::numeric_limits<double>::infinity();
  double maxValue = -std::numeric_limits<double>::infinity();
  std::int64_t minIndex = -1;
  std::int64_t maxIndex = -1;
  double sum = 0.0;
  const auto n = static_cast<std::int64_t>(heights_.size());
  // A mapped grid's pages are let go every 16 MB read: counting a tile set's samples does not
  // leave them all in the process.
  constexpr std::int64_t kReleaseEvery = std::int64_t{4} << 20;
  for (std::int64_t k = 0; k < n; ++k) {
    if (fileBacked_ && k % kReleaseEvery == kReleaseEvery - 1) releaseResident();
    const double v = static_cast<double>(heights_[static_cast<std::size_t>(k)]);
    if (std::isnan(v)) {
      ++stats.noDataCount;
      continue;
    }
    ++stats.validCount;
    sum += v;
    if (v < minValue) {
      minValue = v;
      minIndex = k;
    }
    if (v > maxValue) {
      maxValue = v;
      maxIndex = k;
    }
  }
  if (stats.validCount == 0) return stats;
  stats.meanMeters = sum / static_cast<double>(stats.validCount);
  stats.minMeters = minValue;
  stats.maxMeters = maxValue;
  stats.minLatDegrees = latOfRowDegrees(minIndex / geometry_.width);
  stats.minLonDegrees = lonOfColumnDegrees(minIndex % geometry_.width);
  stats.maxLatDegrees = latOfRowDegrees(maxIndex / geometry_.width);
  stats.maxLonDegrees = lonOfColumnDegrees(maxIndex % geometry_.width);
  return stats;
}

}  // namespace pbdam::formats
