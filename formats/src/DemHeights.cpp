// The heights of a DEM's band (DemHeights.h): decoded to metres and read into memory, or out of
// core in row blocks into a scratch mapping.
#include "DemHeights.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/formats/MemoryMapping.h"

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

Error fail(ErrorCode code, const fs::path& path, const std::string& what) {
  return makeError(code, path.string() + ": " + what);
}

/// Metres per unit for the height units GDAL reports.
std::optional<double> metresPerUnit(std::string units) {
  std::transform(units.begin(), units.end(), units.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (units.empty() || units == "m" || units == "meter" || units == "meters" || units == "metre" ||
      units == "metres") {
    return 1.0;
  }
  if (units == "ft" || units == "foot" || units == "feet" || units == "international foot") {
    return 0.3048;
  }
  if (units == "us-ft" || units == "us survey foot" || units == "ftus") return 1200.0 / 3937.0;
  if (units == "km" || units == "kilometers" || units == "kilometres") return 1000.0;
  return std::nullopt;
}

/// Reads a band's rows as metres, nodata as NaN (scale, offset and length unit applied).
class HeightDecoder final {
 public:
  /// Reads the band's nodata value, scale, offset and unit (recorded in `source`).
  static Result<HeightDecoder> make(GDALRasterBandH band, std::int64_t width, const fs::path& path,
                                    GridSource& source) {
    HeightDecoder d;
    d.band_ = band;
    d.width_ = width;
    int hasNoData = 0;
    d.noData_ = GDALGetRasterNoDataValue(band, &hasNoData);
    d.hasNoData_ = hasNoData != 0;
    if (d.hasNoData_) source.noDataValue = d.noData_;
    int hasScale = 0;
    int hasOffset = 0;
    const double scale = GDALGetRasterScale(band, &hasScale);
    const double offset = GDALGetRasterOffset(band, &hasOffset);
    const char* unitType = GDALGetRasterUnitType(band);
    source.units = unitType != nullptr && *unitType != '\0' ? unitType : "m";
    const auto perUnit = metresPerUnit(unitType != nullptr ? unitType : "");
    if (!perUnit) {
      return fail(ErrorCode::UnsupportedFormat, path,
                  "height unit '" + source.units + "' is not a length unit pbdam knows");
    }
    d.factor_ = (hasScale != 0 ? scale : 1.0) * *perUnit;
    d.shift_ = (hasOffset != 0 ? offset : 0.0) * *perUnit;
    return d;
  }

  /// Reads rows [row, row + rows) into `out` (rows × width floats).
  Result<void> readRows(std::int64_t row, std::int64_t rows, float* out, const fs::path& path,
                        const GdalErrorCapture& capture) const {
    if (GDALRasterIO(band_, GF_Read, 0, static_cast<int>(row), static_cast<int>(width_),
                     static_cast<int>(rows), out, static_cast<int>(width_), static_cast<int>(rows),
                     GDT_Float32, 0, 0) != CE_None ||
        capture.hasFailures()) {
      return fail(ErrorCode::CorruptData, path, withGdal("cannot read the samples", capture));
    }
    const auto noDataFloat = static_cast<float>(noData_);
    for (float& v : std::span(out, static_cast<std::size_t>(rows * width_))) {
      // Huge fill values (ETOPO's −1e34) may differ in their last bits between attribute and
      // data.
      const bool isNoData =
          hasNoData_ && (v == noDataFloat || (std::abs(noData_) > 1e30 && std::abs(v) > 1e30f));
      if (!std::isfinite(v) || isNoData) {
        v = std::numeric_limits<float>::quiet_NaN();
      } else if (factor_ != 1.0 || shift_ != 0.0) {
        v = static_cast<float>(static_cast<double>(v) * factor_ + shift_);
      }
    }
    return {};
  }

  /// Drops what GDAL's block cache (5% of RAM by default) keeps of the rows read so far.
  void flushCache() const { GDALFlushRasterCache(band_); }

 private:
  GDALRasterBandH band_ = nullptr;
  std::int64_t width_ = 0;
  double noData_ = 0.0;
  bool hasNoData_ = false;
  double factor_ = 1.0;
  double shift_ = 0.0;
};

/// Out of core: rows in blocks of about 16 MB straight into the scratch mapping, each block's
/// pages dropped from the process once written (they stay in the page cache).
Result<HeightGrid> readIntoScratch(MemoryMapping scratch, const HeightDecoder& decoder,
                                   const GridGeometry& geometry, GridSource source,
                                   const fs::path& path, const GdalErrorCapture& capture) {
  auto owner = std::make_shared<MemoryMapping>(std::move(scratch));
  auto* heights = reinterpret_cast<float*>(owner->writableBytes().data());
  const std::int64_t width = geometry.width;
  const std::int64_t blockRows = std::max<std::int64_t>(1, (std::int64_t{16} << 20) / (width * 4));
  for (std::int64_t row = 0; row < geometry.height; row += blockRows) {
    const std::int64_t rows = std::min(blockRows, geometry.height - row);
    if (auto r = decoder.readRows(row, rows, heights + row * width, path, capture); !r) {
      return r.error();
    }
    (void)owner->releaseResident(static_cast<std::size_t>(row * width) * sizeof(float),
                                 static_cast<std::size_t>(rows * width) * sizeof(float));
    decoder.flushCache();
  }
  (void)owner->protectReadOnly();
  const float* first = heights;
  return HeightGrid(geometry, std::shared_ptr<const float>(std::move(owner), first), true,
                    std::move(source));
}

}  // namespace

Result<HeightGrid> readDemHeights(GDALRasterBandH band, const GridGeometry& geometry,
                                  GridSource source, const fs::path& path,
                                  const DemReadOptions& options, const GdalErrorCapture& capture) {
  auto decoder = HeightDecoder::make(band, geometry.width, path, source);
  if (!decoder) return std::move(decoder).error();
  const auto bytes = static_cast<std::uint64_t>(geometry.width * geometry.height) * sizeof(float);
  if (!options.scratchDirectory.empty() && bytes >= options.mapAtBytes) {
    if (auto scratch = MemoryMapping::createScratch(options.scratchDirectory, bytes)) {
      return readIntoScratch(std::move(scratch).value(), *decoder, geometry, std::move(source),
                             path, capture);
    }
  }
  std::vector<float> heights(static_cast<std::size_t>(geometry.width * geometry.height));
  if (auto r = decoder->readRows(0, geometry.height, heights.data(), path, capture); !r) {
    return r.error();
  }
  return HeightGrid(geometry, std::move(heights), std::move(source));
}

}  // namespace pbdam::formats
