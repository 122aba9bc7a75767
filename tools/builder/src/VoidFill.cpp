// Voids filled from their rims, large ones from the surface below (VoidFill.h).
#include "pbdam/builder/VoidFill.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "pbdam/formats/MemoryMapping.h"
#include "pbdam/formats/NodataFill.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// One void: its samples (row-major indices into the grid) and their box.
struct Void final {
  std::vector<std::int64_t> samples;
  std::int64_t row0 = 0, row1 = 0, col0 = 0, col1 = 0;
};

/// A window of the grid around a void, with room for the fill's search.
struct Window final {
  std::int64_t row0 = 0, col0 = 0, rows = 0, cols = 0;
  std::size_t at(std::int64_t row, std::int64_t col) const noexcept {
    return static_cast<std::size_t>((row - row0) * cols + (col - col0));
  }
};

Window windowAround(const HeightGrid& grid, const Void& v, std::int64_t margin) {
  Window w;
  w.row0 = std::max<std::int64_t>(0, v.row0 - margin);
  w.col0 = std::max<std::int64_t>(0, v.col0 - margin);
  w.rows = std::min(grid.height() - 1, v.row1 + margin) - w.row0 + 1;
  w.cols = std::min(grid.width() - 1, v.col1 + margin) - w.col0 + 1;
  return w;
}

std::vector<float> copyWindow(const HeightGrid& grid, const Window& w) {
  std::vector<float> out(static_cast<std::size_t>(w.rows * w.cols));
  for (std::int64_t r = 0; r < w.rows; ++r) {
    for (std::int64_t c = 0; c < w.cols; ++c) {
      out[static_cast<std::size_t>(r * w.cols + c)] = grid.at(w.row0 + r, w.col0 + c);
    }
  }
  return out;
}

/// Per window sample, the Chebyshev distance in samples to the nearest valid one (0 on valid
/// samples): two passes of the 3 × 3 distance transform.
std::vector<std::int32_t> distancesToValid(const std::vector<float>& heights, const Window& w) {
  constexpr std::int32_t kFar = std::numeric_limits<std::int32_t>::max() / 2;
  std::vector<std::int32_t> d(heights.size());
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = std::isnan(heights[i]) ? kFar : 0;
  const auto get = [&](std::int64_t r, std::int64_t c) {
    return r < 0 || r >= w.rows || c < 0 || c >= w.cols
               ? kFar
               : d[static_cast<std::size_t>(r * w.cols + c)];
  };
  const auto relax = [&](std::int64_t r, std::int64_t c, std::int64_t dr) {
    std::int32_t& v = d[static_cast<std::size_t>(r * w.cols + c)];
    if (v == 0) return;
    v = std::min(
        v, std::min({get(r - dr, c - 1), get(r - dr, c), get(r - dr, c + 1), get(r, c - dr)}) + 1);
  };
  for (std::int64_t r = 0; r < w.rows; ++r) {
    for (std::int64_t c = 0; c < w.cols; ++c) relax(r, c, 1);
  }
  for (std::int64_t r = w.rows; r-- > 0;) {
    for (std::int64_t c = w.cols; c-- > 0;) relax(r, c, -1);
  }
  return d;
}

double smoothstep(double x) noexcept {
  const double t = std::clamp(x, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

using Below = std::function<std::optional<double>(double, double)>;

/// Appends the runs of `samples` (one void's, any order) along their rows to `runs`.
void appendRuns(std::vector<std::int64_t> samples, std::int64_t width, VoidKind kind,
                std::vector<VoidRun>& runs) {
  std::sort(samples.begin(), samples.end());
  for (std::size_t k = 0; k < samples.size();) {
    std::size_t end = k + 1;
    while (end < samples.size() && samples[end] == samples[end - 1] + 1 &&
           samples[end] / width == samples[k] / width) {
      ++end;
    }
    runs.push_back(VoidRun{static_cast<std::uint32_t>(samples[k] / width),
                           static_cast<std::uint32_t>(samples[k] % width),
                           static_cast<std::uint32_t>(end - k), kind});
    k = end;
  }
}

/// Finds every void and decides its heights: filled from the rim, or (with `below`) the
/// surface below plus the rim's offset fading inwards. Without `below` only classifies.
/// Appends (sample, height) writes to `writes` (NaN where no height can be given) and the
/// voids' runs to `runs` (with `below`).
Result<VoidReport> processVoids(const HeightGrid& grid, const VoidFillOptions& options,
                                const Below* below,
                                std::vector<std::pair<std::int64_t, float>>& writes,
                                std::vector<VoidRun>& runs) {
  const std::int64_t width = grid.width(), height = grid.height();
  VoidReport report;
  std::vector<bool> seen(static_cast<std::size_t>(width * height), false);
  std::vector<std::int64_t> queue;
  const auto margin = static_cast<std::int64_t>(std::ceil(options.maxDistanceSamples)) + 2;
  for (std::int64_t start = 0; start < width * height; ++start) {
    if (seen[static_cast<std::size_t>(start)] || !std::isnan(grid.at(start / width, start % width)))
      continue;
    // The 8-connected nodata region from `start`.
    Void v;
    v.row0 = v.row1 = start / width;
    v.col0 = v.col1 = start % width;
    bool reachesEdge = false;
    queue.assign(1, start);
    seen[static_cast<std::size_t>(start)] = true;
    while (!queue.empty()) {
      const std::int64_t i = queue.back();
      queue.pop_back();
      v.samples.push_back(i);
      const std::int64_t r = i / width, c = i % width;
      v.row0 = std::min(v.row0, r);
      v.row1 = std::max(v.row1, r);
      v.col0 = std::min(v.col0, c);
      v.col1 = std::max(v.col1, c);
      if (r == 0 || c == 0 || r == height - 1 || c == width - 1) reachesEdge = true;
      const std::int64_t next[8][2] = {{r - 1, c},     {r + 1, c},     {r, c - 1},
                                       {r, c + 1},     {r - 1, c - 1}, {r - 1, c + 1},
                                       {r + 1, c - 1}, {r + 1, c + 1}};
      for (const auto& [nr, nc] : next) {
        if (nr < 0 || nc < 0 || nr >= height || nc >= width) continue;
        const std::int64_t j = nr * width + nc;
        if (seen[static_cast<std::size_t>(j)] || !std::isnan(grid.at(nr, nc))) continue;
        seen[static_cast<std::size_t>(j)] = true;
        queue.push_back(j);
      }
    }
    const auto count = static_cast<std::int64_t>(v.samples.size());
    if (reachesEdge) {
      report.outsideSamples += count;
      continue;
    }
    ++report.voids;
    report.voidSamples += count;
    // Filled from the rim when the fill reaches all of it.
    const Window w = windowAround(grid, v, margin);
    std::vector<float> heights = copyWindow(grid, w);
    const std::vector<float> original = heights;
    if (auto r = fillNodata(heights, w.cols, w.rows, options.maxDistanceSamples); !r) {
      return r.error();
    }
    const bool reached = std::all_of(v.samples.begin(), v.samples.end(), [&](std::int64_t i) {
      return !std::isnan(heights[w.at(i / width, i % width)]);
    });
    if (reached) {
      ++report.filledVoids;
      report.filledSamples += count;
      if (below != nullptr) {
        for (const std::int64_t i : v.samples) {
          writes.emplace_back(i, heights[w.at(i / width, i % width)]);
        }
        appendRuns(v.samples, width, VoidKind::FilledFromRim, runs);
      }
      continue;
    }
    ++report.largeVoids;
    report.belowSamples += count;
    if (count > report.largestBelowSamples) {
      report.largestBelowSamples = count;
      const double half = 0.5 * grid.geometry().latSpacingDegrees;
      const double halfLon = 0.5 * grid.geometry().lonSpacingDegrees;
      report.largestBelow = LatLonBounds{
          grid.latOfRowDegrees(v.row1) - half, grid.lonOfColumnDegrees(v.col0) - halfLon,
          grid.latOfRowDegrees(v.row0) + half, grid.lonOfColumnDegrees(v.col1) + halfLon};
    }
    if (below == nullptr) continue;
    appendRuns(v.samples, width, VoidKind::SurfaceBelow, runs);
    // The surface below, plus the inset's offset from it at the rim fading inwards across
    // half the void's inscribed radius (at most the search distance).
    const std::vector<std::int32_t> distance = distancesToValid(original, w);
    std::int32_t inscribed = 1;
    for (const std::int64_t i : v.samples) {
      inscribed = std::max(inscribed, distance[w.at(i / width, i % width)]);
    }
    const double band = std::clamp(0.5 * inscribed, 2.0, options.maxDistanceSamples);
    std::vector<float> offset(original.size(), kNaN);
    std::vector<double> belowAt(original.size(), std::numeric_limits<double>::quiet_NaN());
    for (std::int64_t r = 0; r < w.rows; ++r) {
      const std::int64_t row = w.row0 + r;
      const double lat = grid.latOfRowDegrees(row);
      for (std::int64_t c = 0; c < w.cols; ++c) {
        const std::size_t k = static_cast<std::size_t>(r * w.cols + c);
        const std::optional<double> b = (*below)(lat, grid.lonOfColumnDegrees(w.col0 + c));
        if (!b) continue;
        belowAt[k] = *b;
        if (!std::isnan(original[k]))
          offset[k] = static_cast<float>(static_cast<double>(original[k]) - *b);
      }
    }
    if (auto r = fillNodata(offset, w.cols, w.rows, band + 1.0); !r) return r.error();
    for (const std::int64_t i : v.samples) {
      const std::size_t k = w.at(i / width, i % width);
      if (std::isnan(belowAt[k])) {
        writes.emplace_back(i, kNaN);
        continue;
      }
      const double fade = 1.0 - smoothstep((distance[k] - 1.0) / band);
      const double o = std::isnan(offset[k]) ? 0.0 : static_cast<double>(offset[k]);
      writes.emplace_back(i, static_cast<float>(belowAt[k] + o * fade));
    }
  }
  return report;
}

/// A writable copy of the grid's heights with `writes` applied: in a scratch file for a
/// file-backed grid when a scratch directory is given, in memory otherwise.
Result<HeightGrid> patchedCopy(const HeightGrid& grid,
                               const std::vector<std::pair<std::int64_t, float>>& writes,
                               const std::filesystem::path& scratchDirectory) {
  const std::span<const float> source = grid.heightsMeters();
  if (grid.fileBacked() && !scratchDirectory.empty()) {
    auto scratch = MemoryMapping::createScratch(scratchDirectory, source.size_bytes());
    if (scratch) {
      auto owner = std::make_shared<MemoryMapping>(std::move(scratch).value());
      auto* heights = reinterpret_cast<float*>(owner->writableBytes().data());
      constexpr std::size_t kPiece = std::size_t{4} << 20;  // floats
      for (std::size_t at = 0; at < source.size(); at += kPiece) {
        const std::size_t n = std::min(kPiece, source.size() - at);
        std::memcpy(heights + at, source.data() + at, n * sizeof(float));
        (void)owner->releaseResident(at * sizeof(float), n * sizeof(float));
        grid.releaseResident();
      }
      for (const auto& [i, h] : writes) heights[i] = h;
      (void)owner->protectReadOnly();
      const float* first = heights;
      return HeightGrid(grid.geometry(), std::shared_ptr<const float>(std::move(owner), first),
                        true, grid.source());
    }
  }
  std::vector<float> heights(source.begin(), source.end());
  for (const auto& [i, h] : writes) heights[static_cast<std::size_t>(i)] = h;
  return HeightGrid(grid.geometry(), std::move(heights), grid.source());
}

}  // namespace

Result<VoidReport> findVoids(const HeightGrid& grid, const VoidFillOptions& options) {
  std::vector<std::pair<std::int64_t, float>> writes;
  std::vector<VoidRun> runs;
  return processVoids(grid, options, nullptr, writes, runs);
}

Result<FilledGrid> fillVoids(const HeightGrid& grid, const VoidFillOptions& options,
                             const Below& below) {
  std::vector<std::pair<std::int64_t, float>> writes;
  std::vector<VoidRun> runs;
  auto report = processVoids(grid, options, &below, writes, runs);
  if (!report) return std::move(report).error();
  std::sort(runs.begin(), runs.end(), [](const VoidRun& a, const VoidRun& b) {
    return a.row != b.row ? a.row < b.row : a.column < b.column;
  });
  if (writes.empty()) return FilledGrid{grid, *report, std::move(runs)};
  auto copy = patchedCopy(grid, writes, options.scratchDirectory);
  if (!copy) return std::move(copy).error();
  return FilledGrid{std::move(copy).value(), *report, std::move(runs)};
}

}  // namespace pbdam::builder
