// GDAL's fill-nodata over an in-memory raster (NodataFill.h).
#include "pbdam/formats/NodataFill.h"

#include <cpl_error.h>
#include <gdal.h>
#include <gdal_alg.h>

#include <cassert>
#include <cmath>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

namespace pbdam::formats {
namespace {

struct DatasetCloser {
  void operator()(GDALDatasetH ds) const noexcept { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<std::remove_pointer_t<GDALDatasetH>, DatasetCloser>;

GDALDriverH memDriver() {
  // GDALAllRegister once (a function-local static, as DemReader.cpp does: GDAL's own mutex
  // inside call_once reads as a lock-order inversion to ThreadSanitizer).
  static const bool registered = [] {
    GDALAllRegister();
    return true;
  }();
  (void)registered;
  return GDALGetDriverByName("MEM");
}

std::string lastGdalError() {
  const char* message = CPLGetLastErrorMsg();
  return message != nullptr && *message != '\0' ? std::string(" (GDAL: ") + message + ")" : "";
}

}  // namespace

Result<void> fillNodata(std::span<float> heightsMeters, std::int64_t width, std::int64_t height,
                        double maxSearchDistanceSamples) {
  assert(width > 0 && height > 0 &&
         heightsMeters.size() == static_cast<std::size_t>(width * height));
  if (width > INT32_MAX || height > INT32_MAX) {
    return makeError(ErrorCode::InvalidArgument, "fill-nodata: a window of " +
                                                     std::to_string(width) + "x" +
                                                     std::to_string(height) + " is too large");
  }
  GDALDriverH driver = memDriver();
  if (driver == nullptr) return makeError(ErrorCode::Internal, "fill-nodata: no GDAL MEM driver");
  const int w = static_cast<int>(width), h = static_cast<int>(height);
  DatasetPtr values(GDALCreate(driver, "", w, h, 1, GDT_Float32, nullptr));
  DatasetPtr mask(GDALCreate(driver, "", w, h, 1, GDT_Byte, nullptr));
  if (!values || !mask) {
    return makeError(ErrorCode::Internal, "fill-nodata: cannot create a " + std::to_string(w) +
                                              "x" + std::to_string(h) + " raster" +
                                              lastGdalError());
  }
  std::vector<std::uint8_t> valid(heightsMeters.size());
  for (std::size_t i = 0; i < valid.size(); ++i) valid[i] = std::isnan(heightsMeters[i]) ? 0 : 255;
  GDALRasterBandH valueBand = GDALGetRasterBand(values.get(), 1);
  GDALRasterBandH maskBand = GDALGetRasterBand(mask.get(), 1);
  if (GDALRasterIO(valueBand, GF_Write, 0, 0, w, h, heightsMeters.data(), w, h, GDT_Float32, 0,
                   0) != CE_None ||
      GDALRasterIO(maskBand, GF_Write, 0, 0, w, h, valid.data(), w, h, GDT_Byte, 0, 0) != CE_None ||
      GDALFillNodata(valueBand, maskBand, maxSearchDistanceSamples, 0, 0, nullptr, nullptr,
                     nullptr) != CE_None ||
      GDALRasterIO(valueBand, GF_Read, 0, 0, w, h, heightsMeters.data(), w, h, GDT_Float32, 0, 0) !=
          CE_None) {
    return makeError(ErrorCode::Internal, "fill-nodata failed" + lastGdalError());
  }
  return {};
}

}  // namespace pbdam::formats
