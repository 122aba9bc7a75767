// Imagery ingest through OpenImageIO, georeference through GDAL (Image.h).
#include "pbdam/formats/Image.h"

#include <OpenImageIO/imageio.h>
#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
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

/// The file's geographic bounds when GDAL finds a north-up geographic georeference in it.
std::optional<LatLonBounds> georeference(const std::filesystem::path& path) {
  static const bool registered = [] {
    GDALAllRegister();
    return true;
  }();
  (void)registered;
  CPLPushErrorHandler(CPLQuietErrorHandler);
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO");
  std::optional<LatLonBounds> bounds;
  if (GDALDatasetH ds =
          GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
      ds != nullptr) {
    double gt[6] = {};
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds);
    if (srs != nullptr && OSRIsGeographic(srs) != 0 && GDALGetGeoTransform(ds, gt) == CE_None &&
        gt[2] == 0.0 && gt[4] == 0.0 && gt[5] < 0.0) {
      const double w = GDALGetRasterXSize(ds);
      const double h = GDALGetRasterYSize(ds);
      bounds = LatLonBounds{gt[3] + h * gt[5], gt[0], gt[3], gt[0] + w * gt[1]};
    }
    GDALClose(ds);
  }
  CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr);
  CPLPopErrorHandler();
  return bounds;
}

}  // namespace

Result<GeoImage> readImage(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return makeError(ErrorCode::NotFound, path.string() + ": no such file");
  }
  auto input = OIIO::ImageInput::open(path.string());
  if (!input) {
    return makeError(
        ErrorCode::UnsupportedFormat,
        path.string() + ": not an image OpenImageIO can read (" + OIIO::geterror() + ")");
  }
  const OIIO::ImageSpec& spec = input->spec();
  if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.depth > 1) {
    return makeError(ErrorCode::UnsupportedFormat,
                     path.string() + ": unsupported image layout (" + std::to_string(spec.width) +
                         "x" + std::to_string(spec.height) + ", " + std::to_string(spec.nchannels) +
                         " channels)");
  }
  const auto width = static_cast<std::int64_t>(spec.width);
  const auto height = static_cast<std::int64_t>(spec.height);
  const int channels = std::min(spec.nchannels, 4);
  std::vector<std::uint8_t> pixels(static_cast<std::size_t>(width * height * channels));
  // Decoders such as libjpeg report a truncated file as a warning and fill the rest: any
  // message recorded during the read makes the image corrupt.
  const bool decoded = input->read_image(0, 0, 0, channels, OIIO::TypeDesc::UINT8, pixels.data());
  if (!decoded || input->has_error()) {
    return makeError(ErrorCode::CorruptData,
                     path.string() + ": cannot decode the pixels (" + input->geterror() + ")");
  }
  input->close();
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
  const auto geo = georeference(path);
  return GeoImage(width, height, std::move(rgba),
                  geo.value_or(LatLonBounds{-90.0, -180.0, 90.0, 180.0}), geo.has_value());
}

}  // namespace pbdam::formats
