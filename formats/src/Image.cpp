// Imagery ingest through OpenImageIO (its module, ImageCodec.h), georeference through GDAL
// (Image.h).
#include "pbdam/formats/Image.h"

#include "pbdam/formats/DemTileSet.h"
#include "pbdam/formats/ImageCodec.h"

#include <cpl_conv.h>
#include <gdal.h>
#include <gdal_utils.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>

namespace pbdam::formats {

GeoImage::GeoImage(std::int64_t width, std::int64_t height, std::vector<std::uint8_t> rgba,
                   LatLonBounds bounds, bool georeferenced)
    : width_(width),
      height_(height),
      rgba_(std::move(rgba)),
      bounds_(bounds),
      georeferenced_(georeferenced) {}

std::array<std::uint8_t, 4> GeoImage::pixel(std::int64_t x, std::int64_t y) const noexcept {
  const auto base = static_cast<std::size_t>((y * width_ + x) * 4);
  return {rgba_[base], rgba_[base + 1], rgba_[base + 2], rgba_[base + 3]};
}

std::optional<std::array<float, 4>> GeoImage::sampleBilinear(double latDegrees,
                                                             double lonDegrees) const noexcept {
  if (!std::isfinite(latDegrees) || !std::isfinite(lonDegrees) || width_ == 0) return std::nullopt;
  const double spanLon = bounds_.eastDegrees - bounds_.westDegrees;
  const bool global = std::abs(spanLon - 360.0) < 1e-9;
  double lon = lonDegrees - bounds_.westDegrees;
  lon -= 360.0 * std::floor(lon / 360.0);
  if (!global && lon > spanLon) return std::nullopt;
  if (latDegrees > bounds_.northDegrees || latDegrees < bounds_.southDegrees) return std::nullopt;
  const double x = lon / spanLon * static_cast<double>(width_) - 0.5;
  const double y = (bounds_.northDegrees - latDegrees) /
                       (bounds_.northDegrees - bounds_.southDegrees) *
                       static_cast<double>(height_) -
                   0.5;
  const double x0 = std::floor(x);
  const double y0 = std::floor(y);
  const double fx = x - x0;
  const double fy = y - y0;
  auto col = [&](double c) {
    auto i = static_cast<std::int64_t>(c);
    if (global) return ((i % width_) + width_) % width_;
    return std::clamp<std::int64_t>(i, 0, width_ - 1);
  };
  auto row = [&](double r) {
    return std::clamp<std::int64_t>(static_cast<std::int64_t>(r), 0, height_ - 1);
  };
  const auto p00 = pixel(col(x0), row(y0));
  const auto p01 = pixel(col(x0 + 1), row(y0));
  const auto p10 = pixel(col(x0), row(y0 + 1));
  const auto p11 = pixel(col(x0 + 1), row(y0 + 1));
  std::array<float, 4> out{};
  for (std::size_t c = 0; c < 4; ++c) {
    const double top = (1.0 - fx) * p00[c] + fx * p01[c];
    const double bottom = (1.0 - fx) * p10[c] + fx * p11[c];
    out[c] = static_cast<float>((1.0 - fy) * top + fy * bottom);
  }
  return out;
}

namespace {

void registerGdal() {
  static const bool registered = [] {
    GDALAllRegister();
    return true;
  }();
  (void)registered;
}

/// What GDAL finds in the file: a north-up geographic georeference (its bounds), a projected
/// one (the image must be warped), or none.
struct Georeference final {
  std::optional<LatLonBounds> bounds;
  bool projected = false;
};

Georeference georeference(const std::filesystem::path& path) {
  registerGdal();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
  Georeference found;
  if (GDALDatasetH ds =
          GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
      ds != nullptr) {
    double gt[6] = {};
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
    const bool transform = GDALGetGeoTransform(ds, gt) == CE_None;
    if (srs != nullptr && OSRIsGeographic(srs) != 0 && transform && gt[2] == 0.0 && gt[4] == 0.0 &&
        gt[5] < 0.0) {
      const double w = GDALGetRasterXSize(ds);
      const double h = GDALGetRasterYSize(ds);
      found.bounds = LatLonBounds{gt[3] + h * gt[5], gt[0], gt[3], gt[0] + w * gt[1]};
    } else if (srs != nullptr && OSRIsProjected(srs) != 0 && transform) {
      found.projected = true;
    }
    GDALClose(ds);
  }
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
  CPLPopErrorHandler();
  return found;
}

/// The pixels of a north-up geographic GDAL dataset whose last band is alpha, as RGBA8 (colour
/// bands 1..3; a grey band thrice). `fail` makes the error naming what was read.
Result<GeoImage> rgbaOf(GDALDatasetH ds, const std::function<Error(const std::string&)>& fail) {
  double gt[6] = {};
  const std::int64_t width = GDALGetRasterXSize(ds);
  const std::int64_t height = GDALGetRasterYSize(ds);
  const int out = GDALGetRasterCount(ds);  // colour bands, then alpha
  if (GDALGetGeoTransform(ds, gt) != CE_None || gt[2] != 0.0 || gt[4] != 0.0 || gt[5] >= 0.0 ||
      width < 1 || height < 1 || out < 2) {
    return fail("not a north-up grid");
  }
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(width * height * 4));
  const int colours = out - 1;
  bool read = true;
  for (int c = 0; c < 4 && read; ++c) {
    const int band = c == 3 ? out : std::min(c + 1, colours);
    read =
        GDALRasterIO(GDALGetRasterBand(ds, band), GF_Read, 0, 0, static_cast<int>(width),
                     static_cast<int>(height), rgba.data() + c, static_cast<int>(width),
                     static_cast<int>(height), GDT_Byte, 4, static_cast<int>(width * 4)) == CE_None;
  }
  if (!read) return fail("GDAL could not read its pixels");
  return GeoImage(width, height, std::move(rgba),
                  LatLonBounds{gt[3] + static_cast<double>(height) * gt[5], gt[0], gt[3],
                               gt[0] + static_cast<double>(width) * gt[1]},
                  true);
}

/// `source` (8-bit bands, projected) warped by GDAL's warper to the geographic CRS of its own
/// datum (bilinear, GDAL's default resolution), as RGBA8 with alpha 0 where the warp has no
/// source. Closes nothing.
Result<GeoImage> warpedImage(GDALDatasetH source,
                             const std::function<Error(const std::string&)>& fail) {
  const int bands = GDALGetRasterCount(source);
  if (bands < 1 || GDALGetRasterDataType(GDALGetRasterBand(source, 1)) != GDT_Byte) {
    return fail("it needs 8-bit bands");
  }
  OGRSpatialReferenceH geographic = OSRCloneGeogCS(GDALGetSpatialRef(source));
  char* wkt = nullptr;
  if (geographic != nullptr) OSRExportToWkt(geographic, &wkt);
  std::string target = wkt != nullptr ? wkt : "";
  CPLFree(wkt);
  OSRDestroySpatialReference(geographic);
  if (target.empty()) return fail("its CRS has no geographic base");
  // An alpha band of the source is carried as such; otherwise the warper adds one.
  const bool hasAlpha =
      GDALGetRasterColorInterpretation(GDALGetRasterBand(source, bands)) == GCI_AlphaBand;
  std::vector<std::string> args = {"-of", "MEM", "-t_srs", target, "-r", "bilinear"};
  if (!hasAlpha) args.emplace_back("-dstalpha");
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  CPLPushErrorHandler(CPLQuietErrorHandler);
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(argv.data(), nullptr);
  int usageError = 0;
  GDALDatasetH inputs[1] = {source};
  GDALDatasetH warped = GDALWarp("", nullptr, 1, inputs, options, &usageError);
  GDALWarpAppOptionsFree(options);
  CPLPopErrorHandler();
  if (warped == nullptr) return fail("GDAL's warper failed");
  auto image = rgbaOf(warped, [&](const std::string& why) { return fail("the warp is " + why); });
  GDALClose(warped);
  return image;
}

/// A projected image warped to geographic (warpedImage).
Result<GeoImage> readWarpedImage(const std::filesystem::path& path) {
  registerGdal();
  const auto fail = [&path](const std::string& why) {
    return makeError(
        ErrorCode::UnsupportedFormat,
        path.string() + ": a projected image that cannot be warped to geographic (" + why + ")");
  };
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
  GDALDatasetH source =
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
  if (source == nullptr) return fail("GDAL cannot open it");
  auto image = warpedImage(source, fail);
  GDALClose(source);
  return image;
}

/// Imagery tiles (a directory or a glob of georeferenced images) as one image: a GDAL VRT
/// mosaic of them with an alpha band (0 where no tile lies), warped when projected.
Result<GeoImage> readImageSet(const std::filesystem::path& path) {
  auto files = expandDemSet(path);
  if (!files) return std::move(files).error();
  registerGdal();
  for (const std::filesystem::path& file : *files) {
    if (const Georeference geo = georeference(file); !geo.bounds && !geo.projected) {
      return makeError(ErrorCode::UnsupportedFormat,
                       file.string() + ": an imagery tile of a set must be georeferenced (or " +
                           "give the image alone, to cover its inset)");
    }
  }
  const auto fail = [&path](const std::string& why) {
    return makeError(ErrorCode::UnsupportedFormat,
                     path.string() + ": its imagery tiles cannot be joined (" + why + ")");
  };
  std::vector<std::string> names;
  std::vector<const char*> pointers;
  names.reserve(files->size());
  pointers.reserve(files->size());
  for (const auto& file : *files) names.push_back(file.string());
  for (const auto& name : names) pointers.push_back(name.c_str());
  std::string addAlpha = "-addalpha";
  std::vector<char*> argv = {addAlpha.data(), nullptr};
  CPLPushErrorHandler(CPLQuietErrorHandler);
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
  GDALBuildVRTOptions* options = GDALBuildVRTOptionsNew(argv.data(), nullptr);
  int usageError = 0;
  GDALDatasetH mosaic = GDALBuildVRT("", static_cast<int>(pointers.size()), nullptr,
                                     pointers.data(), options, &usageError);
  GDALBuildVRTOptionsFree(options);
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
  CPLPopErrorHandler();
  if (mosaic == nullptr) return fail("GDAL could not build a mosaic of them");
  Result<GeoImage> image = fail("no georeference");
  if (GDALGetRasterDataType(GDALGetRasterBand(mosaic, 1)) != GDT_Byte) {
    image = fail("they need 8-bit bands");
  } else if (OGRSpatialReferenceH srs = GDALGetSpatialRef(mosaic);
             srs != nullptr && OSRIsProjected(srs) != 0) {
    image = warpedImage(mosaic, fail);
  } else {
    image = rgbaOf(mosaic, [&](const std::string& why) { return fail("the mosaic is " + why); });
  }
  GDALClose(mosaic);
  return image;
}

}  // namespace

Result<GeoImage> readImage(const std::filesystem::path& path) {
  if (namesDemSet(path)) return readImageSet(path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return makeError(ErrorCode::NotFound, path.string() + ": no such file");
  }
  const Result<const ImageCodec*> codec = imageCodec();
  if (!codec) return codec.error();
  Result<Pixels8> read = (*codec)->read(path);
  if (!read) return makeError(read.error().code, path.string() + ": " + read.error().message);
  const std::int64_t width = read->width;
  const std::int64_t height = read->height;
  const int channels = read->channels;
  const std::vector<std::uint8_t>& pixels = read->bytes;
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(width * height * 4));
  for (std::size_t p = 0; p < static_cast<std::size_t>(width * height); ++p) {
    const std::uint8_t* src = &pixels[p * static_cast<std::size_t>(channels)];
    std::uint8_t* dst = &rgba[p * 4];
    if (channels >= 3) {
      dst[0] = src[0];
      dst[1] = src[1];
      dst[2] = src[2];
    } else {
      dst[0] = dst[1] = dst[2] = src[0];
    }
    dst[3] = channels == 4 ? src[3] : (channels == 2 ? src[1] : 255);
  }
  const Georeference geo = georeference(path);
  if (geo.projected) return readWarpedImage(path);
  return GeoImage(width, height, std::move(rgba),
                  geo.bounds.value_or(LatLonBounds{-90.0, -180.0, 90.0, 180.0}),
                  geo.bounds.has_value());
}

}  // namespace pbdam::formats
