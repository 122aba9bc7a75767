// The DEM resampled onto the cube-map lattice ([P-BDAM 2003] §5 "Data preparation and resampling"):
// one height per lattice point of every face, terrain positions and normals derived from them,
// and the source DEM's own samples bucketed by face cell so that patch errors can be measured
// against the original data. In memory (build()) for small users, or out of core for the builder:
// the heights in one file written row range by row range (writeHeightRows), the bucketed
// samples in one file per DEM row range (writeSourceBuckets), both read through read-only
// mappings (open()), so that the page cache holds them once per machine. Buckets are squares of
// a fixed number of lattice cells; a bucket holding many more samples than a leaf triangle
// reaches (a lidar inset on a global base: millions in a 2.4 km bucket at 2^24 cells a face) is
// split into a grid of sub-buckets, and a triangle reads of it only the sub-buckets it reaches.
// Thread-safety:
// immutable after build()/open(); const members are safe from any thread.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/streaming/MappedFile.h"

namespace pbdam::builder {

/// A source DEM sample placed on a face: its position in lattice cells from the lower corner of
/// its bucket (0 ≤ x, y ≤ the bucket's cells) and its height. Relative to the bucket, a float
/// keeps the position to 2^-24 of a bucket (at 2^24 cells a face, 0.6 m cells: 0.6 mm in the
/// 16384-cell buckets of a 1 m inset's build); a float face coordinate rounded it to half a cell
/// (0.3 m) at that lattice.
struct SourceSample final {
  float x = 0.0f;
  float y = 0.0f;
  float heightMeters = 0.0f;
};

/// A bucket of a sample table split into side² sub-buckets (row-major by sub-row, then
/// sub-column): its samples are ordered by sub-bucket, sub-bucket k's from start[bucket] +
/// subStart[first + k] to start[bucket] + subStart[first + k + 1].
struct DenseBucket final {
  std::uint64_t bucket = 0;  // face-major bucket index
  std::uint32_t side = 1;
  std::uint32_t reserved = 0;
  std::uint64_t first = 0;  // into the table's subStart
};
static_assert(sizeof(DenseBucket) == 24, "bucket files store DenseBucket as 24 bytes");

/// What writeHeightRows found in its rows.
struct HeightRowStats final {
  std::uint64_t noDataPoints = 0;
  float minHeightMeters = 0.0f;  ///< +inf / -inf when the range was empty
  float maxHeightMeters = 0.0f;
};

/// What a lattice can be resampled from: the height (metres) at (lat, lon) in degrees, or
/// nullopt where nothing is known there.
using HeightFunction = std::function<std::optional<double>(double, double)>;
/// Calls its argument fn(lat, lon, height) for every sample of a source, in a fixed order.
using SampleEnumerator = std::function<void(const std::function<void(double, double, double)>&)>;

class SampleGrid final {
 public:
  /// Resamples `dem` (bicubic, bilinear where bicubic lacks data, 0 m where the DEM has none) at
  /// every lattice point of every face, in parallel, and buckets the DEM's valid samples into
  /// `bucketCells`-sized squares of each face, all in memory. `progress(done, total)` is called
  /// from the calling thread only.
  static SampleGrid build(const formats::HeightGrid& dem, const runtime::Planet& planet,
                          const Lattice& lattice, std::uint32_t bucketCells,
                          const std::function<void(std::size_t, std::size_t)>& progress = {});
  /// The same at the lattice points of `tiles` only.
  static SampleGrid build(const formats::HeightGrid& dem, const runtime::Planet& planet,
                          const Lattice& lattice, const LatticeTiles& tiles,
                          std::uint32_t bucketCells,
                          const std::function<void(std::size_t, std::size_t)>& progress = {});

  /// Out of core, step 1: resamples the lattice rows [beginRow, endRow) of the 6·(N+1) rows
  /// (face-major: row r is row r mod (N+1) of face r / (N+1)) as build() does and writes them
  /// into `heightsFile` (raw little-endian floats, face-major, rows by j, (N+1) per row; created
  /// if missing, other rows untouched), one pwrite per row, then fsyncs. Several processes may
  /// write disjoint row ranges of one file. Errors: I/O, naming the file.
  static formats::Result<HeightRowStats> writeHeightRows(
      const formats::HeightGrid& dem, const runtime::Planet& planet, const Lattice& lattice,
      const std::filesystem::path& heightsFile, std::size_t beginRow, std::size_t endRow,
      const std::function<void(std::size_t, std::size_t)>& progress = {});
  /// The same for the storage rows [beginRow, endRow) of `tiles` (LatticeTiles::row), written
  /// at their offsets; the dense layout's rows are the rows above.
  static formats::Result<HeightRowStats> writeHeightRows(
      const formats::HeightGrid& dem, const runtime::Planet& planet, const Lattice& lattice,
      const LatticeTiles& tiles, const std::filesystem::path& heightsFile, std::size_t beginRow,
      std::size_t endRow, const std::function<void(std::size_t, std::size_t)>& progress = {});

  /// writeHeightRows from any surface: `heightAt` in place of the DEM's bicubic (bilinear
  /// where bicubic lacks data) height.
  static formats::Result<HeightRowStats> writeHeightRows(
      const HeightFunction& heightAt, const runtime::Planet& planet, const Lattice& lattice,
      const LatticeTiles& tiles, const std::filesystem::path& heightsFile, std::size_t beginRow,
      std::size_t endRow, const std::function<void(std::size_t, std::size_t)>& progress = {});

  /// Out of core, step 2: the valid DEM samples of the DEM rows [beginRow, endRow), bucketed
  /// into `bucketCells`-sized squares of each face (counting sort: within a bucket, or within a
  /// dense bucket's sub-bucket, in DEM row order), written to `samplesFile` (a new file, through
  /// a temporary name). The DEM is read twice (count, then place; three times where a bucket is
  /// dense: its sub-buckets counted in between) in chunks, so memory stays at the bucket table
  /// plus one chunk. Files of consecutive row ranges together hold the samples of build()'s
  /// single table (each file splits its own dense buckets, so the order of the visits may
  /// differ; the set does not).
  static formats::Result<void> writeSourceBuckets(const formats::HeightGrid& dem,
                                                  const runtime::Planet& planet,
                                                  const Lattice& lattice, std::uint32_t bucketCells,
                                                  const std::filesystem::path& samplesFile,
                                                  std::size_t beginRow, std::size_t endRow);

  /// Step 2 for any source: the samples [beginSample, endSample) of those `samples`
  /// enumerates (in its order), bucketed as writeSourceBuckets does a DEM's: `samples` is
  /// called two or three times (count, count a dense bucket's sub-buckets, place), so that memory
  /// is the bucket table and not the samples.
  static formats::Result<void> writeSourceBuckets(const SampleEnumerator& samples,
                                                  std::uint64_t beginSample,
                                                  std::uint64_t endSample,
                                                  const runtime::Planet& planet,
                                                  const Lattice& lattice, std::uint32_t bucketCells,
                                                  const std::filesystem::path& samplesFile);

  /// Where a sample of height `heightMeters` at (lat, lon) is bucketed: its face, bucket column
  /// and row, and the sample as stored; nullopt for a NaN height or |lat| > 90.
  struct Placement final {
    int face = 0;
    std::uint32_t bx = 0;
    std::uint32_t by = 0;
    SourceSample sample;
  };
  static std::optional<Placement> placeSample(const runtime::Planet& planet, const Lattice& lattice,
                                              std::uint32_t bucketCells, double lat, double lon,
                                              float heightMeters);

  /// Out of core, step 3: maps the complete heights file and the bucket files (in row order)
  /// read-only. `stats` are the totals over all rows. Errors: missing, short or damaged files.
  static formats::Result<SampleGrid> open(const Lattice& lattice, const runtime::Planet& planet,
                                          const std::filesystem::path& heightsFile,
                                          const std::vector<std::filesystem::path>& samplesFiles,
                                          std::uint32_t bucketCells, const HeightRowStats& stats);
  /// The same for a heights file of `tiles`.
  static formats::Result<SampleGrid> open(const Lattice& lattice, const LatticeTiles& tiles,
                                          const runtime::Planet& planet,
                                          const std::filesystem::path& heightsFile,
                                          const std::vector<std::filesystem::path>& samplesFiles,
                                          std::uint32_t bucketCells, const HeightRowStats& stats);

  /// Out of core: drops this process's page-table entries of the mappings (the pages stay in the
  /// page cache; the next read is a minor fault), so that RSS counts only what was touched
  /// since. Safe while other threads read. No-op for an in-memory grid.
  void releaseResident() const noexcept;
  /// The resident file bytes (ResidentTrimmer.h) above which reading 32 MiB of bucket pages
  /// drops them; 0 (the default): they are dropped every time.
  void setResidentBudget(std::uint64_t bytes) noexcept { residentBudget_ = bytes; }
  /// Out of core, the samples' mappings are also released each time the pages read from them
  /// since the last release reach this many bytes, so that the pages a build's error
  /// measurement holds are bounded by its reads, not by a timer against the CPU's speed: a
  /// coarse level reads every sample of the face (hundreds of MB for a large input).
  static constexpr std::uint64_t kReleaseSamplesAfterBytes = std::uint64_t{32} << 20;

  /// A bucket of a table holding more samples than this is split into sub-buckets
  /// (subBucketsPerSide).
  static constexpr std::uint64_t kDenseBucketSamples = 1024;
  /// Sub-buckets per side of a bucket of `bucketCells` cells holding `samples` samples: 1 (not
  /// split) up to kDenseBucketSamples, else a power of two for about 16 samples a sub-bucket,
  /// at most one a lattice cell.
  static std::uint32_t subBucketsPerSide(std::uint64_t samples,
                                         std::uint32_t bucketCells) noexcept {
    if (samples <= kDenseBucketSamples || bucketCells < 2) return 1;
    const auto side =
        static_cast<std::uint32_t>(std::ceil(std::sqrt(static_cast<double>(samples) / 16.0)));
    return std::clamp(std::bit_ceil(side), 2U, bucketCells);
  }

  /// The bucket size that keeps buckets a few lattice cells wide at most (a patch triangle then
  /// tests only the source samples near it) while bounding the bucket table to 4096² per face
  /// (805 MB of offsets at the paper's 16384-cell lattice, in the mapped samples file). A
  /// 1024² bound made the paper-scale buckets 16 cells wide: ETOPO5 with 16-cell buckets builds
  /// its leaf level 1.9× and the whole dataset 1.2× slower than with 2-cell ones.
  static std::uint32_t defaultBucketCells(const Lattice& lattice) noexcept {
    return std::max<std::uint32_t>(1, lattice.sideCells() / 4096);
  }
  /// For a sparse lattice (insets): no finer than about one source sample per bucket, and at
  /// most 1024 buckets a face side. Its side follows its densest inset, and buckets of a few of
  /// its cells over the whole planet would cost 8 bytes each for mostly empty buckets (805 MB at
  /// 16384 cells for ETOPO5's 9 M samples); where an inset is dense its buckets are split
  /// (subBucketsPerSide), so the table need not follow the sample count: at 4096² a face the
  /// table (400 MB of counts while bucketing, 800 MB of offsets) grew with the input. Which
  /// samples a triangle tests does not depend on the bucket size.
  static std::uint32_t bucketCellsFor(const Lattice& lattice,
                                      std::uint64_t sourceSamples) noexcept {
    const double perFace = static_cast<double>(sourceSamples) / 6.0;
    const auto side = static_cast<std::uint32_t>(std::min(1024.0, std::ceil(std::sqrt(perFace))));
    const std::uint32_t buckets = std::min(lattice.sideCells(), std::bit_ceil(std::max(side, 1U)));
    return std::max(defaultBucketCells(lattice), lattice.sideCells() / buckets);
  }

  const Lattice& lattice() const noexcept { return lattice_; }
  const runtime::Planet& planet() const noexcept { return planet_; }

  /// The lattice points stored.
  const LatticeTiles& tiles() const noexcept { return tiles_; }
  /// The heights of `face`'s lattice points, (N + 1)² row-major by j: of a dense lattice only.
  const float* faceHeights(int face) const noexcept {
    assert(tiles_.isDense());
    return faceHeights_[static_cast<std::size_t>(face)];
  }
  /// The heights of `face` as the insertion reads them (dense or tiled).
  FaceHeights heightsOf(int face) const noexcept {
    if (tiles_.isDense()) {
      return FaceHeights{faceHeights_[static_cast<std::size_t>(face)], lattice_.sideCells()};
    }
    return FaceHeights{faceHeights_[0], lattice_.sideCells(), &tiles_, face};
  }
  /// Height of lattice point p of `face` (equal on every face sharing the point), which must be
  /// stored.
  float height(int face, runtime::LatticeXY p) const noexcept {
    if (tiles_.isDense()) {
      const auto n1 = static_cast<std::size_t>(lattice_.sideCells()) + 1;
      return faceHeights_[static_cast<std::size_t>(face)]
                         [static_cast<std::size_t>(p.y) * n1 + static_cast<std::size_t>(p.x)];
    }
    const std::uint64_t at = tiles_.index(face, p);
    assert(at != LatticeTiles::kAbsent);
    return faceHeights_[0][at];
  }
  /// The terrain point (planetocentric, metres) of lattice point p: the surface point of its
  /// direction raised by its height along the surface normal. Bit-identical on every face:
  /// runtime::latticeTerrainPoint (TerrainPoint.h), the function the runtime draws vertices with.
  glm::dvec3 terrainPoint(int face, runtime::LatticeXY p) const noexcept;
  /// The terrain point of a direction at a given height.
  glm::dvec3 terrainPoint(const glm::dvec3& direction, double heightMeters) const noexcept;
  /// The planet's unit surface normal at lattice point p. Bit-identical on every face.
  glm::dvec3 surfaceNormal(int face, runtime::LatticeXY p) const noexcept;

  /// Source samples of `face` in bucket (bx, by), bx, by in [0, bucketsPerSide()): one span
  /// per bucket table (one in memory; one per bucket file out of core), visited in order.
  std::uint32_t bucketsPerSide() const noexcept { return bucketsPerSide_; }
  std::uint32_t bucketCells() const noexcept { return bucketCells_; }
  std::size_t bucketTables() const noexcept { return tables_.size(); }
  std::span<const SourceSample> bucket(std::size_t table, int face, std::uint32_t bx,
                                       std::uint32_t by) const noexcept {
    const BucketTable& t = tables_[table];
    const std::size_t b =
        (static_cast<std::size_t>(face) * bucketsPerSide_ + by) * bucketsPerSide_ + bx;
    return {t.samples + t.start[b], t.samples + t.start[b + 1]};
  }
  std::size_t sourceSampleCount() const noexcept;
  /// Buckets split into sub-buckets, over all tables.
  std::size_t denseBuckets() const noexcept;

  /// Calls fn(l0, l1, l2, sample) for every source sample inside or on the counter-clockwise
  /// (u,v) triangle (a, b, c) of `face`, with (l0, l1, l2) its barycentric weights (summing to
  /// 1). Degenerate or clockwise triangles visit nothing.
  template <typename Fn>
  void forEachSourceSampleIn(int face, glm::dvec2 a, glm::dvec2 b, glm::dvec2 c, Fn&& fn) const {
    const std::optional<TriangleBuckets> box = bucketsOf(a, b, c);
    if (!box) return;
    for (std::uint32_t by = box->by0; by <= box->by1; ++by) {
      for (std::uint32_t bx = box->bx0; bx <= box->bx1; ++bx) {
        for (std::size_t table = 0; table < tables_.size(); ++table) {
          visitInside(bucket(table, face, bx, by), bucketOrigin(bx, by), a, b, c, *box, fn);
        }
      }
    }
  }

  /// The same samples as forEachSourceSampleIn of the triangle's (u,v) corners, with the same
  /// arithmetic, for a triangle with lattice-point corners — but of each bucket row only the
  /// buckets the triangle reaches (widened by one: a sample that passes the inside test may lie
  /// its tolerance outside the triangle) are read, rather than its whole bounding box. The order
  /// of the visits may differ.
  template <typename Fn>
  void forEachSourceSampleIn(int face, runtime::LatticeXY la, runtime::LatticeXY lb,
                             runtime::LatticeXY lc, Fn&& fn) const {
    const glm::dvec2 a = lattice_.uv(la);
    const glm::dvec2 b = lattice_.uv(lb);
    const glm::dvec2 c = lattice_.uv(lc);
    const std::optional<TriangleBuckets> box = bucketsOf(a, b, c);
    if (!box) return;
    const double cells = static_cast<double>(bucketCells_);
    const std::uint32_t bx0 = box->bx0;
    const std::uint32_t bx1 = box->bx1;
    for (std::uint32_t by = box->by0; by <= box->by1; ++by) {
      std::uint32_t rx0 = bx0;
      std::uint32_t rx1 = bx1;
      if (bx1 - bx0 > 2) {
        double xLo = 0.0;
        double xHi = 0.0;
        triangleSpanInRows(la, lb, lc, (static_cast<double>(by) - 1.0) * cells,
                           (static_cast<double>(by) + 2.0) * cells, xLo, xHi);
        if (!(xLo <= xHi)) continue;
        const double first = std::floor(xLo / cells) - 1.0;
        const double lastRun = std::floor(xHi / cells) + 1.0;
        rx0 = static_cast<std::uint32_t>(
            std::clamp(first, static_cast<double>(bx0), static_cast<double>(bx1)));
        rx1 = static_cast<std::uint32_t>(
            std::clamp(lastRun, static_cast<double>(bx0), static_cast<double>(bx1)));
        if (rx0 > rx1) continue;
      }
      // Buckets of one row are consecutive in each bucket table.
      for (std::size_t table = 0; table < tables_.size(); ++table) {
        forEachRunNear(table, face, by, rx0, rx1, {la, lb, lc},
                       [&](std::span<const SourceSample> run, std::uint32_t bx) {
                         visitInside(run, bucketOrigin(bx, by), a, b, c, *box, fn);
                       });
      }
    }
  }

  /// For a patch's triangles (lattice-point corners, all inside or on the triangle `outline`),
  /// the same visits as forEachSourceSampleIn of each triangle k — the
  /// same inside test and weights, fn(k, l0, l1, l2, sample) — but each sample of the patch's
  /// buckets is read once and tested only against the triangles whose bounding boxes reach the
  /// bin it lies in (instead of by every triangle whose widened bucket box reaches it). Bins are
  /// squares of a power-of-two number of cells, at most sixteen per triangle. The order of the
  /// visits differs.
  template <typename Fn>
  void forEachSourceSampleInTriangles(int face, const std::array<runtime::LatticeXY, 3>& outline,
                                      std::span<const std::array<runtime::LatticeXY, 3>> triangles,
                                      Fn&& fn) const {
    if (triangles.empty()) return;
    const TriangleBins bins = binTriangles(triangles);
    const auto x0 = static_cast<double>(bins.x0);
    const auto y0 = static_cast<double>(bins.y0);
    const double margin = bins.margin;
    const double perBin = 1.0 / static_cast<double>(bins.binCells);
    const auto binOf = [perBin](double x, std::int64_t count) {
      return std::clamp<std::int64_t>(static_cast<std::int64_t>(x * perBin), 0, count - 1);
    };
    const std::int64_t bw = bins.columns;
    const std::int64_t bh = bins.rows;
    const double perCell = 1.0 / static_cast<double>(lattice_.sideCells());
    forEachOutlineRun(
        face, outline, [&](std::span<const SourceSample> run, std::uint32_t bx, std::uint32_t by) {
          const glm::dvec2 origin = bucketOrigin(bx, by);
          for (const SourceSample* s = run.data(); s != run.data() + run.size(); ++s) {
            const double x = origin.x + static_cast<double>(s->x);
            const double y = origin.y + static_cast<double>(s->y);
            const std::int64_t sx0 = binOf(x - x0 - margin, bw);
            const std::int64_t sx1 = binOf(x - x0 + margin, bw);
            const std::int64_t sy0 = binOf(y - y0 - margin, bh);
            const std::int64_t sy1 = binOf(y - y0 + margin, bh);
            for (std::int64_t sy = sy0; sy <= sy1; ++sy) {
              for (std::int64_t sx = sx0; sx <= sx1; ++sx) {
                const auto bin = static_cast<std::size_t>(sy * bw + sx);
                for (std::uint32_t i = bins.start[bin]; i < bins.start[bin + 1]; ++i) {
                  const std::uint32_t k = bins.binned[i];
                  // A triangle in several of the sample's bins is visited from the first.
                  if ((sx != sx0 && bins.reach[k][0] < sx) || (sy != sy0 && bins.reach[k][2] < sy))
                    continue;
                  testSample(k, bins.uv[k], bins.tests[k], x * perCell, y * perCell, bx, by, *s,
                             fn);
                }
              }
            }
          }
        });
  }

  /// forEachSourceSampleInTriangles for a patch whose triangles are all half a lattice cell
  /// (doubled area 1, as a leaf's): the same visits, with a sample's triangles found from the
  /// cells within the bins' margin of it (each cell holds at most two such triangles) instead
  /// of through bins of triangle boxes built for the patch.
  template <typename Fn>
  void forEachSourceSampleInCells(int face, const std::array<runtime::LatticeXY, 3>& outline,
                                  std::span<const std::array<runtime::LatticeXY, 3>> triangles,
                                  Fn&& fn) const {
    if (triangles.empty()) return;
    const CellTriangles cells = cellTriangles(triangles);
    const double perCell = 1.0 / static_cast<double>(lattice_.sideCells());
    const auto x0 = static_cast<double>(cells.x0);
    const auto y0 = static_cast<double>(cells.y0);
    const auto cellOf = [](double v, std::int64_t count) {
      return std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor(v)), 0, count - 1);
    };
    forEachOutlineRun(face, outline,
                      [&](std::span<const SourceSample> run, std::uint32_t bx, std::uint32_t by) {
                        const glm::dvec2 origin = bucketOrigin(bx, by);
                        for (const SourceSample& s : run) {
                          const double x = origin.x + static_cast<double>(s.x);
                          const double y = origin.y + static_cast<double>(s.y);
                          const std::int64_t cx0 = cellOf(x - x0 - cells.margin, cells.columns);
                          const std::int64_t cx1 = cellOf(x - x0 + cells.margin, cells.columns);
                          const std::int64_t cy0 = cellOf(y - y0 - cells.margin, cells.rows);
                          const std::int64_t cy1 = cellOf(y - y0 + cells.margin, cells.rows);
                          for (std::int64_t cy = cy0; cy <= cy1; ++cy) {
                            for (std::int64_t cx = cx0; cx <= cx1; ++cx) {
                              for (const std::uint32_t k :
                                   cells.at[static_cast<std::size_t>(cy * cells.columns + cx)]) {
                                if (k != kNoTriangle) {
                                  testSample(k, cells.uv[k], cells.tests[k], x * perCell,
                                             y * perCell, bx, by, s, fn);
                                }
                              }
                            }
                          }
                        }
                      });
  }

  /// The x-extent in lattice units of the triangle (a, b, c) within the rows [y0, y1] (all of
  /// it if it lies there; empty if it misses them: lo > hi).
  static void triangleSpanInRows(runtime::LatticeXY a, runtime::LatticeXY b, runtime::LatticeXY c,
                                 double y0, double y1, double& lo, double& hi) noexcept;

  /// Lattice points where the DEM had no data (given height 0).
  std::uint64_t noDataPoints() const noexcept { return noDataPoints_; }
  float minHeightMeters() const noexcept { return minHeight_; }
  float maxHeightMeters() const noexcept { return maxHeight_; }

 private:
  /// A (u,v) triangle's doubled area, inside tolerance and box of buckets.
  struct TriangleBuckets final {
    double total = 0.0;
    double eps = 0.0;
    std::uint32_t bx0 = 0, bx1 = 0, by0 = 0, by1 = 0;
  };
  /// A patch's triangles binned for forEachSourceSampleInTriangles: bins are squares of
  /// `binCells` cells (a power of two, at most sixteen bins per triangle) over the triangles' box
  /// from (x0, y0); a triangle is in the bins its own box covers (`reach`: columns and rows,
  /// first and last), listed CSR-style (`start`, `binned`). A sample passes a triangle's test
  /// only if its barycentric weights are all ≥ −1e-9, so it lies within 1e-8 of the box's
  /// extent of the triangle's box: a sample looks in the bins within `margin` cells of it.
  struct TriangleBins final {
    int x0 = 0, y0 = 0;
    std::int64_t binCells = 1, columns = 1, rows = 1;
    double margin = 0.0;
    std::vector<std::array<glm::dvec2, 3>> uv;
    std::vector<TriangleBuckets> tests;
    std::vector<std::array<std::int64_t, 4>> reach;
    std::vector<std::uint32_t> start;
    std::vector<std::uint32_t> binned;
  };
  TriangleBins binTriangles(std::span<const std::array<runtime::LatticeXY, 3>> triangles) const;

  static constexpr std::uint32_t kNoTriangle = 0xffffffffU;
  /// A patch of half-cell triangles by lattice cell over its box from (x0, y0): each cell's (at
  /// most two) triangles, and each triangle's corners and test; `margin` as TriangleBins'.
  struct CellTriangles final {
    int x0 = 0, y0 = 0;
    std::int64_t columns = 1, rows = 1;
    double margin = 0.0;
    std::vector<std::array<glm::dvec2, 3>> uv;
    std::vector<TriangleBuckets> tests;
    std::vector<std::array<std::uint32_t, 2>> at;
  };
  CellTriangles cellTriangles(std::span<const std::array<runtime::LatticeXY, 3>> triangles) const;

  /// The runs of samples a patch's triangles are tested against: those of the buckets the
  /// outline reaches, row by row, widened as forEachSourceSampleIn widens each triangle's (every
  /// sample that passes a triangle's test is among them); fn(run, bx, by).
  template <typename Fn>
  void forEachOutlineRun(int face, const std::array<runtime::LatticeXY, 3>& outline,
                         Fn&& fn) const {
    const glm::dvec2 oa = lattice_.uv(outline[0]);
    const glm::dvec2 ob = lattice_.uv(outline[1]);
    const glm::dvec2 oc = lattice_.uv(outline[2]);
    const std::optional<TriangleBuckets> outer =
        bucketsOf(oa, ob, oc) ? bucketsOf(oa, ob, oc) : bucketsOf(oa, oc, ob);
    if (!outer) return;
    const double cells = static_cast<double>(bucketCells_);
    for (std::uint32_t by = outer->by0; by <= outer->by1; ++by) {
      double xLo = 0.0;
      double xHi = 0.0;
      triangleSpanInRows(outline[0], outline[1], outline[2],
                         (static_cast<double>(by) - 1.0) * cells,
                         (static_cast<double>(by) + 2.0) * cells, xLo, xHi);
      if (!(xLo <= xHi)) continue;
      const auto rx0 = static_cast<std::uint32_t>(std::clamp(std::floor(xLo / cells) - 1.0,
                                                             static_cast<double>(outer->bx0),
                                                             static_cast<double>(outer->bx1)));
      const auto rx1 = static_cast<std::uint32_t>(std::clamp(std::floor(xHi / cells) + 1.0,
                                                             static_cast<double>(outer->bx0),
                                                             static_cast<double>(outer->bx1)));
      if (rx0 > rx1) continue;
      for (std::size_t table = 0; table < tables_.size(); ++table) {
        forEachRunNear(
            table, face, by, rx0, rx1, outline,
            [&](std::span<const SourceSample> run, std::uint32_t bx) { fn(run, bx, by); });
      }
    }
  }

  /// Nothing for a degenerate or clockwise triangle.
  std::optional<TriangleBuckets> bucketsOf(glm::dvec2 a, glm::dvec2 b,
                                           glm::dvec2 c) const noexcept {
    TriangleBuckets box;
    box.total = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (!(box.total > 0.0)) return std::nullopt;
    box.eps = -1e-9 * box.total;
    const double scale = static_cast<double>(lattice_.sideCells()) / bucketCells_;
    const double last = static_cast<double>(bucketsPerSide_ - 1);
    auto bucketOf = [&](double x) {
      return static_cast<std::uint32_t>(std::clamp(std::floor(x * scale), 0.0, last));
    };
    box.bx0 = bucketOf(std::min({a.x, b.x, c.x}));
    box.bx1 = bucketOf(std::max({a.x, b.x, c.x}));
    box.by0 = bucketOf(std::min({a.y, b.y, c.y}));
    box.by1 = bucketOf(std::max({a.y, b.y, c.y}));
    return box;
  }

  /// The lower corner of bucket (bx, by) in lattice units.
  glm::dvec2 bucketOrigin(std::uint32_t bx, std::uint32_t by) const noexcept {
    return {static_cast<double>(bx) * bucketCells_, static_cast<double>(by) * bucketCells_};
  }

  /// The inside test of forEachSourceSampleIn for a sample at (px, py) on the face (its bucket's
  /// origin plus its position, over the lattice's cells: exact, the cells being a power of two):
  /// whether it lies inside or on (a, b, c) up to `eps` of the doubled area `total`, and its
  /// weights (w0, w1, w2) / total.
  static bool inside(double px, double py, glm::dvec2 a, glm::dvec2 b, glm::dvec2 c,
                     const TriangleBuckets& box, double& w0, double& w1, double& w2) noexcept {
    w0 = (c.x - b.x) * (py - b.y) - (c.y - b.y) * (px - b.x);
    w1 = (a.x - c.x) * (py - c.y) - (a.y - c.y) * (px - c.x);
    w2 = (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
    return !(w0 < box.eps || w1 < box.eps || w2 < box.eps);
  }

  /// fn(k, l0, l1, l2, s) when the sample s at (u, v) of bucket (bx, by) passes triangle k's
  /// inside test (corners `uv`) and forEachSourceSampleIn of triangle k reads that bucket.
  template <typename Fn>
  static void testSample(std::size_t k, const std::array<glm::dvec2, 3>& uv,
                         const TriangleBuckets& test, double u, double v, std::uint32_t bx,
                         std::uint32_t by, const SourceSample& s, Fn& fn) {
    if (bx < test.bx0 || bx > test.bx1 || by < test.by0 || by > test.by1) return;
    double w0 = 0.0;
    double w1 = 0.0;
    double w2 = 0.0;
    if (!inside(u, v, uv[0], uv[1], uv[2], test, w0, w1, w2)) return;
    fn(k, w0 / test.total, w1 / test.total, w2 / test.total, s);
  }

  /// The inside test of forEachSourceSampleIn over one run of samples of the bucket whose lower
  /// corner is `origin` (lattice units): fn(l0, l1, l2, sample) for those inside or on (a, b, c)
  /// up to `eps` of the doubled area `total`.
  template <typename Fn>
  void visitInside(std::span<const SourceSample> run, glm::dvec2 origin, glm::dvec2 a, glm::dvec2 b,
                   glm::dvec2 c, const TriangleBuckets& box, Fn& fn) const {
    const double total = box.total;
    const double perCell = 1.0 / static_cast<double>(lattice_.sideCells());
    for (const SourceSample& s : run) {
      double w0 = 0.0;
      double w1 = 0.0;
      double w2 = 0.0;
      if (!inside((origin.x + static_cast<double>(s.x)) * perCell,
                  (origin.y + static_cast<double>(s.y)) * perCell, a, b, c, box, w0, w1, w2))
        continue;
      fn(w0 / total, w1 / total, w2 / total, s);
    }
  }

  /// The samples of the buckets rx0..rx1 of bucket row `by` of `face` in table `table`, as
  /// runs, visit(run, bx) with bx the run's bucket column: each bucket whole, but of a dense
  /// bucket the sub-buckets within one sub-bucket of `outline` (lattice corners), one run per
  /// sub-bucket row. Every sample of these buckets within a sub-bucket of the outline is in a
  /// run.
  template <typename Visit>
  void forEachRunNear(std::size_t table, int face, std::uint32_t by, std::uint32_t rx0,
                      std::uint32_t rx1, const std::array<runtime::LatticeXY, 3>& outline,
                      Visit&& visit) const {
    const BucketTable& t = tables_[table];
    const std::size_t rowFirst =
        (static_cast<std::size_t>(face) * bucketsPerSide_ + by) * bucketsPerSide_;
    std::size_t next = rowFirst + rx0;
    const std::size_t last = rowFirst + rx1;
    // The runs lie in one stretch of the table (its buckets rx0..rx1 are consecutive): the
    // pages between the first and the last are what the visits touch.
    const SourceSample* lo = nullptr;
    const SourceSample* hi = nullptr;
    const auto counted = [&lo, &hi, &visit](std::span<const SourceSample> run, std::uint32_t bx) {
      if (!lo || run.data() < lo) lo = run.data();
      if (!hi || run.data() + run.size() > hi) hi = run.data() + run.size();
      visit(run, bx);
    };
    const auto wholeBuckets = [&](std::size_t first, std::size_t end) {  // [first, end)
      for (std::size_t b = first; b < end; ++b) {
        if (t.start[b] != t.start[b + 1]) {
          counted(std::span<const SourceSample>(t.samples + t.start[b], t.samples + t.start[b + 1]),
                  static_cast<std::uint32_t>(b - rowFirst));
        }
      }
    };
    const DenseBucket* d =
        std::lower_bound(t.dense, t.dense + t.denseCount, next,
                         [](const DenseBucket& e, std::size_t b) { return e.bucket < b; });
    for (; d != t.dense + t.denseCount && d->bucket <= last; ++d) {
      wholeBuckets(next, static_cast<std::size_t>(d->bucket));
      next = static_cast<std::size_t>(d->bucket) + 1;
      const std::uint32_t bx = static_cast<std::uint32_t>(d->bucket - rowFirst);
      visitDenseBucket(t, *d, bx, by, outline, counted);
    }
    wholeBuckets(next, last + 1);
    if (!samplesMappings_.empty()) {
      // The bucket offsets read (a few pages of the table's CSR index), and the samples.
      noteMappedSampleReads(t.start + rowFirst + rx0, t.start + rowFirst + rx1 + 2);
      if (lo) noteMappedSampleReads(lo, hi);
    }
  }
  /// Adds the pages of [lo, hi) to those read from the mappings since their last release and
  /// releases them when that reaches kReleaseSamplesAfterBytes.
  void noteMappedSampleReads(const void* lo, const void* hi) const noexcept;

  /// One bucket-sorted sample table: CSR offsets over the 6·bucketsPerSide² buckets (face-major,
  /// then by, bx) into its samples, and its dense buckets (sorted by bucket).
  struct BucketTable final {
    const std::uint64_t* start = nullptr;  // 6·B² + 1 entries
    const SourceSample* samples = nullptr;
    const DenseBucket* dense = nullptr;
    std::size_t denseCount = 0;
    const std::uint32_t* subStart = nullptr;  // offsets from the bucket's start
  };

  /// The sub-buckets of dense bucket `d` (bucket column bx of row by) near `outline`.
  template <typename Visit>
  void visitDenseBucket(const BucketTable& t, const DenseBucket& d, std::uint32_t bx,
                        std::uint32_t by, const std::array<runtime::LatticeXY, 3>& outline,
                        Visit& visit) const {
    const double sub = static_cast<double>(bucketCells_) / d.side;  // cells (a power of two)
    const double x0 = static_cast<double>(bx) * bucketCells_;
    const double y0 = static_cast<double>(by) * bucketCells_;
    const double lastSub = static_cast<double>(d.side - 1);
    const double oy0 = std::min({outline[0].y, outline[1].y, outline[2].y});
    const double oy1 = std::max({outline[0].y, outline[1].y, outline[2].y});
    const double syLo = std::floor((oy0 - y0) / sub) - 1.0;
    const double syHi = std::floor((oy1 - y0) / sub) + 1.0;
    if (syHi < 0.0 || syLo > lastSub) return;
    const SourceSample* base = t.samples + t.start[d.bucket];
    const std::uint32_t* offsets = t.subStart + d.first;
    for (auto sy = static_cast<std::uint32_t>(std::max(syLo, 0.0));
         sy <= static_cast<std::uint32_t>(std::min(syHi, lastSub)); ++sy) {
      double xLo = 0.0;
      double xHi = 0.0;
      const double rowY = y0 + static_cast<double>(sy) * sub;
      triangleSpanInRows(outline[0], outline[1], outline[2], rowY - sub, rowY + 2.0 * sub, xLo,
                         xHi);
      if (!(xLo <= xHi)) continue;
      const double sxLo = std::floor((xLo - x0) / sub) - 1.0;
      const double sxHi = std::floor((xHi - x0) / sub) + 1.0;
      if (sxHi < 0.0 || sxLo > lastSub) continue;
      const std::size_t row = static_cast<std::size_t>(sy) * d.side;
      const auto sx0 = static_cast<std::size_t>(std::max(sxLo, 0.0));
      const auto sx1 = static_cast<std::size_t>(std::min(sxHi, lastSub));
      visit(std::span<const SourceSample>(base + offsets[row + sx0], base + offsets[row + sx1 + 1]),
            bx);
    }
  }
  SampleGrid(const Lattice& lattice, const LatticeTiles& tiles, const runtime::Planet& planet)
      : lattice_(lattice), tiles_(tiles), planet_(planet) {}
  template <typename HeightAt>
  static formats::Result<HeightRowStats> writeRows(
      const HeightAt& heightAt, const runtime::Planet& planet, const Lattice& lattice,
      const LatticeTiles& tiles, const std::filesystem::path& heightsFile, std::size_t beginRow,
      std::size_t endRow, const std::function<void(std::size_t, std::size_t)>& progress);
  /// Points faceHeights_ into `storage` (per face when dense; [0] = all when tiled).
  void setFacePointers(const float* storage) noexcept {
    const std::size_t n1 = std::size_t{lattice_.sideCells()} + 1;
    for (std::size_t face = 0; face < 6; ++face) {
      faceHeights_[face] = tiles_.isDense() ? storage + face * n1 * n1 : storage;
    }
  }
  Lattice lattice_;
  LatticeTiles tiles_;
  runtime::Planet planet_;
  // Dense: per face, (N+1)² row-major by j. Tiled: [0] is the whole storage.
  std::array<const float*, 6> faceHeights_{};
  std::uint32_t bucketCells_ = 1;
  std::uint32_t bucketsPerSide_ = 1;
  std::vector<BucketTable> tables_;
  // Storage: in memory (build()) or mapped files (open()). Moving keeps the pointers valid
  // (vector buffers and mappings do not move).
  std::vector<float> heights_;
  std::vector<std::uint64_t> bucketStart_;
  std::vector<SourceSample> samples_;
  std::vector<DenseBucket> dense_;
  std::vector<std::uint32_t> subStart_;
  streaming::MappedFile heightsMapping_;
  std::vector<streaming::MappedFile> samplesMappings_;
  /// Bytes of samples read from samplesMappings_ since they were last released (a pointer so
  /// that the grid stays movable).
  std::unique_ptr<std::atomic<std::uint64_t>> mappedSampleReads_ =
      std::make_unique<std::atomic<std::uint64_t>>(0);
  std::uint64_t residentBudget_ = 0;
  std::uint64_t noDataPoints_ = 0;
  float minHeight_ = 0.0f;
  float maxHeight_ = 0.0f;
};

}  // namespace pbdam::builder
