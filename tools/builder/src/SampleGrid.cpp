// Resampling of the DEM onto the cube-map lattice and bucketing of the source samples
// (SampleGrid.h), in memory or into files read back through mappings. Parallel over rows with
// TBB; every value depends only on its own inputs, so the result is the same for any thread or
// process count.
#include "pbdam/builder/SampleGrid.h"

#include "LatticePlane.h"
#include "SamplePlacement.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/formats/FileWrite.h"
#include "pbdam/formats/MemoryMapping.h"
#include "pbdam/runtime/TerrainPoint.h"

#include <fcntl.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <utility>
#include <vector>

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::builder {

static_assert(sizeof(SourceSample) == 12, "bucket files store SourceSample as three floats");

namespace {

namespace fs = std::filesystem;

constexpr std::array<char, 8> kSamplesMagic = {'P', 'B', 'D', 'A', 'M', 'S', 'M', 'P'};
// 2: bucketed by the stored float position; 3: positions from the bucket's corner, dense
// buckets split into sub-buckets.
constexpr std::uint32_t kSamplesVersion = 3;
// magic, version, buckets per side, samples, dense buckets, sub-bucket offsets, 8 spare
constexpr std::size_t kSamplesHeaderBytes = 48;

Error ioError(const fs::path& path, const std::string& what) {
  return makeError(ErrorCode::IoError,
                   path.string() + ": " + what + " (" + std::strerror(errno) + ")");
}

/// Resamples one storage row into `out` (row.points heights); returns its no-data count.
/// `heightAt(lat, lon)` is the surface's height there, or nullopt.
template <typename HeightAt>
std::uint64_t resampleRow(const HeightAt& heightAt, const Planet& planet, const LatticePlane& plane,
                          const LatticeTiles::Row& row, float* out) {
  std::uint64_t missing = 0;
  // Shared edge/corner points are computed from their canonical direction, so every face (and
  // every tile) stores the same value.
  const CubeFace face = cubeFaceFromIndex(row.face);
  // The row's positions first, its heights after: the surface's reads (cache misses on a large
  // DEM) of successive points then overlap rather than each waiting behind its own trigonometry.
  std::vector<GeodeticPosition> positions(row.points);
  for (std::uint32_t i = 0; i < row.points; ++i) {
    positions[i] = planet.directionToGeodetic(plane.direction(
        face, row.first.x + static_cast<std::int32_t>(i) * row.spacing, row.first.y));
  }
  for (std::uint32_t i = 0; i < row.points; ++i) {
    const std::optional<double> h = heightAt(positions[i].latDegrees, positions[i].lonDegrees);
    if (!h) ++missing;
    out[i] = h ? static_cast<float>(*h) : 0.0f;
  }
  return missing;
}

/// A table's dense buckets (SampleGrid::subBucketsPerSide) and their sub-bucket offsets: chosen
/// from the bucket counts, then each dense bucket's samples counted per sub-bucket (count(),
/// from any thread), prefix-summed (finish()), and placed (place(), in sample order).
class DenseLayout final {
 public:
  template <typename CountOf>
  static DenseLayout choose(std::size_t buckets, std::uint32_t cells, const CountOf& countOf) {
    DenseLayout layout;
    layout.cells_ = cells;
    for (std::size_t b = 0; b < buckets; ++b) {
      const std::uint32_t side = SampleGrid::subBucketsPerSide(countOf(b), cells);
      if (side < 2) continue;
      DenseBucket d;
      d.bucket = b;
      d.side = side;
      d.first = layout.subStart_.size();
      layout.dense_.push_back(d);
      layout.subStart_.resize(layout.subStart_.size() + std::size_t{side} * side + 1, 0);
    }
    return layout;
  }
  bool empty() const noexcept { return dense_.empty(); }
  const std::vector<DenseBucket>& dense() const noexcept { return dense_; }
  const std::vector<std::uint32_t>& subStart() const noexcept { return subStart_; }

  /// Counts a sample of `bucket` if the bucket is dense. Thread-safe.
  void count(std::uint32_t bucket, const SourceSample& s) noexcept {
    if (const DenseBucket* d = find(bucket)) {
      std::atomic_ref<std::uint32_t>(subStart_[d->first + subOf(*d, s) + 1])
          .fetch_add(1, std::memory_order_relaxed);
    }
  }
  void finish() {
    for (const DenseBucket& d : dense_) {
      const std::size_t k = std::size_t{d.side} * d.side;
      for (std::size_t i = 0; i < k; ++i) subStart_[d.first + i + 1] += subStart_[d.first + i];
    }
    cursor_.assign(subStart_.size(), 0);
  }
  /// Where the next sample of a dense `bucket` goes, from the bucket's start; nullopt for a
  /// bucket that is not dense.
  std::optional<std::uint64_t> place(std::uint32_t bucket, const SourceSample& s) noexcept {
    const DenseBucket* d = find(bucket);
    if (!d) return std::nullopt;
    const std::size_t k = d->first + subOf(*d, s);
    return std::uint64_t{subStart_[k]} + cursor_[k]++;
  }

 private:
  const DenseBucket* find(std::uint64_t bucket) const noexcept {
    const auto it =
        std::lower_bound(dense_.begin(), dense_.end(), bucket,
                         [](const DenseBucket& d, std::uint64_t b) { return d.bucket < b; });
    return it != dense_.end() && it->bucket == bucket ? &*it : nullptr;
  }
  /// The sub-bucket of a sample of dense bucket d, from its stored position (the division is
  /// by a power of two: exact).
  std::size_t subOf(const DenseBucket& d, const SourceSample& s) const noexcept {
    const double sub = static_cast<double>(cells_) / d.side;
    const double last = static_cast<double>(d.side - 1);
    const double sx = std::clamp(std::floor(static_cast<double>(s.x) / sub), 0.0, last);
    const double sy = std::clamp(std::floor(static_cast<double>(s.y) / sub), 0.0, last);
    return static_cast<std::size_t>(sy) * d.side + static_cast<std::size_t>(sx);
  }
  std::vector<DenseBucket> dense_;
  std::vector<std::uint32_t> subStart_;
  std::vector<std::uint32_t> cursor_;
  std::uint32_t cells_ = 1;
};

/// Where a bucket file is written before it is renamed into place.
fs::path temporaryBucketPath(const fs::path& samplesFile) {
  std::string name = ".";
  name += samplesFile.filename().string();
  name += ".tmp";
  return samplesFile.parent_path() / name;
}

/// Bytes of a bucket file's dense directory and sub-bucket offsets (padded to 8).
std::size_t denseBytes(std::uint64_t dense, std::uint64_t subOffsets) {
  const std::size_t subBytes = static_cast<std::size_t>(subOffsets) * sizeof(std::uint32_t);
  return static_cast<std::size_t>(dense) * sizeof(DenseBucket) + (subBytes + 7) / 8 * 8;
}

/// Where a bucket file's parts lie.
struct BucketFileLayout final {
  std::size_t dense = kSamplesHeaderBytes;
  std::size_t subStart = 0;
  std::size_t start = 0;
  std::size_t samples = 0;
  std::size_t bytes = 0;
};
BucketFileLayout bucketFileLayout(std::size_t buckets, std::uint64_t total, std::uint64_t dense,
                                  std::uint64_t subOffsets) {
  BucketFileLayout l;
  l.subStart = l.dense + static_cast<std::size_t>(dense) * sizeof(DenseBucket);
  l.start = kSamplesHeaderBytes + denseBytes(dense, subOffsets);
  l.samples = l.start + (buckets + 1) * sizeof(std::uint64_t);
  l.bytes = l.samples + static_cast<std::size_t>(total) * sizeof(SourceSample);
  return l;
}

/// A new bucket file at `tmp` for `buckets` buckets and `total` samples (header, dense buckets
/// and their sub-bucket offsets, CSR offsets, samples), mapped writable, its header and dense
/// parts written (magic, version, buckets per side, count, dense buckets, sub-bucket offsets).
Result<MemoryMapping> createBucketFile(const fs::path& tmp, std::size_t buckets,
                                       std::uint32_t perSide, std::uint64_t total,
                                       const DenseLayout& layout) {
  const std::uint64_t dense = layout.dense().size();
  const std::uint64_t subOffsets = layout.subStart().size();
  const BucketFileLayout l = bucketFileLayout(buckets, total, dense, subOffsets);
  auto map = MemoryMapping::create(tmp, l.bytes);
  if (!map) return std::move(map).error();
  std::byte* at = map->writableBytes().data();
  std::memcpy(at, kSamplesMagic.data(), 8);
  std::memcpy(at + 8, &kSamplesVersion, 4);
  std::memcpy(at + 12, &perSide, 4);
  std::memcpy(at + 16, &total, 8);
  std::memcpy(at + 24, &dense, 8);
  std::memcpy(at + 32, &subOffsets, 8);
  if (dense > 0) {
    std::memcpy(at + l.dense, layout.dense().data(), dense * sizeof(DenseBucket));
    std::memcpy(at + l.subStart, layout.subStart().data(), subOffsets * sizeof(std::uint32_t));
  }
  return map;
}

/// Syncs a written bucket file and renames it into place.
Result<void> publishBucketFile(const MemoryMapping& map, const fs::path& tmp,
                               const fs::path& samplesFile) {
  if (auto synced = map.sync(); !synced) return synced;
  std::error_code ec;
  fs::rename(tmp, samplesFile, ec);
  if (ec) {
    return makeError(ErrorCode::IoError,
                     samplesFile.string() + ": rename failed (" + ec.message() + ")");
  }
  return {};
}

std::uint32_t bucketsPerSideOf(const Lattice& lattice, std::uint32_t bucketCells) {
  const std::uint32_t cells =
      std::max<std::uint32_t>(1, std::min(bucketCells, lattice.sideCells()));
  return lattice.sideCells() / cells;
}

}  // namespace

std::optional<SampleGrid::Placement> SampleGrid::placeSample(const Planet& planet,
                                                             const Lattice& lattice,
                                                             std::uint32_t bucketCells, double lat,
                                                             double lon, float heightMeters) {
  const std::uint32_t cells =
      std::max<std::uint32_t>(1, std::min(bucketCells, lattice.sideCells()));
  const std::uint32_t perSide = bucketsPerSideOf(lattice, bucketCells);
  const Placed p = placeAt(planet, static_cast<double>(lattice.sideCells()), cells, perSide, lat,
                           lon, heightMeters);
  if (p.bucket == std::numeric_limits<std::uint32_t>::max()) return std::nullopt;
  Placement out;
  out.face = static_cast<int>(p.bucket / perSide / perSide);
  out.by = p.bucket / perSide % perSide;
  out.bx = p.bucket % perSide;
  out.sample = p.sample;
  return out;
}

glm::dvec3 SampleGrid::terrainPoint(const glm::dvec3& direction,
                                    double heightMeters) const noexcept {
  return terrainPointOfDirection(planet_, direction, heightMeters);
}

glm::dvec3 SampleGrid::terrainPoint(int face, LatticeXY p) const noexcept {
  return latticeTerrainPoint(planet_, lattice_.sideCells(), face, p,
                             static_cast<double>(height(face, p)));
}

glm::dvec3 SampleGrid::surfaceNormal(int face, LatticeXY p) const noexcept {
  const glm::dvec3 d = lattice_.direction(face, p);
  if (planet_.isSphere()) return d;
  const GeodeticPosition g = planet_.directionToGeodetic(d);
  return planet_.surfaceNormal(g.latDegrees, g.lonDegrees);
}

std::size_t SampleGrid::sourceSampleCount() const noexcept {
  const std::size_t buckets = 6 * std::size_t{bucketsPerSide_} * bucketsPerSide_;
  std::size_t n = 0;
  for (const BucketTable& t : tables_) n += static_cast<std::size_t>(t.start[buckets]);
  return n;
}

std::size_t SampleGrid::denseBuckets() const noexcept {
  std::size_t n = 0;
  for (const BucketTable& t : tables_) n += t.denseCount;
  return n;
}

void SampleGrid::releaseResident() const noexcept {
  (void)heightsMapping_.releaseResident();
  for (const MappedFile& m : samplesMappings_) (void)m.releaseResident();
}

void SampleGrid::noteMappedSampleReads(const void* lo, const void* hi) const noexcept {
  constexpr std::uintptr_t kPage = 4096;
  const auto first = reinterpret_cast<std::uintptr_t>(lo) / kPage;       // NOLINT: page arithmetic
  const auto last = (reinterpret_cast<std::uintptr_t>(hi) - 1) / kPage;  // NOLINT: the same
  const std::uint64_t bytes = (last - first + 1) * kPage;
  const std::uint64_t before = mappedSampleReads_->fetch_add(bytes, std::memory_order_relaxed);
  // The one call that crosses the bound releases; pages counted meanwhile start the next round.
  if (before < kReleaseSamplesAfterBytes && before + bytes >= kReleaseSamplesAfterBytes) {
    if (overResidentBudget(residentBudget_)) {
      for (const MappedFile& m : samplesMappings_) (void)m.releaseResident();
    }
    mappedSampleReads_->fetch_sub(before + bytes, std::memory_order_relaxed);
  }
}

SampleGrid SampleGrid::build(const HeightGrid& dem, const Planet& planet, const Lattice& lattice,
                             std::uint32_t bucketCells,
                             const std::function<void(std::size_t, std::size_t)>& progress) {
  return build(dem, planet, lattice, LatticeTiles::dense(lattice.sideCells()), bucketCells,
               progress);
}

SampleGrid SampleGrid::build(const HeightGrid& dem, const Planet& planet, const Lattice& lattice,
                             const LatticeTiles& tiles, std::uint32_t bucketCells,
                             const std::function<void(std::size_t, std::size_t)>& progress) {
  SampleGrid grid(lattice, tiles, planet);
  const std::uint32_t n = lattice.sideCells();
  grid.heights_.assign(static_cast<std::size_t>(tiles.pointCount()), 0.0f);
  grid.setFacePointers(grid.heights_.data());
  std::atomic<std::uint64_t> noData{0};

  // 1. Heights at lattice points, a chunk of storage rows at a time.
  const std::size_t rows = static_cast<std::size_t>(tiles.rowCount());
  const std::size_t chunk = std::max<std::size_t>(1, rows / 6);
  const LatticePlane plane(n);
  for (std::size_t first = 0; first < rows; first += chunk) {
    const std::size_t last = std::min(rows, first + chunk);
    tbb::parallel_for(first, last, [&](std::size_t r) {
      const LatticeTiles::Row row = tiles.row(r);
      noData +=
          resampleRow(DemHeightAt{dem}, planet, plane, row, grid.heights_.data() + row.offset);
    });
    if (progress) progress(last, rows);
  }
  grid.noDataPoints_ = noData.load();
  const auto [mn, mx] = std::minmax_element(grid.heights_.begin(), grid.heights_.end());
  grid.minHeight_ = *mn;
  grid.maxHeight_ = *mx;

  // 2. Source samples bucketed (counting sort: deterministic order within buckets).
  grid.bucketCells_ = std::max<std::uint32_t>(1, std::min(bucketCells, n));
  grid.bucketsPerSide_ = bucketsPerSideOf(lattice, bucketCells);
  const std::size_t buckets =
      6 * static_cast<std::size_t>(grid.bucketsPerSide_) * grid.bucketsPerSide_;
  const auto w = static_cast<std::size_t>(dem.width());
  const auto h = static_cast<std::size_t>(dem.height());
  std::vector<Placed> placed(w * h);
  const DemPlacer placer(dem, planet, static_cast<double>(n), grid.bucketCells_,
                         grid.bucketsPerSide_);
  tbb::parallel_for(std::size_t{0}, h, [&](std::size_t row) {
    placer.forEachInRow(row, [&](std::size_t col, const Placed& p) { placed[row * w + col] = p; });
  });
  constexpr auto kInvalid = std::numeric_limits<std::uint32_t>::max();
  grid.bucketStart_.assign(buckets + 1, 0);
  for (const Placed& p : placed) {
    if (p.bucket != kInvalid) ++grid.bucketStart_[p.bucket + 1];
  }
  for (std::size_t b = 0; b < buckets; ++b) grid.bucketStart_[b + 1] += grid.bucketStart_[b];
  DenseLayout layout = DenseLayout::choose(buckets, grid.bucketCells_, [&](std::size_t b) {
    return grid.bucketStart_[b + 1] - grid.bucketStart_[b];
  });
  if (!layout.empty()) {
    for (const Placed& p : placed) {
      if (p.bucket != kInvalid) layout.count(p.bucket, p.sample);
    }
  }
  layout.finish();
  grid.samples_.resize(static_cast<std::size_t>(grid.bucketStart_[buckets]));
  std::vector<std::uint64_t> cursor(grid.bucketStart_.begin(), grid.bucketStart_.end() - 1);
  for (const Placed& p : placed) {
    if (p.bucket == kInvalid) continue;
    if (const auto at = layout.place(p.bucket, p.sample)) {
      grid.samples_[grid.bucketStart_[p.bucket] + *at] = p.sample;
    } else {
      grid.samples_[cursor[p.bucket]++] = p.sample;
    }
  }
  grid.dense_ = layout.dense();
  grid.subStart_ = layout.subStart();
  grid.tables_.push_back(BucketTable{grid.bucketStart_.data(), grid.samples_.data(),
                                     grid.dense_.data(), grid.dense_.size(),
                                     grid.subStart_.data()});
  return grid;
}

Result<HeightRowStats> SampleGrid::writeHeightRows(
    const HeightGrid& dem, const Planet& planet, const Lattice& lattice,
    const fs::path& heightsFile, std::size_t beginRow, std::size_t endRow,
    const std::function<void(std::size_t, std::size_t)>& progress) {
  return writeHeightRows(dem, planet, lattice, LatticeTiles::dense(lattice.sideCells()),
                         heightsFile, beginRow, endRow, progress);
}

Result<HeightRowStats> SampleGrid::writeHeightRows(
    const HeightGrid& dem, const Planet& planet, const Lattice& lattice, const LatticeTiles& tiles,
    const fs::path& heightsFile, std::size_t beginRow, std::size_t endRow,
    const std::function<void(std::size_t, std::size_t)>& progress) {
  return writeRows(DemHeightAt{dem}, planet, lattice, tiles, heightsFile, beginRow, endRow,
                   progress);
}

Result<HeightRowStats> SampleGrid::writeHeightRows(
    const HeightFunction& heightAt, const Planet& planet, const Lattice& lattice,
    const LatticeTiles& tiles, const fs::path& heightsFile, std::size_t beginRow,
    std::size_t endRow, const std::function<void(std::size_t, std::size_t)>& progress) {
  return writeRows(heightAt, planet, lattice, tiles, heightsFile, beginRow, endRow, progress);
}

template <typename HeightAt>
Result<HeightRowStats> SampleGrid::writeRows(
    const HeightAt& heightAt, const Planet& planet, const Lattice& lattice,
    const LatticeTiles& tiles, const fs::path& heightsFile, std::size_t beginRow,
    std::size_t endRow, const std::function<void(std::size_t, std::size_t)>& progress) {
  const int fd = ::open(heightsFile.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return ioError(heightsFile, "cannot open for writing");
  const auto byteOf = [&](std::size_t r) {
    return r == tiles.rowCount() ? tiles.pointCount() * sizeof(float)
                                 : tiles.row(r).offset * sizeof(float);
  };
  const std::uint64_t firstByte = byteOf(beginRow);
  const std::uint64_t rangeBytes = byteOf(endRow) - firstByte;
  // This rank's rows get their blocks first: a full disk stops the build here, naming the bytes.
  if (auto r = reserveFileSpace(fd, firstByte, rangeBytes, heightsFile); !r) {
    ::close(fd);
    return std::move(r).error();
  }
  const LatticePlane plane(lattice.sideCells());
  std::atomic<std::uint64_t> noData{0};
  std::atomic<std::size_t> rowsDone{0};
  std::atomic<bool> failed{false};
  std::mutex statsMutex;
  std::optional<Error> writeError;  // the first failed write, under statsMutex
  HeightRowStats stats;
  stats.minHeightMeters = std::numeric_limits<float>::infinity();
  stats.maxHeightMeters = -std::numeric_limits<float>::infinity();
  // Chunks of rows, so that progress is reported from the calling thread as they finish.
  const std::size_t chunk = 256;
  for (std::size_t first = beginRow; first < endRow; first += chunk) {
    const std::size_t last = std::min(endRow, first + chunk);
    tbb::parallel_for(first, last, [&](std::size_t row) {
      if (failed) return;
      const LatticeTiles::Row at = tiles.row(row);
      std::vector<float> heights(at.points);
      noData += resampleRow(heightAt, planet, plane, at, heights.data());
      const auto [mn, mx] = std::minmax_element(heights.begin(), heights.end());
      {
        std::lock_guard lock(statsMutex);
        stats.minHeightMeters = std::min(stats.minHeightMeters, *mn);
        stats.maxHeightMeters = std::max(stats.maxHeightMeters, *mx);
      }
      auto written = pwriteFully(fd, std::as_bytes(std::span<const float>(heights)),
                                 at.offset * sizeof(float), heightsFile);
      if (!written) {
        std::lock_guard lock(statsMutex);
        if (!writeError) writeError = std::move(written).error();
        failed = true;
      }
      ++rowsDone;
    });
    if (failed) break;
    if (progress) progress(rowsDone.load(), endRow - beginRow);
  }
  if (writeError) {
    ::close(fd);
    return std::move(*writeError);
  }
  if (auto r = syncFile(fd, rangeBytes, heightsFile); !r) {
    ::close(fd);
    return std::move(r).error();
  }
  if (::close(fd) != 0) return ioError(heightsFile, "close failed");
  stats.noDataPoints = noData.load();
  return stats;
}

Result<void> SampleGrid::writeSourceBuckets(const HeightGrid& dem, const Planet& planet,
                                            const Lattice& lattice, std::uint32_t bucketCells,
                                            const fs::path& samplesFile, std::size_t beginRow,
                                            std::size_t endRow) {
  const std::uint32_t cells =
      std::max<std::uint32_t>(1, std::min(bucketCells, lattice.sideCells()));
  const std::uint32_t perSide = bucketsPerSideOf(lattice, bucketCells);
  const std::size_t buckets = 6 * static_cast<std::size_t>(perSide) * perSide;
  const double n = static_cast<double>(lattice.sideCells());
  const auto w = static_cast<std::size_t>(dem.width());
  constexpr auto kInvalid = std::numeric_limits<std::uint32_t>::max();
  // Rows per chunk: about 4 M samples (64 MB of placements) at a time.
  const std::size_t chunkRows =
      std::max<std::size_t>(1, (std::size_t{1} << 22) / std::max<std::size_t>(w, 1));

  // Pass 1: count per bucket (32 bits: a bucket is a few lattice cells; the table is up to
  // 6·4096² entries, so it is kept as small as it can be; the offsets go straight to the file).
  // The first chunk's placements are kept for pass 2, in the buffer pass 2 places its chunks in:
  // a share of one chunk is placed once, not two or three times, in no more memory.
  const DemPlacer placer(dem, planet, n, cells, perSide);
  const std::size_t keptEnd = std::min(endRow, beginRow + chunkRows);
  std::vector<Placed> placed((keptEnd - beginRow) * w);
  std::vector<std::atomic<std::uint32_t>> counts(buckets);
  tbb::parallel_for(beginRow, endRow, [&](std::size_t row) {
    Placed* kept = row < keptEnd ? placed.data() + (row - beginRow) * w : nullptr;
    placer.forEachInRow(row, [&](std::size_t col, const Placed& p) {
      if (kept) kept[col] = p;
      if (p.bucket != kInvalid) counts[p.bucket].fetch_add(1, std::memory_order_relaxed);
    });
  });
  std::uint64_t total = 0;
  for (std::size_t b = 0; b < buckets; ++b) total += counts[b].load(std::memory_order_relaxed);
  // Dense buckets: their samples counted per sub-bucket (a third read of the rows).
  DenseLayout layout = DenseLayout::choose(buckets, cells, [&](std::size_t b) {
    return std::uint64_t{counts[b].load(std::memory_order_relaxed)};
  });
  if (!layout.empty()) {
    tbb::parallel_for(beginRow, endRow, [&](std::size_t row) {
      const auto count = [&](std::size_t, const Placed& p) {
        if (p.bucket != kInvalid) layout.count(p.bucket, p.sample);
      };
      if (row < keptEnd) {
        for (std::size_t col = 0; col < w; ++col) count(col, placed[(row - beginRow) * w + col]);
      } else {
        placer.forEachInRow(row, count);
      }
    });
  }
  layout.finish();

  // The file: header, dense buckets, CSR offsets, samples; written through a temporary name.
  const fs::path tmp = temporaryBucketPath(samplesFile);
  auto map = createBucketFile(tmp, buckets, perSide, total, layout);
  if (!map) return std::move(map).error();
  const BucketFileLayout parts =
      bucketFileLayout(buckets, total, layout.dense().size(), layout.subStart().size());
  std::byte* at = map->writableBytes().data();
  auto* start = reinterpret_cast<std::uint64_t*>(at + parts.start);
  start[0] = 0;
  for (std::size_t b = 0; b < buckets; ++b) {
    start[b + 1] = start[b] + counts[b].load(std::memory_order_relaxed);
    counts[b].store(0, std::memory_order_relaxed);  // from here on: samples placed so far
    // Every 64 MB: the offsets of 6·4096² buckets are 800 MB of pages written in this loop.
    if ((b + 1) % (std::size_t{1} << 23) == 0) (void)map->releaseResident();
  }
  (void)map->releaseResident();  // the offsets' pages (8 bytes a bucket) stay in the page cache
  auto* samples = reinterpret_cast<SourceSample*>(at + parts.samples);

  // Pass 2: place chunk by chunk (in parallel; the first chunk's are kept from pass 1), scatter
  // in row order (stable).
  for (std::size_t first = beginRow; first < endRow; first += chunkRows) {
    const std::size_t last = std::min(endRow, first + chunkRows);
    if (first != beginRow) {
      placed.resize((last - first) * w);
      tbb::parallel_for(first, last, [&](std::size_t row) {
        placer.forEachInRow(
            row, [&](std::size_t col, const Placed& p) { placed[(row - first) * w + col] = p; });
      });
    }
    for (const Placed& p : placed) {
      if (p.bucket == kInvalid) continue;
      if (const auto inBucket = layout.place(p.bucket, p.sample)) {
        samples[start[p.bucket] + *inBucket] = p.sample;
      } else {
        std::atomic<std::uint32_t>& placedSoFar = counts[p.bucket];
        const std::uint32_t k = placedSoFar.load(std::memory_order_relaxed);
        placedSoFar.store(k + 1, std::memory_order_relaxed);
        samples[start[p.bucket] + k] = p.sample;
      }
    }
    (void)map->releaseResident();  // RSS bound: the written pages live on in the page cache
  }
  return publishBucketFile(*map, tmp, samplesFile);
}

Result<void> SampleGrid::writeSourceBuckets(const SampleEnumerator& samples,
                                            std::uint64_t beginSample, std::uint64_t endSample,
                                            const Planet& planet, const Lattice& lattice,
                                            std::uint32_t bucketCells,
                                            const fs::path& samplesFile) {
  const std::uint32_t cells =
      std::max<std::uint32_t>(1, std::min(bucketCells, lattice.sideCells()));
  const std::uint32_t perSide = bucketsPerSideOf(lattice, bucketCells);
  const std::size_t buckets = 6 * static_cast<std::size_t>(perSide) * perSide;
  const double n = static_cast<double>(lattice.sideCells());
  constexpr auto kInvalid = std::numeric_limits<std::uint32_t>::max();
  // The share's samples are enumerated again for each pass (count, count the dense buckets'
  // sub-buckets where there are any, place) rather than held: memory is the bucket table and the
  // file's pages, whatever the input's size.
  const auto forEachPlaced = [&](const auto& fn) {
    std::uint64_t ordinal = 0;
    samples([&](double lat, double lon, double height) {
      if (ordinal >= beginSample && ordinal < endSample) {
        const Placed p = placeAt(planet, n, cells, perSide, lat, lon, static_cast<float>(height));
        if (p.bucket != kInvalid) fn(p);
      }
      ++ordinal;
    });
  };
  // Pass 1: count per bucket (32 bits, as writeSourceBuckets of a DEM).
  std::vector<std::uint32_t> counts(buckets, 0);
  forEachPlaced([&](const Placed& p) { ++counts[p.bucket]; });
  std::uint64_t total = 0;
  for (const std::uint32_t c : counts) total += c;
  DenseLayout layout =
      DenseLayout::choose(buckets, cells, [&](std::size_t b) { return std::uint64_t{counts[b]}; });
  if (!layout.empty()) forEachPlaced([&](const Placed& p) { layout.count(p.bucket, p.sample); });
  layout.finish();
  const fs::path tmp = temporaryBucketPath(samplesFile);
  auto map = createBucketFile(tmp, buckets, perSide, total, layout);
  if (!map) return std::move(map).error();
  const BucketFileLayout parts =
      bucketFileLayout(buckets, total, layout.dense().size(), layout.subStart().size());
  std::byte* at = map->writableBytes().data();
  auto* start = reinterpret_cast<std::uint64_t*>(at + parts.start);
  start[0] = 0;
  for (std::size_t b = 0; b < buckets; ++b) {
    start[b + 1] = start[b] + counts[b];
    counts[b] = 0;  // from here on: samples placed so far
    if ((b + 1) % (std::size_t{1} << 23) == 0) (void)map->releaseResident();  // every 64 MB
  }
  (void)map->releaseResident();  // the offsets' pages (8 bytes a bucket) stay in the page cache
  auto* out = reinterpret_cast<SourceSample*>(at + parts.samples);
  // Pass 2: place in enumeration order (stable within a bucket or sub-bucket).
  std::uint64_t placedSinceRelease = 0;
  forEachPlaced([&](const Placed& p) {
    if (const auto inBucket = layout.place(p.bucket, p.sample)) {
      out[start[p.bucket] + *inBucket] = p.sample;
    } else {
      out[start[p.bucket] + counts[p.bucket]++] = p.sample;
    }
    if (++placedSinceRelease == (std::uint64_t{1} << 22)) {
      (void)map->releaseResident();  // RSS bound: the written pages live on in the page cache
      placedSinceRelease = 0;
    }
  });
  return publishBucketFile(*map, tmp, samplesFile);
}

namespace {

/// The lattice box of a patch's triangles (each extent at least one cell) and the margin within
/// which a sample can pass a triangle's inside test beyond its box (TriangleBins::margin).
struct PatchBox final {
  int x0 = 0;
  int y0 = 0;
  std::int64_t width = 1;
  std::int64_t height = 1;
  double margin = 0.0;
};

PatchBox patchBox(std::span<const std::array<LatticeXY, 3>> triangles) noexcept {
  PatchBox box;
  int x1 = triangles[0][0].x;
  int y1 = triangles[0][0].y;
  box.x0 = x1;
  box.y0 = y1;
  for (const auto& t : triangles) {
    for (const LatticeXY p : t) {
      box.x0 = std::min(box.x0, p.x);
      x1 = std::max(x1, p.x);
      box.y0 = std::min(box.y0, p.y);
      y1 = std::max(y1, p.y);
    }
  }
  box.width = std::max(1, x1 - box.x0);
  box.height = std::max(1, y1 - box.y0);
  box.margin = 1e-6 + 1e-8 * static_cast<double>(std::max(box.width, box.height));
  return box;
}

}  // namespace

SampleGrid::CellTriangles SampleGrid::cellTriangles(
    std::span<const std::array<LatticeXY, 3>> triangles) const {
  CellTriangles cells;
  const PatchBox box = patchBox(triangles);
  cells.x0 = box.x0;
  cells.y0 = box.y0;
  cells.columns = box.width;
  cells.rows = box.height;
  cells.margin = box.margin;
  cells.uv.resize(triangles.size());
  cells.tests.resize(triangles.size());
  cells.at.assign(static_cast<std::size_t>(box.width * box.height), {kNoTriangle, kNoTriangle});
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    const auto& t = triangles[k];
    cells.uv[k] = {lattice_.uv(t[0]), lattice_.uv(t[1]), lattice_.uv(t[2])};
    const std::optional<TriangleBuckets> test =
        bucketsOf(cells.uv[k][0], cells.uv[k][1], cells.uv[k][2]);
    if (!test) continue;  // degenerate or clockwise: visits nothing, as forEachSourceSampleIn
    cells.tests[k] = *test;
    // Half a cell: its box is one cell.
    const std::int64_t cx = std::min({t[0].x, t[1].x, t[2].x}) - cells.x0;
    const std::int64_t cy = std::min({t[0].y, t[1].y, t[2].y}) - cells.y0;
    auto& slots = cells.at[static_cast<std::size_t>(cy * box.width + cx)];
    slots[slots[0] == kNoTriangle ? 0 : 1] = static_cast<std::uint32_t>(k);
  }
  return cells;
}

SampleGrid::TriangleBins SampleGrid::binTriangles(
    std::span<const std::array<LatticeXY, 3>> triangles) const {
  TriangleBins bins;
  const PatchBox box = patchBox(triangles);
  bins.x0 = box.x0;
  bins.y0 = box.y0;
  const std::int64_t w = box.width;
  const std::int64_t h = box.height;
  const auto binsOf = [](std::int64_t extent, std::int64_t cells) {
    return (extent + cells - 1) / cells;
  };
  const std::int64_t most = std::max<std::int64_t>(16, 16 * std::ssize(triangles));
  while (binsOf(w, bins.binCells) * binsOf(h, bins.binCells) > most) bins.binCells *= 2;
  bins.columns = binsOf(w, bins.binCells);
  bins.rows = binsOf(h, bins.binCells);
  bins.margin = box.margin;
  bins.uv.resize(triangles.size());
  bins.tests.resize(triangles.size());
  bins.reach.resize(triangles.size());
  bins.start.assign(static_cast<std::size_t>(bins.columns * bins.rows) + 1, 0);
  const auto forEachBin = [&](std::size_t k, auto&& f) {
    for (std::int64_t by = bins.reach[k][2]; by <= bins.reach[k][3]; ++by) {
      for (std::int64_t bx = bins.reach[k][0]; bx <= bins.reach[k][1]; ++bx) {
        f(static_cast<std::size_t>(by * bins.columns + bx));
      }
    }
  };
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    const auto& t = triangles[k];
    bins.uv[k] = {lattice_.uv(t[0]), lattice_.uv(t[1]), lattice_.uv(t[2])};
    const std::optional<TriangleBuckets> test =
        bucketsOf(bins.uv[k][0], bins.uv[k][1], bins.uv[k][2]);
    if (!test) {  // degenerate or clockwise: visits nothing, as forEachSourceSampleIn
      bins.reach[k] = {1, 0, 1, 0};
      continue;
    }
    bins.tests[k] = *test;
    // The cells [x0, x1) × [y0, y1) of the triangle's box (positive area: both extents ≥ 1).
    const std::int64_t cx0 = std::min({t[0].x, t[1].x, t[2].x}) - bins.x0;
    const std::int64_t cx1 = std::max({t[0].x, t[1].x, t[2].x}) - bins.x0 - 1;
    const std::int64_t cy0 = std::min({t[0].y, t[1].y, t[2].y}) - bins.y0;
    const std::int64_t cy1 = std::max({t[0].y, t[1].y, t[2].y}) - bins.y0 - 1;
    bins.reach[k] = {std::min(cx0 / bins.binCells, bins.columns - 1),
                     std::min(cx1 / bins.binCells, bins.columns - 1),
                     std::min(cy0 / bins.binCells, bins.rows - 1),
                     std::min(cy1 / bins.binCells, bins.rows - 1)};
    forEachBin(k, [&](std::size_t bin) { ++bins.start[bin + 1]; });
  }
  for (std::size_t b = 1; b < bins.start.size(); ++b) bins.start[b] += bins.start[b - 1];
  bins.binned.resize(bins.start.back());
  std::vector<std::uint32_t> fill(bins.start.begin(), bins.start.end() - 1);
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    forEachBin(k,
               [&](std::size_t bin) { bins.binned[fill[bin]++] = static_cast<std::uint32_t>(k); });
  }
  return bins;
}

void SampleGrid::triangleSpanInRows(LatticeXY a, LatticeXY b, LatticeXY c, double y0, double y1,
                                    double& lo, double& hi) noexcept {
  lo = std::numeric_limits<double>::infinity();
  hi = -std::numeric_limits<double>::infinity();
  const std::array<LatticeXY, 3> p = {a, b, c};
  for (std::size_t e = 0; e < 3; ++e) {
    const glm::dvec2 s(p[e]);
    const glm::dvec2 t(p[(e + 1) % 3]);
    const double ys = std::min(s.y, t.y);
    const double ye = std::max(s.y, t.y);
    if (ye < y0 || ys > y1) continue;
    if (s.y == t.y) {
      lo = std::min({lo, s.x, t.x});
      hi = std::max({hi, s.x, t.x});
      continue;
    }
    for (const double y : {std::max(ys, y0), std::min(ye, y1)}) {
      const double x = s.x + (t.x - s.x) * ((y - s.y) / (t.y - s.y));
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  }
}

Result<SampleGrid> SampleGrid::open(const Lattice& lattice, const Planet& planet,
                                    const fs::path& heightsFile,
                                    const std::vector<fs::path>& samplesFiles,
                                    std::uint32_t bucketCells, const HeightRowStats& stats) {
  return open(lattice, LatticeTiles::dense(lattice.sideCells()), planet, heightsFile, samplesFiles,
              bucketCells, stats);
}

Result<SampleGrid> SampleGrid::open(const Lattice& lattice, const LatticeTiles& tiles,
                                    const Planet& planet, const fs::path& heightsFile,
                                    const std::vector<fs::path>& samplesFiles,
                                    std::uint32_t bucketCells, const HeightRowStats& stats) {
  SampleGrid grid(lattice, tiles, planet);
  auto heights = MappedFile::open(heightsFile);
  if (!heights) return std::move(heights).error();
  const std::uint64_t expected = tiles.pointCount() * sizeof(float);
  if (heights->size() != expected) {
    return makeError(ErrorCode::CorruptData, heightsFile.string() + ": " +
                                                 std::to_string(heights->size()) +
                                                 " bytes, expected " + std::to_string(expected));
  }
  grid.heightsMapping_ = std::move(heights).value();
  grid.setFacePointers(reinterpret_cast<const float*>(grid.heightsMapping_.bytes().data()));
  grid.noDataPoints_ = stats.noDataPoints;
  grid.minHeight_ = stats.minHeightMeters;
  grid.maxHeight_ = stats.maxHeightMeters;

  grid.bucketCells_ = std::max<std::uint32_t>(1, std::min(bucketCells, lattice.sideCells()));
  grid.bucketsPerSide_ = bucketsPerSideOf(lattice, bucketCells);
  const std::size_t buckets =
      6 * static_cast<std::size_t>(grid.bucketsPerSide_) * grid.bucketsPerSide_;
  for (const fs::path& path : samplesFiles) {
    auto mapped = MappedFile::open(path);
    if (!mapped) return std::move(mapped).error();
    const auto bytes = mapped->bytes();
    auto damaged = [&](const std::string& what) {
      return makeError(ErrorCode::CorruptData, path.string() + ": " + what);
    };
    if (bytes.size() < kSamplesHeaderBytes) return damaged("truncated bucket file");
    std::uint32_t version = 0;
    std::uint32_t perSide = 0;
    std::uint64_t total = 0;
    std::uint64_t dense = 0;
    std::uint64_t subOffsets = 0;
    std::memcpy(&version, bytes.data() + 8, 4);
    std::memcpy(&perSide, bytes.data() + 12, 4);
    std::memcpy(&total, bytes.data() + 16, 8);
    std::memcpy(&dense, bytes.data() + 24, 8);
    std::memcpy(&subOffsets, bytes.data() + 32, 8);
    if (std::memcmp(bytes.data(), kSamplesMagic.data(), 8) != 0) {
      return damaged("not a bucket file of this lattice");
    }
    if (version != kSamplesVersion) {
      return damaged("bucket file version " + std::to_string(version) + ", this pbdam writes " +
                     std::to_string(kSamplesVersion) +
                     " (a checkpoint of another pbdam: build again without --resume)");
    }
    if (perSide != grid.bucketsPerSide_) return damaged("not a bucket file of this lattice");
    // Counts bounded by the file's size before any layout arithmetic.
    if (total > bytes.size() || dense > bytes.size() || subOffsets > bytes.size()) {
      return damaged("size mismatch");
    }
    const BucketFileLayout parts = bucketFileLayout(buckets, total, dense, subOffsets);
    if (bytes.size() != parts.bytes) return damaged("size mismatch");
    BucketTable table;
    table.start = reinterpret_cast<const std::uint64_t*>(bytes.data() + parts.start);
    table.samples = reinterpret_cast<const SourceSample*>(bytes.data() + parts.samples);
    table.dense = reinterpret_cast<const DenseBucket*>(bytes.data() + parts.dense);
    table.denseCount = static_cast<std::size_t>(dense);
    table.subStart = reinterpret_cast<const std::uint32_t*>(bytes.data() + parts.subStart);
    if (table.start[0] != 0 || table.start[buckets] != total) return damaged("bad bucket offsets");
    // Every dense bucket's sub-buckets inside its bucket, in order (queries read them unchecked).
    for (std::size_t i = 0; i < table.denseCount; ++i) {
      const DenseBucket& d = table.dense[i];
      const std::uint64_t k = std::uint64_t{d.side} * d.side;
      if (d.bucket >= buckets || (i > 0 && d.bucket <= table.dense[i - 1].bucket) || d.side < 2 ||
          d.side > grid.bucketCells_ || !std::has_single_bit(d.side) || d.first > subOffsets ||
          k + 1 > subOffsets - d.first) {
        return damaged("bad dense bucket " + std::to_string(i));
      }
      const std::uint64_t count =
          table.start[d.bucket + 1] - std::min(table.start[d.bucket], table.start[d.bucket + 1]);
      const std::uint32_t* sub = table.subStart + d.first;
      if (sub[0] != 0 || sub[k] != count || table.start[d.bucket + 1] < table.start[d.bucket] ||
          !std::is_sorted(sub, sub + k + 1)) {
        return damaged("bad sub-bucket offsets of dense bucket " + std::to_string(i));
      }
    }
    grid.tables_.push_back(table);
    grid.samplesMappings_.push_back(std::move(mapped).value());
  }
  return grid;
}

}  // namespace pbdam::builder
