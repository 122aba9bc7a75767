// Byte rasters as GeoTIFF through GDAL (GeoTiffWriter.h).
#include "pbdam/formats/GeoTiffWriter.h"

#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <memory>

namespace pbdam::formats {
namespace {

struct DatasetCloser final {
  void operator()(GDALDataset* d) const noexcept { GDALClose(d); }
};

}  // namespace

Result<std::string> azimuthalEquidistantWkt(double lat0Degrees, double lon0Degrees,
                                            double semiMajorMeters, double flattening,
                                            const std::string& body) {
  OGRSpatialReference srs;
  const double inverseFlattening = flattening > 0.0 ? 1.0 / flattening : 0.0;
  if (srs.SetGeogCS(body.c_str(), (body + " datum").c_str(), body.c_str(), semiMajorMeters,
                    inverseFlattening) != OGRERR_NONE ||
      srs.SetProjCS((body + " azimuthal equidistant").c_str()) != OGRERR_NONE ||
      srs.SetAE(lat0Degrees, lon0Degrees, 0.0, 0.0) != OGRERR_NONE ||
      srs.SetLinearUnits(SRS_UL_METER, 1.0) != OGRERR_NONE) {
    return makeError(ErrorCode::InvalidArgument,
                     "GDAL refuses an azimuthal equidistant CRS centred on " +
                         std::to_string(lat0Degrees) + ", " + std::to_string(lon0Degrees));
  }
  char* wkt = nullptr;
  if (srs.exportToWkt(&wkt) != OGRERR_NONE || wkt == nullptr) {
    CPLFree(wkt);
    return makeError(ErrorCode::InvalidArgument, "GDAL cannot write the viewshed's CRS as WKT");
  }
  std::string text(wkt);
  CPLFree(wkt);
  return text;
}

Result<std::vector<std::byte>> encodeByteGeoTiff(const ByteRaster& raster) {
  if (raster.width <= 0 || raster.height <= 0 ||
      raster.cells.size() !=
          static_cast<std::size_t>(raster.width) * static_cast<std::size_t>(raster.height)) {
    return makeError(ErrorCode::InvalidArgument, "GeoTIFF: " + std::to_string(raster.cells.size()) +
                                                     " cells for a " +
                                                     std::to_string(raster.width) + " x " +
                                                     std::to_string(raster.height) + " raster");
  }
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) return makeError(ErrorCode::UnsupportedFormat, "GDAL has no GTiff driver");
  static std::atomic<unsigned> serial{0};
  const std::string name = "/vsimem/pbdam_mask_" + std::to_string(::getpid()) + "_" +
                           std::to_string(serial.fetch_add(1)) + ".tif";
  char** options = nullptr;
  options = CSLSetNameValue(options, "COMPRESS", "DEFLATE");
  options = CSLSetNameValue(options, "TILED", "YES");
  std::unique_ptr<GDALDataset, DatasetCloser> out(
      driver->Create(name.c_str(), raster.width, raster.height, 1, GDT_Byte, options));
  CSLDestroy(options);
  if (!out) {
    return makeError(ErrorCode::UnsupportedFormat,
                     "GDAL cannot create a GeoTIFF: " + std::string(CPLGetLastErrorMsg()));
  }
  std::array<double, 6> transform = raster.geoTransform;
  out->SetGeoTransform(transform.data());
  if (!raster.srsWkt.empty()) {
    OGRSpatialReference srs;
    if (srs.importFromWkt(raster.srsWkt.c_str()) != OGRERR_NONE) {
      out.reset();
      VSIUnlink(name.c_str());
      return makeError(ErrorCode::InvalidArgument, "GeoTIFF: GDAL refuses the CRS's WKT");
    }
    out->SetSpatialRef(&srs);
  }
  for (const auto& [key, value] : raster.metadata) {
    out->SetMetadataItem(key.c_str(), value.c_str());
  }
  GDALRasterBand* band = out->GetRasterBand(1);
  if (raster.noData) band->SetNoDataValue(*raster.noData);
  if (!raster.colours.empty()) {
    GDALColorTable table;
    for (const auto& [value, rgba] : raster.colours) {
      const GDALColorEntry entry{rgba[0], rgba[1], rgba[2], rgba[3]};
      table.SetColorEntry(value, &entry);
    }
    band->SetColorTable(&table);
    band->SetColorInterpretation(GCI_PaletteIndex);
  }
  const CPLErr wrote = band->RasterIO(GF_Write, 0, 0, raster.width, raster.height,
                                      const_cast<std::uint8_t*>(raster.cells.data()), raster.width,
                                      raster.height, GDT_Byte, 0, 0);
  out.reset();  // flushes into /vsimem/
  vsi_l_offset length = 0;
  GByte* bytes = VSIGetMemFileBuffer(name.c_str(), &length, FALSE);
  if (wrote != CE_None || bytes == nullptr) {
    VSIUnlink(name.c_str());
    return makeError(ErrorCode::UnsupportedFormat,
                     "GDAL cannot write the GeoTIFF: " + std::string(CPLGetLastErrorMsg()));
  }
  std::vector<std::byte> file(static_cast<std::size_t>(length));
  std::memcpy(file.data(), bytes, file.size());
  VSIUnlink(name.c_str());
  return file;
}

}  // namespace pbdam::formats
