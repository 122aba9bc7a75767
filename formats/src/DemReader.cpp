// Elevation ingest through GDAL (DemReader.h). GDAL identifies and decodes the file; this file
// turns its georeference into sample-centre latitude/longitude, converts or warps projected
// CRSs and checks raw layouts against the file size (GDAL reads short raw files without
// complaint in some drivers); the heights are read by DemHeights.h (nodata to NaN, out of core
// for a large grid).
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/DemTileSet.h"

#include "DemHeights.h"
#include "GdalErrorCapture.h"
#include "pbdam/formats/NumberList.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <gdalwarper.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <sstream>
#include <vector>

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

void registerGdalOnce() {
  // A function-local static rather than std::call_once: GDAL takes its own mutex inside, which
  // ThreadSanitizer reports as a lock-order inversion against call_once's lock.
  static const bool registered = [] {
    GDALAllRegister();
    return true;
  }();
  (void)registered;
}
/// Sets a GDAL configuration option on this thread for the lifetime of the object.
class ScopedConfig final {
 public:
  ScopedConfig(const char* key, const char* value) : key_(key) {
    const char* old = CPLGetThreadLocalConfigOption(key, nullptr);
    if (old != nullptr) old_ = old;
    CPLSetThreadLocalConfigOption(key, value);
  }
  ~ScopedConfig() { CPLSetThreadLocalConfigOption(key_, old_ ? old_->c_str() : nullptr); }
  ScopedConfig(const ScopedConfig&) = delete;
  ScopedConfig& operator=(const ScopedConfig&) = delete;

 private:
  const char* key_;
  std::optional<std::string> old_;
};

struct DatasetCloser {
  void operator()(GDALDatasetH ds) const noexcept { GDALClose(ds); }
};
using DatasetPtr = std::unique_ptr<std::remove_pointer_t<GDALDatasetH>, DatasetCloser>;

Error fail(ErrorCode code, const fs::path& path, const std::string& what) {
  return makeError(code, path.string() + ": " + what);
}

std::string formatDouble(double value, int digits = 10) {
  std::ostringstream out;
  out.precision(digits);
  out << value;
  return out.str();
}

std::string xmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::int64_t rawTypeBytes(RawSampleType type) {
  switch (type) {
    case RawSampleType::UInt8:
      return 1;
    case RawSampleType::Int16:
    case RawSampleType::UInt16:
      return 2;
    case RawSampleType::Int32:
    case RawSampleType::UInt32:
    case RawSampleType::Float32:
      return 4;
    case RawSampleType::Float64:
      return 8;
  }
  return 1;
}

const char* rawTypeGdalName(RawSampleType type) {
  switch (type) {
    case RawSampleType::UInt8:
      return "Byte";
    case RawSampleType::Int16:
      return "Int16";
    case RawSampleType::UInt16:
      return "UInt16";
    case RawSampleType::Int32:
      return "Int32";
    case RawSampleType::UInt32:
      return "UInt32";
    case RawSampleType::Float32:
      return "Float32";
    case RawSampleType::Float64:
      return "Float64";
  }
  return "Byte";
}

/// A VRT description that makes GDAL read the raw file (GDAL's raw support, not our parser).
std::string rawVrtXml(const fs::path& path, const RawLayout& raw) {
  const double dx =
      (raw.bounds.eastDegrees - raw.bounds.westDegrees) / static_cast<double>(raw.width);
  const double dy =
      (raw.bounds.northDegrees - raw.bounds.southDegrees) / static_cast<double>(raw.height);
  const std::int64_t bytes = rawTypeBytes(raw.type);
  std::ostringstream xml;
  xml.precision(17);
  xml << "<VRTDataset rasterXSize=\"" << raw.width << "\" rasterYSize=\"" << raw.height << "\">"
      << "<GeoTransform>" << raw.bounds.westDegrees << "," << dx << ",0," << raw.bounds.northDegrees
      << ",0," << -dy << "</GeoTransform>"
      << "<VRTRasterBand dataType=\"" << rawTypeGdalName(raw.type)
      << "\" band=\"1\" subClass=\"VRTRawRasterBand\">"
      << "<SourceFilename relativeToVRT=\"0\">" << xmlEscape(fs::absolute(path).string())
      << "</SourceFilename><ImageOffset>" << raw.headerBytes << "</ImageOffset><PixelOffset>"
      << bytes << "</PixelOffset><LineOffset>" << bytes * raw.width << "</LineOffset>"
      << "<ByteOrder>" << (raw.bigEndian ? "MSB" : "LSB") << "</ByteOrder>"
      << "</VRTRasterBand></VRTDataset>";
  return xml.str();
}

/// Snaps a spacing to 1/n degree and an origin to a multiple of half a cell when they are that
/// within rounding of the file's numbers (ETOPO5's float32 axis, MOLA's 14.818 km/px scale).
double snapSpacing(double spacing) {
  const double perDegree = 1.0 / spacing;
  const double n = std::round(perDegree);
  if (n >= 1.0 && std::abs(perDegree - n) <= 1e-4 * n) return 1.0 / n;
  return spacing;
}

double snapOrigin(double origin, double spacing) {
  const double halves = origin / (0.5 * spacing);
  const double n = std::round(halves);
  if (std::abs(halves - n) <= 0.05) return n * 0.5 * spacing;
  return origin;
}

/// Geographic georeference of a dataset: corner-based like a GDAL geotransform, in degrees.
struct GeoRef final {
  double westDegrees = 0.0;
  double northDegrees = 0.0;
  double lonSpacingDegrees = 0.0;
  double latSpacingDegrees = 0.0;
};

std::string bodyForSemiMajor(double a) {
  if (a > 3.3e6 && a < 3.5e6) return "mars";
  if (a > 6.3e6 && a < 6.4e6) return "earth";
  if (a > 1.7e6 && a < 1.8e6) return "moon";
  return "";
}

/// Converts a projected, axis-aligned georeference to degrees when the projection is linear in
/// latitude and longitude over the grid (equirectangular); nullopt when it is not.
std::optional<GeoRef> linearGeographic(const OGRSpatialReference& projected,
                                       const std::array<double, 6>& gt, std::int64_t width,
                                       std::int64_t height) {
  std::unique_ptr<OGRSpatialReference> geographic(projected.CloneGeogCS());
  if (!geographic) return std::nullopt;
  geographic->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  OGRSpatialReference source(projected);
  source.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> toGeo(
      OGRCreateCoordinateTransformation(&source, geographic.get()));
  if (!toGeo) return std::nullopt;
  auto lonLat = [&](double px, double py, double& lon, double& lat) {
    lon = gt[0] + px * gt[1];
    lat = gt[3] + py * gt[5];
    return toGeo->Transform(1, &lon, &lat) != 0 && std::isfinite(lon) && std::isfinite(lat);
  };
  double lon0 = 0, lat0 = 0, lon1 = 0, lat1 = 0, lon2 = 0, lat2 = 0;
  // Spacing from one cell near the origin (avoids the ±180° wrap of far corners).
  if (!lonLat(0.5, 0.5, lon0, lat0) || !lonLat(1.5, 0.5, lon1, lat1) ||
      !lonLat(0.5, 1.5, lon2, lat2)) {
    return std::nullopt;
  }
  const double dLon = lon1 - lon0;
  const double dLat = lat0 - lat2;
  if (!(dLon > 0.0) || !(dLat > 0.0) || std::abs(lat1 - lat0) > 1e-9 ||
      std::abs(lon2 - lon0) > 1e-9 * std::max(1.0, std::abs(lon0))) {
    return std::nullopt;
  }
  // Linear means every sample centre is where the origin and spacing put it.
  const std::array<double, 3> fx = {0.5, 0.5 * static_cast<double>(width),
                                    static_cast<double>(width) - 0.5};
  const std::array<double, 3> fy = {0.5, 0.5 * static_cast<double>(height),
                                    static_cast<double>(height) - 0.5};
  for (double px : fx) {
    for (double py : fy) {
      double lon = 0, lat = 0;
      if (!lonLat(px, py, lon, lat)) return std::nullopt;
      const double expectLon = lon0 + (px - 0.5) * dLon;
      const double expectLat = lat0 - (py - 0.5) * dLat;
      const double lonError = std::remainder(lon - expectLon, 360.0);
      if (std::abs(lonError) > 1e-6 * dLon || std::abs(lat - expectLat) > 1e-6 * dLat) {
        return std::nullopt;
      }
    }
  }
  return GeoRef{lon0 - 0.5 * dLon, lat0 + 0.5 * dLat, dLon, dLat};
}

/// Warps a projected dataset to the geographic CRS of its own datum at native resolution.
DatasetPtr warpToGeographic(GDALDatasetH source, const OGRSpatialReference& projected,
                            std::string& why) {
  std::unique_ptr<OGRSpatialReference> geographic(projected.CloneGeogCS());
  if (!geographic) {
    why = "its CRS has no geographic base";
    return nullptr;
  }
  char* wkt = nullptr;
  geographic->exportToWkt(&wkt);
  std::string wktString = wkt != nullptr ? wkt : "";
  CPLFree(wkt);
  // Native resolution: the source's finer cell size in metres, as degrees of latitude, and as
  // degrees of longitude at the grid's centre latitude (GDAL's default would use square degree
  // cells and undersample latitude away from the equator).
  std::array<double, 6> gt{};
  GDALGetGeoTransform(source, gt.data());
  const double cellMeters =
      std::min(std::hypot(gt[1], gt[4]), std::hypot(gt[2], gt[5])) * projected.GetLinearUnits();
  OGRSpatialReference src(projected);
  src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  geographic->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> toGeo(
      OGRCreateCoordinateTransformation(&src, geographic.get()));
  double cx =
      gt[0] + 0.5 * GDALGetRasterXSize(source) * gt[1] + 0.5 * GDALGetRasterYSize(source) * gt[2];
  double cy =
      gt[3] + 0.5 * GDALGetRasterXSize(source) * gt[4] + 0.5 * GDALGetRasterYSize(source) * gt[5];
  if (!toGeo || !toGeo->Transform(1, &cx, &cy) || !(cellMeters > 0.0)) {
    why = "cannot find the grid's centre in geographic coordinates";
    return nullptr;
  }
  const double metresPerDegree = geographic->GetSemiMajor() * M_PI / 180.0;
  const double dLat = cellMeters / metresPerDegree;
  const double dLon = dLat / std::max(0.01, std::cos(cy * M_PI / 180.0));
  std::vector<std::string> args = {"-of",
                                   "MEM",
                                   "-t_srs",
                                   wktString,
                                   "-r",
                                   "bilinear",
                                   "-ot",
                                   "Float32",
                                   "-dstnodata",
                                   "nan",
                                   "-tr",
                                   formatDouble(dLon, 17),
                                   formatDouble(dLat, 17)};
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(argv.data(), nullptr);
  int usageError = 0;
  GDALDatasetH inputs[1] = {source};
  GDALDatasetH warped = GDALWarp("", nullptr, 1, inputs, options, &usageError);
  GDALWarpAppOptionsFree(options);
  if (warped == nullptr) why = "GDAL's warper could not reproject it to geographic";
  return DatasetPtr(warped);
}

/// Checks that the raw bytes a raw-layout driver (PDS, EHdr, VRT raw, SRTM .hgt, ...) will read
/// exist; GDAL otherwise returns zeros or fails late for a short file.
Result<void> checkRawExtent(GDALDatasetH ds, const fs::path& path, bool detachedIsError) {
  GDALDataset::RawBinaryLayout layout;
  if (!GDALDataset::FromHandle(ds)->GetRawBinaryLayout(layout)) return {};
  const int typeBytes = GDALGetDataTypeSizeBytes(layout.eDataType);
  const auto w = static_cast<std::int64_t>(GDALGetRasterXSize(ds));
  const auto h = static_cast<std::int64_t>(GDALGetRasterYSize(ds));
  const std::int64_t needed = static_cast<std::int64_t>(layout.nImageOffset) +
                              (h - 1) * static_cast<std::int64_t>(layout.nLineOffset) +
                              (w - 1) * static_cast<std::int64_t>(layout.nPixelOffset) + typeBytes;
  std::error_code ec;
  const auto size = static_cast<std::int64_t>(fs::file_size(layout.osRawFilename, ec));
  if (ec) return fail(ErrorCode::IoError, path, "cannot stat " + layout.osRawFilename);
  const std::string described = std::to_string(w) + "x" + std::to_string(h) + " " +
                                GDALGetDataTypeName(layout.eDataType) + " samples need " +
                                std::to_string(needed) + " bytes";
  if (size < needed) {
    return fail(ErrorCode::CorruptData, path,
                "truncated: " + described + " but " + layout.osRawFilename + " has " +
                    std::to_string(size));
  }
  const bool detached = fs::path(layout.osRawFilename) != fs::absolute(path) &&
                        fs::path(layout.osRawFilename) != path;
  if (detachedIsError && detached && size > needed + layout.nLineOffset) {
    return fail(ErrorCode::CorruptData, path,
                "label/data size mismatch: " + described + " but " + layout.osRawFilename +
                    " has " + std::to_string(size));
  }
  return {};
}

/// NetCDF classic files store variables uncompressed: a file shorter than its grid is truncated
/// (libnetcdf then returns fill values without an error).
Result<void> checkNetcdfClassicSize(const fs::path& path, std::int64_t samples, int typeBytes) {
  std::ifstream in(path, std::ios::binary);
  std::array<char, 4> magic{};
  in.read(magic.data(), 4);
  if (!in || std::memcmp(magic.data(), "CDF", 3) != 0) return {};  // netCDF-4/HDF5
  std::error_code ec;
  const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
  const std::int64_t needed = samples * typeBytes;
  if (!ec && size < needed) {
    return fail(ErrorCode::CorruptData, path,
                "truncated: the grid needs " + std::to_string(needed) + " bytes, the file has " +
                    std::to_string(size));
  }
  return {};
}

}  // namespace

Result<RawLayout> parseRawType(std::string_view name) {
  struct Entry {
    std::string_view name;
    RawSampleType type;
    bool bigEndian;
  };
  static constexpr std::array<Entry, 13> kTypes = {{
      {"uint8", RawSampleType::UInt8, false},
      {"int16be", RawSampleType::Int16, true},
      {"int16le", RawSampleType::Int16, false},
      {"uint16be", RawSampleType::UInt16, true},
      {"uint16le", RawSampleType::UInt16, false},
      {"int32be", RawSampleType::Int32, true},
      {"int32le", RawSampleType::Int32, false},
      {"uint32be", RawSampleType::UInt32, true},
      {"uint32le", RawSampleType::UInt32, false},
      {"float32be", RawSampleType::Float32, true},
      {"float32le", RawSampleType::Float32, false},
      {"float64be", RawSampleType::Float64, true},
      {"float64le", RawSampleType::Float64, false},
  }};
  for (const auto& e : kTypes) {
    if (e.name == name) {
      RawLayout layout;
      layout.type = e.type;
      layout.bigEndian = e.bigEndian;
      return layout;
    }
  }
  return makeError(ErrorCode::InvalidArgument,
                   "--raw-type '" + std::string(name) +
                       "': expected one of uint8, int16be, int16le, uint16be, uint16le, int32be, "
                       "int32le, uint32be, uint32le, float32be, float32le, float64be, float64le");
}

Result<void> parseRawSize(std::string_view text, RawLayout& layout) {
  std::vector<double> v;
  if (!parseNumberList(text, 2, v) || v[0] < 1 || v[1] < 1 || v[0] != std::floor(v[0]) ||
      v[1] != std::floor(v[1]) || v[0] > 1e7 || v[1] > 1e7) {
    return makeError(ErrorCode::InvalidArgument,
                     "--raw-size '" + std::string(text) + "': expected W,H positive integers");
  }
  layout.width = static_cast<std::int64_t>(v[0]);
  layout.height = static_cast<std::int64_t>(v[1]);
  return {};
}

Result<void> parseRawBounds(std::string_view text, RawLayout& layout) {
  std::vector<double> v;
  if (!parseNumberList(text, 4, v) || v[0] < -90.0 || v[2] > 90.0 || v[0] >= v[2] || v[1] >= v[3] ||
      v[3] - v[1] > 360.0 + 1e-9 || v[1] < -360.0 || v[3] > 720.0) {
    return makeError(ErrorCode::InvalidArgument,
                     "--bounds '" + std::string(text) +
                         "': expected S,W,N,E degrees with -90 <= S < N <= 90 and W < E, "
                         "at most 360 degrees apart");
  }
  layout.bounds = LatLonBounds{v[0], v[1], v[2], v[3]};
  return {};
}

namespace {

/// An open elevation raster: the GDAL dataset (its geographic warp once georeference has run on
/// a projected grid), the driver's short name, the file GDAL opened (a detached label for an
/// image named without it) and what is known of the source so far.
struct OpenDem final {
  DatasetPtr dataset;
  std::string driverName;
  fs::path openedPath;
  GridSource source;
};

DatasetPtr openRaster(const char* pathOrXml) {
  return DatasetPtr(
      GDALOpenEx(pathOrXml, GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr));
}

/// Opens a headerless grid through a VRT raw band after checking its size against the layout.
Result<DatasetPtr> openRaw(const fs::path& path, const RawLayout& raw) {
  if (raw.width < 1 || raw.height < 1) {
    return fail(ErrorCode::InvalidArgument, path, "raw grid needs --raw-size W,H");
  }
  const std::int64_t needed = raw.headerBytes + raw.width * raw.height * rawTypeBytes(raw.type);
  std::error_code ec;
  const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
  if (ec) return fail(ErrorCode::IoError, path, "cannot stat");
  if (size != needed) {
    return fail(ErrorCode::CorruptData, path,
                "raw size mismatch: " + std::to_string(raw.width) + "x" +
                    std::to_string(raw.height) + " " + rawTypeGdalName(raw.type) +
                    " samples need " + std::to_string(needed) + " bytes, the file has " +
                    std::to_string(size));
  }
  return openRaster(rawVrtXml(path, raw).c_str());
}

/// A PDS3 label beside `image` (same stem, .lbl or .LBL), if there is one.
std::optional<fs::path> labelBeside(const fs::path& image) {
  for (const char* extension : {".lbl", ".LBL"}) {
    fs::path label = image;
    label.replace_extension(extension);
    std::error_code ec;
    if (label != image && fs::is_regular_file(label, ec)) return label;
  }
  return std::nullopt;
}

std::string upperCase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return text;
}

/// Whether `label` is a PDS3 label whose data pointers name `image` (PDS names files in upper
/// case; the file on disk may be in either).
bool labelNamesImage(const fs::path& label, const fs::path& image) {
  std::ifstream in(label, std::ios::binary);
  std::string text(std::size_t{64} << 10, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  text = upperCase(std::move(text));
  return text.find("PDS_VERSION_ID") != std::string::npos &&
         text.find("\"" + upperCase(image.filename().string()) + "\"") != std::string::npos;
}

/// Opens `path` with GDAL as the caller named it, or through the detached PDS label that names
/// it when GDAL does not recognise the image alone.
Result<void> openNamedOrLabelled(OpenDem& dem, const fs::path& path, GdalErrorCapture& capture) {
  dem.dataset = openRaster(path.c_str());
  if (dem.dataset) return {};
  const std::optional<fs::path> label = labelBeside(path);
  if (!label) {
    return fail(ErrorCode::UnsupportedFormat, path,
                withGdal("not a raster format GDAL can read, or a corrupt one (a headerless grid "
                         "needs --raw-size, --raw-type and --bounds)",
                         capture));
  }
  if (!labelNamesImage(*label, path)) {
    return fail(ErrorCode::UnsupportedFormat, path,
                "not a raster format GDAL can read, and the label beside it, " + label->string() +
                    ", does not name it: pass the PDS label that describes this image");
  }
  capture.clear();  // the image's own open failed as expected: its data is the label's
  dem.dataset = openRaster(label->c_str());
  if (!dem.dataset) {
    return fail(ErrorCode::UnsupportedFormat, *label,
                withGdal("the PDS label beside " + path.filename().string() +
                             " is not one GDAL can read, or a corrupt one",
                         capture));
  }
  dem.openedPath = *label;
  dem.source.labelPath = label->string();
  return {};
}

/// Opens the raster (raw through a VRT, named, or through its label) and checks it has a band.
Result<OpenDem> openDem(const fs::path& path, const DemReadOptions& options,
                        GdalErrorCapture& capture) {
  OpenDem dem;
  dem.openedPath = path;
  dem.source.path = path.string();
  if (options.raw) {
    auto raw = openRaw(path, *options.raw);
    if (!raw) return std::move(raw).error();
    dem.dataset = std::move(raw).value();
    if (!dem.dataset) {
      return fail(ErrorCode::UnsupportedFormat, path,
                  withGdal("not a raster format GDAL can read, or a corrupt one", capture));
    }
  } else if (auto opened = openNamedOrLabelled(dem, path, capture); !opened) {
    return opened.error();
  }
  GDALDriverH driver = GDALGetDatasetDriver(dem.dataset.get());
  dem.source.format = options.raw ? std::string("raw (GDAL VRT raw band)")
                                  : std::string(GDALGetDriverShortName(driver)) + " (" +
                                        GDALGetDriverLongName(driver) + ")";
  dem.driverName = options.raw ? "VRT" : GDALGetDriverShortName(driver);
  if (GDALGetRasterCount(dem.dataset.get()) < 1) {
    return fail(ErrorCode::UnsupportedFormat, path, "has no raster band");
  }
  return dem;
}

/// Records the CRS's name, ellipsoid and body in `source`.
void describeCrs(const OGRSpatialReference* crs, GridSource& source) {
  if (crs == nullptr) {
    source.crs = "none";
    return;
  }
  const char* name = crs->GetName();
  source.crs = name != nullptr ? name : "unnamed";
  OGRErr err = OGRERR_NONE;
  source.semiMajorMeters = crs->GetSemiMajor(&err);
  const double inverseFlattening = crs->GetInvFlattening(&err);
  source.flattening = inverseFlattening > 0.0 ? 1.0 / inverseFlattening : 0.0;
  source.body = bodyForSemiMajor(source.semiMajorMeters);
  // A compound CRS names its heights' vertical datum (EGM96, NAVD88, a Mars areoid, ...).
  if (const char* vertical = crs->GetAttrValue("VERT_CS"); vertical != nullptr) {
    source.verticalDatum = vertical;
  }
}

/// The grid's corner-based geographic georeference: exact for geographic and equirectangular
/// grids; other projected or rotated grids are warped first (dem.dataset becomes the warp).
Result<GeoRef> georeference(OpenDem& dem, const fs::path& path, const GdalErrorCapture& capture) {
  OGRSpatialReference crs;
  bool hasCrs = false;
  if (OGRSpatialReferenceH h = GDALGetSpatialRef(dem.dataset.get()); h != nullptr) {
    crs = *OGRSpatialReference::FromHandle(h);
    crs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    hasCrs = true;
  }
  std::array<double, 6> gt{};
  if (GDALGetGeoTransform(dem.dataset.get(), gt.data()) != CE_None) {
    return fail(ErrorCode::UnsupportedFormat, path,
                "has no georeferencing (for a headerless grid use --raw-size, --raw-type and "
                "--bounds)");
  }
  const bool rotated = gt[2] != 0.0 || gt[4] != 0.0;
  std::optional<GeoRef> geo;
  if (hasCrs && crs.IsProjected() && !rotated) {
    geo = linearGeographic(crs, gt, GDALGetRasterXSize(dem.dataset.get()),
                           GDALGetRasterYSize(dem.dataset.get()));
  }
  if (!geo && ((hasCrs && crs.IsProjected()) || rotated)) {
    if (!hasCrs) return fail(ErrorCode::UnsupportedFormat, path, "rotated grid without a CRS");
    std::string why;
    DatasetPtr warped = warpToGeographic(dem.dataset.get(), crs, why);
    if (!warped) return fail(ErrorCode::UnsupportedFormat, path, withGdal(why, capture));
    dem.dataset = std::move(warped);
    dem.source.warped = true;
    if (GDALGetGeoTransform(dem.dataset.get(), gt.data()) != CE_None) {
      return fail(ErrorCode::Internal, path, "warped grid has no georeferencing");
    }
  }
  if (!geo) {
    if (hasCrs && !crs.IsGeographic() && !crs.IsProjected()) {
      return fail(ErrorCode::UnsupportedFormat, path, "CRS is neither geographic nor projected");
    }
    geo = GeoRef{gt[0], gt[3], gt[1], -gt[5]};
  }
  if (!(geo->lonSpacingDegrees > 0.0) || !(geo->latSpacingDegrees > 0.0)) {
    return fail(ErrorCode::UnsupportedFormat, path,
                "georeferencing is not north-up with positive spacing");
  }
  describeCrs(hasCrs ? &crs : nullptr, dem.source);
  return *geo;
}

/// Sample-centre geometry of the grid: spacing and origin snapped to round values, the cell
/// convention (pixel-is-point for grids whose outer rows sit on the poles), checked against the
/// poles and a 360° longitude span.
Result<GridGeometry> gridGeometry(GDALDatasetH ds, const GeoRef& geo, const fs::path& path,
                                  std::int64_t maxSamples) {
  const std::int64_t width = GDALGetRasterXSize(ds);
  const std::int64_t height = GDALGetRasterYSize(ds);
  if (width * height > maxSamples) {
    return fail(ErrorCode::InvalidArgument, path,
                std::to_string(width) + "x" + std::to_string(height) +
                    " samples exceed the in-memory limit of " + std::to_string(maxSamples));
  }
  GridGeometry geometry;
  geometry.width = width;
  geometry.height = height;
  geometry.lonSpacingDegrees = snapSpacing(geo.lonSpacingDegrees);
  geometry.latSpacingDegrees = snapSpacing(geo.latSpacingDegrees);
  const double west = snapOrigin(geo.westDegrees, geometry.lonSpacingDegrees);
  const double north = snapOrigin(geo.northDegrees, geometry.latSpacingDegrees);
  geometry.firstLonDegrees = west + 0.5 * geometry.lonSpacingDegrees;
  geometry.firstLatDegrees = north - 0.5 * geometry.latSpacingDegrees;
  const char* areaOrPoint = GDALGetMetadataItem(ds, "AREA_OR_POINT", nullptr);
  geometry.pixelIsArea = areaOrPoint == nullptr || !EQUAL(areaOrPoint, "Point");
  const double lastLat =
      geometry.firstLatDegrees - static_cast<double>(height - 1) * geometry.latSpacingDegrees;
  // A grid whose outer sample centres sit on the poles samples points (ETOPO5's −90…90 rows),
  // whatever the file's cell convention says.
  const double poleTolerance = 1e-6 * geometry.latSpacingDegrees;
  if (std::abs(geometry.firstLatDegrees - 90.0) <= poleTolerance ||
      std::abs(lastLat + 90.0) <= poleTolerance) {
    geometry.pixelIsArea = false;
  }
  const double northEdge =
      geometry.firstLatDegrees + (geometry.pixelIsArea ? 0.5 * geometry.latSpacingDegrees : 0.0);
  const double southEdge =
      lastLat - (geometry.pixelIsArea ? 0.5 * geometry.latSpacingDegrees : 0.0);
  if (northEdge > 90.0 + poleTolerance || southEdge < -90.0 - poleTolerance) {
    return fail(ErrorCode::CorruptData, path,
                "georeferencing puts the grid beyond a pole (north edge " +
                    formatDouble(northEdge) + "°, south edge " + formatDouble(southEdge) +
                    "°): wrong label or projection offsets");
  }
  if (static_cast<double>(width) * geometry.lonSpacingDegrees >
      360.0 + 1.5 * geometry.lonSpacingDegrees) {
    return fail(ErrorCode::CorruptData, path, "georeferencing spans more than 360° of longitude");
  }
  return geometry;
}

/// Truncation checks that GDAL does not always make, for files read as they are (not raw
/// layouts, which openRaw checks, nor warps).
Result<void> checkTruncation(const OpenDem& dem, std::int64_t samples) {
  const std::string& driver = dem.driverName;
  const bool detachedLabel =
      driver == "PDS" || driver == "ISIS3" || driver == "EHdr" || driver == "ENVI";
  if (auto r = checkRawExtent(dem.dataset.get(), dem.openedPath, detachedLabel); !r) return r;
  if (driver == "netCDF") {
    GDALRasterBandH band = GDALGetRasterBand(dem.dataset.get(), 1);
    return checkNetcdfClassicSize(dem.openedPath, samples,
                                  GDALGetDataTypeSizeBytes(GDALGetRasterDataType(band)));
  }
  return {};
}

}  // namespace

std::optional<fs::path> pdsLabelFor(const fs::path& image) {
  std::error_code ec;
  if (!fs::is_regular_file(image, ec)) return std::nullopt;
  std::optional<fs::path> label = labelBeside(image);
  if (!label || !labelNamesImage(*label, image)) return std::nullopt;
  registerGdalOnce();
  GdalErrorCapture capture;  // identification failures are the expected answer here
  if (GDALIdentifyDriverEx(image.c_str(), GDAL_OF_RASTER, nullptr, nullptr) != nullptr) {
    return std::nullopt;  // GDAL reads the image as it is
  }
  return label;
}

namespace {

/// readDem's work on a path GDAL opens (a file, or a VRT in GDAL's memory filesystem); the grid's
/// source names `name` when given.
Result<HeightGrid> readOpened(const fs::path& path, const std::string& name,
                              const DemReadOptions& options) {
  registerGdalOnce();
  GdalErrorCapture capture;
  // Never write .aux.xml side files next to the input.
  ScopedConfig noPam("GDAL_PAM_ENABLED", "NO");
  // PDS3 *_PROJECTION_OFFSET counts from 1 at the first pixel's centre (the MEGDR convention);
  // GDAL's default places such grids one pixel off.
  ScopedConfig pdsSample("PDS_SampleProjOffset_Shift", "-0.5");
  ScopedConfig pdsLine("PDS_LineProjOffset_Shift", "-0.5");

  auto dem = openDem(path, options, capture);
  if (!dem) return std::move(dem).error();
  auto geo = georeference(*dem, path, capture);
  if (!geo) return std::move(geo).error();
  auto geometry = gridGeometry(dem->dataset.get(), *geo, path, options.maxSamples);
  if (!geometry) return std::move(geometry).error();
  if (!options.raw && !dem->source.warped) {
    if (auto r = checkTruncation(*dem, geometry->width * geometry->height); !r) return r.error();
  }
  if (!name.empty()) dem->source.path = name;
  return readDemHeights(GDALGetRasterBand(dem->dataset.get(), 1), *geometry, std::move(dem->source),
                        path, options, capture);
}

}  // namespace

Result<HeightGrid> readDem(const fs::path& path, const DemReadOptions& options) {
  if (namesDemSet(path)) {
    // A directory or a glob: its tiles as one grid, when they make one surface.
    if (options.raw) {
      return fail(ErrorCode::InvalidArgument, path, "a set of tiles cannot be read as a raw grid");
    }
    auto files = expandDemSet(path);
    if (!files) return std::move(files).error();
    auto tiles = probeDemTiles(*files);
    if (!tiles) return std::move(tiles).error();
    const auto surfaces = groupDemTiles(*tiles);
    if (surfaces.size() != 1) {
      return fail(ErrorCode::InvalidArgument, path,
                  "its " + std::to_string(tiles->size()) + " tiles make " +
                      std::to_string(surfaces.size()) +
                      " separate surfaces (other CRSs or spacings, or tiles that do not touch): "
                      "one DEM must be one surface (as insets, tiles of several surfaces are "
                      "joined to the base each)");
    }
    return readDemMosaic(*files, path.string(), options);
  }
  std::error_code ec;
  if (!fs::exists(path, ec)) return fail(ErrorCode::NotFound, path, "no such file");
  if (!fs::is_regular_file(path, ec)) return fail(ErrorCode::InvalidArgument, path, "not a file");
  return readOpened(path, "", options);
}

Result<DemTileProbe> probeDemTile(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return fail(ErrorCode::NotFound, path, "no such file");
  registerGdalOnce();
  GdalErrorCapture capture;
  ScopedConfig noPam("GDAL_PAM_ENABLED", "NO");
  auto dem = openDem(path, DemReadOptions{}, capture);
  if (!dem) return std::move(dem).error();
  DemTileProbe probe;
  probe.path = path;
  probe.format = dem->driverName;
  probe.width = GDALGetRasterXSize(dem->dataset.get());
  probe.height = GDALGetRasterYSize(dem->dataset.get());
  if (GDALGetGeoTransform(dem->dataset.get(), probe.geoTransform.data()) != CE_None) {
    return fail(ErrorCode::UnsupportedFormat, path, "has no georeferencing");
  }
  if (probe.geoTransform[2] != 0.0 || probe.geoTransform[4] != 0.0 ||
      !(probe.geoTransform[1] > 0.0) || !(probe.geoTransform[5] < 0.0)) {
    return fail(ErrorCode::UnsupportedFormat, path,
                "is not a north-up grid (a tile of a set must be; warp it first)");
  }
  if (OGRSpatialReferenceH h = GDALGetSpatialRef(dem->dataset.get()); h != nullptr) {
    OGRSpatialReference crs = *OGRSpatialReference::FromHandle(h);
    char* wkt = nullptr;
    if (crs.exportToWkt(&wkt) == OGRERR_NONE && wkt != nullptr) probe.crsWkt = wkt;
    CPLFree(wkt);
    describeCrs(&crs, dem->source);
    probe.body = dem->source.body;
  }
  if (auto r = checkTruncation(*dem, probe.width * probe.height); !r) return r.error();
  return probe;
}

Result<HeightGrid> readDemMosaic(const std::vector<fs::path>& tiles, const std::string& name,
                                 const DemReadOptions& options) {
  if (tiles.empty()) return makeError(ErrorCode::InvalidArgument, name + ": no tiles");
  if (tiles.size() == 1) {
    auto grid = readOpened(tiles.front(), name, options);
    return grid;
  }
  registerGdalOnce();
  GdalErrorCapture capture;
  ScopedConfig noPam("GDAL_PAM_ENABLED", "NO");
  static std::atomic<std::uint64_t> counter{0};
  const std::string vrt = "/vsimem/pbdam-mosaic-" + std::to_string(counter++) + ".vrt";
  std::vector<std::string> names;
  std::vector<const char*> pointers;
  names.reserve(tiles.size());
  pointers.reserve(tiles.size());
  for (const fs::path& tile : tiles) names.push_back(tile.string());
  for (const std::string& n : names) pointers.push_back(n.c_str());
  {
    DatasetPtr mosaic(GDALBuildVRT(vrt.c_str(), static_cast<int>(pointers.size()), nullptr,
                                   pointers.data(), nullptr, nullptr));
    if (!mosaic) {
      return makeError(ErrorCode::UnsupportedFormat,
                       name + ": its tiles could not be joined" +
                           (capture.hasFailures() ? " (GDAL: " + capture.failures() + ")" : ""));
    }
  }  // closed: the VRT is written
  auto grid = readOpened(vrt, name, options);
  VSIUnlink(vrt.c_str());
  if (grid) {
    // Named by what the tiles are, not by the VRT that joins them.
    std::string tileFormat = "unknown";
    if (GDALDriverH driver = GDALIdentifyDriver(tiles.front().c_str(), nullptr)) {
      tileFormat =
          std::string(GDALGetDriverShortName(driver)) + " (" + GDALGetDriverLongName(driver) + ")";
    }
    GridSource source = grid->source();
    source.format =
        std::to_string(tiles.size()) + " tiles of " + tileFormat + ", joined as a GDAL VRT mosaic";
    return grid->withSource(std::move(source));
  }
  if (!grid) {
    return makeError(grid.error().code, name + " (" + std::to_string(tiles.size()) +
                                            " tiles): " + grid.error().message);
  }
  return grid;
}

}  // namespace pbdam::formats
