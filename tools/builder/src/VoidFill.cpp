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
#include "pbdam/formats/ScratchArray.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// A run of nodata samples along a row: columns [col0, col1].
struct NodataRun final {
  std::uint32_t row = 0, col0 = 0, col1 = 0;
};

/// One void: its runs (in row order) and their box.
struct Void final {
  std::vector<NodataRun> runs;
  std::int64_t samples = 0;
  std::int64_t row0 = 0, row1 = 0, col0 = 0, col1 = 0;
  template <class F>
  void forEachSample(F&& f) const {
    for (const NodataRun& run : runs) {
      for (std::int64_t c = run.col0; c <= std::int64_t{run.col1}; ++c) f(std::int64_t{run.row}, c);
    }
  }
};

/// The nodata regions of a grid: its voids (8-connected, not reaching the grid's edge) and the
/// count of nodata samples that do reach it.
struct NodataRegions final {
  std::vector<Void> voids;
  std::int64_t outsideSamples = 0;
};

/// Finds the 8-connected nodata regions row by row, as runs joined by union-find: the memory
/// grows with the number of runs (a coastline's few per row), not with the grid's samples, and a
/// mapped grid is read once in order with its pages let go as it goes.
NodataRegions findNodataRegions(const HeightGrid& grid) {
  const std::int64_t width = grid.width(), height = grid.height();
  std::vector<NodataRun> runs;
  std::vector<std::uint32_t> parent;
  const auto find = [&](std::uint32_t i) {
    while (parent[i] != i) {
      parent[i] = parent[parent[i]];
      i = parent[i];
    }
    return i;
  };
  const auto unite = [&](std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  const std::int64_t releaseEvery = std::max<std::int64_t>(1, (std::int64_t{4} << 20) / width);
  std::size_t previous = 0;  // the first run of the previous row
  for (std::int64_t r = 0; r < height; ++r) {
    const std::size_t current = runs.size();
    for (std::int64_t c = 0; c < width;) {
      if (!std::isnan(grid.at(r, c))) {
        ++c;
        continue;
      }
      const std::int64_t first = c;
      while (c < width && std::isnan(grid.at(r, c))) ++c;
      runs.push_back(NodataRun{static_cast<std::uint32_t>(r), static_cast<std::uint32_t>(first),
                               static_cast<std::uint32_t>(c - 1)});
      parent.push_back(static_cast<std::uint32_t>(runs.size() - 1));
    }
    // Join with the previous row's runs that touch, corners included.
    std::size_t j = previous;
    for (std::size_t k = current; k < runs.size(); ++k) {
      while (j < current && std::int64_t{runs[j].col1} + 1 < std::int64_t{runs[k].col0}) ++j;
      for (std::size_t i = j;
           i < current && std::int64_t{runs[i].col0} <= std::int64_t{runs[k].col1} + 1; ++i) {
        unite(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k));
      }
    }
    previous = current;
    if (r % releaseEvery == 0) grid.releaseResident();
  }
  grid.releaseResident();
  // Each region's size, box and whether it reaches the edge, by its root run.
  struct Region final {
    std::int64_t samples = 0, row0 = 0, row1 = 0, col0 = 0, col1 = 0;
    bool reachesEdge = false;
    std::int64_t voidIndex = -1;
  };
  std::vector<Region> regions;
  std::vector<std::uint32_t> regionOf(runs.size());
  std::vector<std::int64_t> regionOfRoot(runs.size(), -1);
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const std::uint32_t root = find(static_cast<std::uint32_t>(k));
    const NodataRun& run = runs[k];
    if (regionOfRoot[root] < 0) {
      regionOfRoot[root] = static_cast<std::int64_t>(regions.size());
      regions.push_back(Region{0, run.row, run.row, run.col0, run.col1, false, -1});
    }
    Region& g = regions[static_cast<std::size_t>(regionOfRoot[root])];
    regionOf[k] = static_cast<std::uint32_t>(regionOfRoot[root]);
    g.samples += std::int64_t{run.col1} - run.col0 + 1;
    g.row0 = std::min<std::int64_t>(g.row0, run.row);
    g.row1 = std::max<std::int64_t>(g.row1, run.row);
    g.col0 = std::min<std::int64_t>(g.col0, run.col0);
    g.col1 = std::max<std::int64_t>(g.col1, run.col1);
    g.reachesEdge = g.reachesEdge || run.row == 0 || run.row == height - 1 || run.col0 == 0 ||
                    run.col1 == width - 1;
  }
  regionOfRoot = {};
  NodataRegions out;
  for (Region& g : regions) {
    if (g.reachesEdge) {
      out.outsideSamples += g.samples;
      continue;
    }
    g.voidIndex = static_cast<std::int64_t>(out.voids.size());
    out.voids.push_back(Void{{}, g.samples, g.row0, g.row1, g.col0, g.col1});
  }
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const Region& g = regions[regionOf[k]];
    if (g.voidIndex >= 0) out.voids[static_cast<std::size_t>(g.voidIndex)].runs.push_back(runs[k]);
  }
  return out;
}

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

/// Appends the runs of `v` to `runs`.
void appendRuns(const Void& v, VoidKind kind, std::vector<VoidRun>& runs) {
  for (const NodataRun& run : v.runs) {
    runs.push_back(VoidRun{run.row, run.col0, run.col1 - run.col0 + 1, kind});
  }
}

/// Where filled heights go: a writable copy of the grid's heights, in a scratch file for a
/// file-backed grid when a scratch directory is given, in memory otherwise.
using WritableCopy = ScratchArray<float>;

Result<WritableCopy> writableCopy(const HeightGrid& grid,
                                  const std::filesystem::path& scratchDirectory) {
  const std::span<const float> source = grid.heightsMeters();
  WritableCopy copy = WritableCopy::allocate(
      source.size(), grid.fileBacked() ? scratchDirectory : std::filesystem::path());
  float* const heights = copy.elements().data();
  constexpr std::size_t kPiece = std::size_t{4} << 20;  // floats
  for (std::size_t at = 0; at < source.size(); at += kPiece) {
    const std::size_t n = std::min(kPiece, source.size() - at);
    std::memcpy(heights + at, source.data() + at, n * sizeof(float));
    if (copy.file()) (void)copy.file()->releaseResident(at * sizeof(float), n * sizeof(float));
    grid.releaseResident();
  }
  return copy;
}

HeightGrid finish(const HeightGrid& grid, const WritableCopy& copy) {
  if (copy.file()) {
    (void)copy.file()->releaseResident();
    (void)copy.file()->protectReadOnly();
  }
  return HeightGrid(grid.geometry(), copy.share(), copy.file() != nullptr, grid.source());
}

/// Decides the heights of each void of `regions`: filled from the rim, or (with `below`) the
/// surface below plus the rim's offset fading inwards. Without `below` only classifies. With
/// `below`, writes the heights into `target` (NaN where no height can be given; the grid's
/// layout) and appends the voids' runs to `runs`.
Result<VoidReport> processVoids(const HeightGrid& grid, const NodataRegions& regions,
                                const VoidFillOptions& options, const Below* below, float* target,
                                std::vector<VoidRun>& runs) {
  VoidReport report;
  report.outsideSamples = regions.outsideSamples;
  const auto margin = static_cast<std::int64_t>(std::ceil(options.maxDistanceSamples)) + 2;
  const std::int64_t width = grid.width();
  for (const Void& v : regions.voids) {
    const std::int64_t count = v.samples;
    ++report.voids;
    report.voidSamples += count;
    // Filled from the rim when the fill reaches all of it.
    const Window w = windowAround(grid, v, margin);
    std::vector<float> heights = copyWindow(grid, w);
    const std::vector<float> original = heights;
    if (auto r = fillNodata(heights, w.cols, w.rows, options.maxDistanceSamples); !r) {
      return r.error();
    }
    bool reached = true;
    v.forEachSample([&](std::int64_t r, std::int64_t c) {
      reached = reached && !std::isnan(heights[w.at(r, c)]);
    });
    if (reached) {
      ++report.filledVoids;
      report.filledSamples += count;
      if (below != nullptr) {
        v.forEachSample([&](std::int64_t r, std::int64_t c) {
          target[static_cast<std::size_t>(r * width + c)] = heights[w.at(r, c)];
        });
        appendRuns(v, VoidKind::FilledFromRim, runs);
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
    appendRuns(v, VoidKind::SurfaceBelow, runs);
    // The surface below, plus the inset's offset from it at the rim fading inwards across
    // half the void's inscribed radius (at most the search distance).
    const std::vector<std::int32_t> distance = distancesToValid(original, w);
    std::int32_t inscribed = 1;
    v.forEachSample([&](std::int64_t r, std::int64_t c) {
      inscribed = std::max(inscribed, distance[w.at(r, c)]);
    });
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
    v.forEachSample([&](std::int64_t r, std::int64_t c) {
      const std::size_t k = w.at(r, c);
      float& out = target[static_cast<std::size_t>(r * width + c)];
      if (std::isnan(belowAt[k])) {
        out = kNaN;
        return;
      }
      const double fade = 1.0 - smoothstep((distance[k] - 1.0) / band);
      const double o = std::isnan(offset[k]) ? 0.0 : static_cast<double>(offset[k]);
      out = static_cast<float>(belowAt[k] + o * fade);
    });
  }
  return report;
}

}  // namespace

Result<VoidReport> findVoids(const HeightGrid& grid, const VoidFillOptions& options) {
  std::vector<VoidRun> runs;
  return processVoids(grid, findNodataRegions(grid), options, nullptr, nullptr, runs);
}

Result<FilledGrid> fillVoids(const HeightGrid& grid, const VoidFillOptions& options,
                             const Below& below) {
  const NodataRegions regions = findNodataRegions(grid);
  std::vector<VoidRun> runs;
  if (regions.voids.empty()) {
    VoidReport report;
    report.outsideSamples = regions.outsideSamples;
    return FilledGrid{grid, report, std::move(runs)};
  }
  auto copy = writableCopy(grid, options.scratchDirectory);
  if (!copy) return std::move(copy).error();
  auto report = processVoids(grid, regions, options, &below, copy->elements().data(), runs);
  if (!report) return std::move(report).error();
  std::sort(runs.begin(), runs.end(), [](const VoidRun& a, const VoidRun& b) {
    return a.row != b.row ? a.row < b.row : a.column < b.column;
  });
  return FilledGrid{finish(grid, *copy), *report, std::move(runs)};
}

}  // namespace pbdam::builder
