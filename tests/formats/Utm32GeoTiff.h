// A projected GeoTIFF for the readers' tests: UTM zone 32N, 1 km cells from (300 km E,
// 5600 km N), west of the zone's central meridian (9°E), so the grid is visibly rotated and
// curved in latitude/longitude. Shared by the DEM and imagery tests.
#pragma once

#include <gdal.h>
#include <ogr_srs_api.h>

#include <array>
#include <filesystem>
#include <vector>

namespace pbdam::test {

inline constexpr std::array<double, 6> kUtm32Transform = {300000.0,  1000.0, 0.0,
                                                          5600000.0, 0.0,    -1000.0};

/// Writes `bands` (each w·h values of GDAL type `type`, row-major) as a GeoTIFF on the grid
/// above. False when GDAL cannot.
template <typename T>
bool writeUtm32GeoTiff(const std::filesystem::path& path, int w, int h, GDALDataType type,
                       const std::vector<std::vector<T>>& bands) {
  GDALAllRegister();
  GDALDriverH gtiff = GDALGetDriverByName("GTiff");
  if (gtiff == nullptr) return false;
  GDALDatasetH ds =
      GDALCreate(gtiff, path.c_str(), w, h, static_cast<int>(bands.size()), type, nullptr);
  if (ds == nullptr) return false;
  std::array<double, 6> gt = kUtm32Transform;
  GDALSetGeoTransform(ds, gt.data());
  OGRSpatialReferenceH utm = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(utm, 32632);
  GDALSetSpatialRef(ds, utm);
  OSRDestroySpatialReference(utm);
  bool ok = true;
  for (std::size_t b = 0; b < bands.size(); ++b) {
    std::vector<T> values = bands[b];
    ok = ok && GDALRasterIO(GDALGetRasterBand(ds, static_cast<int>(b) + 1), GF_Write, 0, 0, w, h,
                            values.data(), w, h, type, 0, 0) == CE_None;
  }
  GDALClose(ds);
  return ok;
}

/// Converts `count` points from the grid's UTM metres to longitude (x) and latitude (y) in place.
inline bool utm32ToLonLat(double* x, double* y, int count) {
  OGRSpatialReferenceH utm = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(utm, 32632);
  OGRSpatialReferenceH wgs84 = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(wgs84, 4326);
  OSRSetAxisMappingStrategy(wgs84, OAMS_TRADITIONAL_GIS_ORDER);
  OSRSetAxisMappingStrategy(utm, OAMS_TRADITIONAL_GIS_ORDER);
  OGRCoordinateTransformationH toGeo = OCTNewCoordinateTransformation(utm, wgs84);
  const bool ok = toGeo != nullptr && OCTTransform(toGeo, count, x, y, nullptr) != 0;
  if (toGeo != nullptr) OCTDestroyCoordinateTransformation(toGeo);
  OSRDestroySpatialReference(wgs84);
  OSRDestroySpatialReference(utm);
  return ok;
}

}  // namespace pbdam::test
