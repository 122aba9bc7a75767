// A deterministic fractal upsampling of a global DEM, for the large-data benchmarks (streaming:
// a dataset far larger than any frame's working set; the distributed build: [P-BDAM 2003] §6's
// 1 G-sample Mars). Each output sample is the source's bicubic height plus fractional Brownian
// motion from libnoise's Perlin module, evaluated on the unit sphere (so the detail is seamless
// across the 0/360° meridian and at the poles) with octaves from the source spacing down to the
// output spacing. The same arguments always give the same bytes, for any thread count.
// Writes a tiled, uncompressed int16 GeoTIFF through GDAL in strips (memory: the source plus one
// strip), georeferenced in degrees on the source body's ellipsoid, pixel-is-area. With --bounds
// it covers that box only (an inset for a hybrid dataset), W columns across it; the source may
// then be regional too (the box inside its samples).
//   pbdam_fractal_dem --dem IN --out OUT.tif --width W [--seed S] [--amplitude-m A]
//                     [--hurst H] [--planet-radius-m R] [--bounds S,W,N,E] [--float32]
//                     [--wgs84]
// --float32 writes Float32 heights, unrounded: detail finer than a metre (a lidar-class inset)
// survives.
#include <cpl_conv.h>
#include <gdal_priv.h>
#include <libnoise/noise.h>
#include <ogr_spatialref.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "pbdam/formats/DemReader.h"

namespace {

struct Options {
  std::string dem;
  std::string out;
  std::int64_t width = 0;
  int seed = 1;
  double amplitudeMeters = 120.0;  ///< fBm amplitude at the source's sample spacing
  bool float32 = false;            ///< Float32 samples (unrounded) instead of Int16
  double hurst = 0.8;              ///< roughness: amplitude ∝ wavelength^H
  double radiusMeters = 0.0;       ///< 0: the source CRS's semi-major axis (or Mars)
  bool wgs84 = false;  ///< georeferenced on WGS 84 (a source without a CRS is otherwise Mars)
  /// A regional output (an inset): S, W, N, E in degrees, --width columns across W..E; empty:
  /// the whole globe.
  std::vector<double> bounds;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(
      stderr,
      "pbdam_fractal_dem: %s\n"
      "usage: pbdam_fractal_dem --dem IN --out OUT.tif --width W [--seed S]\n"
      "       [--amplitude-m A] [--hurst H] [--planet-radius-m R] [--bounds S,W,N,E] [--float32]\n"
      "       [--wgs84]\n"
      "  --wgs84: georeference on WGS 84 (a source without a CRS, such as ETOPO, is otherwise "
      "taken as Mars)\n"
      "  W: output columns over 360 degrees (rows = W/2); must be even and > the "
      "source's width\n"
      "  --bounds: a regional grid (an inset) of W columns across W..E, as many rows "
      "at the same spacing\n",
      why);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage((a + " needs a value").c_str());
      return argv[++i];
    };
    auto number = [&](double lo, double hi) {
      const std::string v = value();
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !std::isfinite(d) || d < lo || d > hi) {
        std::string why = a;
        why += " " + v + ": not a number in range";
        usage(why.c_str());
      }
      return d;
    };
    if (a == "--dem") {
      o.dem = value();
    } else if (a == "--out") {
      o.out = value();
    } else if (a == "--width") {
      o.width = static_cast<std::int64_t>(number(4, 1 << 20));
    } else if (a == "--seed") {
      o.seed = static_cast<int>(number(0, 1 << 30));
    } else if (a == "--amplitude-m") {
      o.amplitudeMeters = number(0, 1e5);
    } else if (a == "--float32") {
      o.float32 = true;
    } else if (a == "--wgs84") {
      o.wgs84 = true;
    } else if (a == "--hurst") {
      o.hurst = number(0.05, 1.0);
    } else if (a == "--planet-radius-m") {
      o.radiusMeters = number(1, 1e8);
    } else if (a == "--bounds") {
      const std::string v = value();
      std::size_t at = 0;
      for (int k = 0; k < 4; ++k) {
        const std::size_t comma = v.find(',', at);
        const std::string part =
            v.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
        char* end = nullptr;
        const double d = std::strtod(part.c_str(), &end);
        if (part.empty() || *end != '\0' || !std::isfinite(d)) usage("--bounds: expected S,W,N,E");
        o.bounds.push_back(d);
        if (comma == std::string::npos) break;
        at = comma + 1;
      }
      if (o.bounds.size() != 4 || !(o.bounds[0] < o.bounds[2]) || !(o.bounds[1] < o.bounds[3]) ||
          o.bounds[0] < -90.0 || o.bounds[2] > 90.0) {
        usage("--bounds: expected S,W,N,E with -90 <= S < N <= 90 and W < E");
      }
    } else if (a == "--help" || a == "-h") {
      usage("help");
    } else {
      usage(("unknown option " + a).c_str());
    }
  }
  if (o.dem.empty() || o.out.empty() || o.width == 0) usage("--dem, --out and --width are needed");
  if (o.bounds.empty() && o.width % 2 != 0) usage("--width must be even");
  return o;
}

/// Creates the tiled Int16 GeoTIFF `tmp` of `width` x `height` samples on the body of `dem`;
/// null (after a message) when GDAL cannot.
std::unique_ptr<GDALDataset> createGeoTiff(const std::string& tmp, std::int64_t width,
                                           std::int64_t height, double spacingDegrees,
                                           double westDegrees, double northDegrees,
                                           const pbdam::formats::HeightGrid& dem, GDALDataType type,
                                           bool wgs84) {
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (driver == nullptr) {
    std::fprintf(stderr, "pbdam_fractal_dem: GDAL has no GTiff driver\n");
    return nullptr;
  }
  char** createOptions = nullptr;
  createOptions = CSLSetNameValue(createOptions, "TILED", "YES");
  createOptions = CSLSetNameValue(createOptions, "BLOCKXSIZE", "512");
  createOptions = CSLSetNameValue(createOptions, "BLOCKYSIZE", "512");
  createOptions = CSLSetNameValue(createOptions, "BIGTIFF", "IF_SAFER");
  std::unique_ptr<GDALDataset> out(driver->Create(
      tmp.c_str(), static_cast<int>(width), static_cast<int>(height), 1, type, createOptions));
  CSLDestroy(createOptions);
  if (!out) {
    std::fprintf(stderr, "pbdam_fractal_dem: %s: cannot create\n", tmp.c_str());
    return nullptr;
  }
  const double semiMajor =
      dem.source().semiMajorMeters > 0.0 ? dem.source().semiMajorMeters : 3396190.0;
  double geoTransform[6] = {westDegrees, spacingDegrees, 0.0, northDegrees, 0.0, -spacingDegrees};
  out->SetGeoTransform(geoTransform);
  OGRSpatialReference srs;
  const double flattening = dem.source().semiMajorMeters > 0.0 ? dem.source().flattening : 0.0;
  if (wgs84) {
    srs.SetWellKnownGeogCS("WGS84");
  } else {
    srs.SetGeogCS("fractal", "fractal_datum", "body", semiMajor,
                  flattening > 0.0 ? 1.0 / flattening : 0.0);
  }
  out->SetSpatialRef(&srs);
  return out;
}

/// Whether `dem` can serve the output: a global grid, or with --bounds a regional one holding
/// the box inside its samples' centres (where its bicubic height is defined); says why not.
bool sourceCovers(const Options& o, const pbdam::formats::HeightGrid& dem) {
  const bool global = dem.wrapsLongitude() && dem.coversPoles();
  if (global) return true;
  if (o.bounds.empty()) {
    std::fprintf(stderr,
                 "pbdam_fractal_dem: %s: must be a global grid (360° x 180°), or give --bounds "
                 "inside it\n",
                 o.dem.c_str());
    return false;
  }
  const pbdam::formats::LatLonBounds b = dem.bounds();
  const double margin = 1.5 * dem.geometry().lonSpacingDegrees;
  if (o.bounds[0] < b.southDegrees + margin || o.bounds[2] > b.northDegrees - margin ||
      o.bounds[1] < b.westDegrees + margin || o.bounds[3] > b.eastDegrees - margin) {
    std::fprintf(stderr,
                 "pbdam_fractal_dem: %s covers %.6f..%.6f N, %.6f..%.6f E: --bounds must lie "
                 "inside it by 1.5 samples\n",
                 o.dem.c_str(), b.southDegrees, b.northDegrees, b.westDegrees, b.eastDegrees);
    return false;
  }
  return true;
}

int run(int argc, char** argv) {
  const Options o = parse(argc, argv);
  auto dem = pbdam::formats::readDem(o.dem);
  if (!dem) {
    std::fprintf(stderr, "pbdam_fractal_dem: %s\n", dem.error().message.c_str());
    return 2;
  }
  const bool regional = !o.bounds.empty();
  if (!sourceCovers(o, *dem)) return 2;
  const double west = regional ? o.bounds[1] : 0.0;
  const double north = regional ? o.bounds[2] : 90.0;
  const double spacingDegrees =
      (regional ? o.bounds[3] - o.bounds[1] : 360.0) / static_cast<double>(o.width);
  if (spacingDegrees >= dem->geometry().lonSpacingDegrees) {
    usage("--width must give a finer spacing than the source's (this upsamples)");
  }
  const std::int64_t width = o.width;
  const std::int64_t height =
      regional
          ? static_cast<std::int64_t>(std::llround((o.bounds[2] - o.bounds[0]) / spacingDegrees))
          : o.width / 2;
  const double semiMajor =
      dem->source().semiMajorMeters > 0.0 ? dem->source().semiMajorMeters : 3396190.0;
  const double radius = o.radiusMeters > 0.0 ? o.radiusMeters : semiMajor;

  // fBm: octave 0 at the source's spacing; each octave halves the wavelength down to the output
  // spacing. libnoise's Perlin takes the frequency in cycles per unit of its input coordinates,
  // here the unit sphere.
  const double sourceWavelengthMeters =
      dem->geometry().lonSpacingDegrees * std::numbers::pi / 180.0 * radius;
  const double outputSpacingMeters = spacingDegrees * std::numbers::pi / 180.0 * radius;
  const int octaves = std::clamp(
      static_cast<int>(std::ceil(std::log2(sourceWavelengthMeters / outputSpacingMeters))) + 1, 1,
      noise::module::PERLIN_MAX_OCTAVE);
  noise::module::Perlin perlin;
  perlin.SetSeed(o.seed);
  perlin.SetFrequency(radius / sourceWavelengthMeters);
  perlin.SetLacunarity(2.0);
  perlin.SetPersistence(std::pow(2.0, -o.hurst));
  perlin.SetOctaveCount(octaves);
  perlin.SetNoiseQuality(noise::QUALITY_STD);

  const std::string tmp = o.out + ".tmp.tif";
  std::unique_ptr<GDALDataset> out =
      createGeoTiff(tmp, width, height, spacingDegrees, west, north, *dem,
                    o.float32 ? GDT_Float32 : GDT_Int16, o.wgs84);
  if (!out) return 1;
  GDALRasterBand* band = out->GetRasterBand(1);
  band->SetNoDataValue(-32768.0);

  const auto start = std::chrono::steady_clock::now();
  constexpr std::int64_t kStripRows = 512;
  std::vector<std::int16_t> strip(static_cast<std::size_t>(kStripRows * width));
  std::vector<float> stripFloat(o.float32 ? strip.size() : 0);
  double minM = 1e300;
  double maxM = -1e300;
  for (std::int64_t row0 = 0; row0 < height; row0 += kStripRows) {
    const std::int64_t rows = std::min(kStripRows, height - row0);
    tbb::parallel_for(std::int64_t{0}, rows, [&](std::int64_t r) {
      const double lat = north - (static_cast<double>(row0 + r) + 0.5) * spacingDegrees;
      const double phi = lat * std::numbers::pi / 180.0;
      for (std::int64_t c = 0; c < width; ++c) {
        const double lon = west + (static_cast<double>(c) + 0.5) * spacingDegrees;
        const double lambda = lon * std::numbers::pi / 180.0;
        const double base = dem->sampleBicubic(lat, lon).value_or(0.0);
        const double detail =
            o.amplitudeMeters * perlin.GetValue(std::cos(phi) * std::cos(lambda),
                                                std::cos(phi) * std::sin(lambda), std::sin(phi));
        if (o.float32) {
          stripFloat[static_cast<std::size_t>(r * width + c)] = static_cast<float>(base + detail);
          continue;
        }
        const double h = std::clamp(std::round(base + detail), -32767.0, 32767.0);
        strip[static_cast<std::size_t>(r * width + c)] = static_cast<std::int16_t>(h);
      }
    });
    for (std::int64_t k = 0; k < rows * width; ++k) {
      const double h = o.float32 ? static_cast<double>(stripFloat[static_cast<std::size_t>(k)])
                                 : strip[static_cast<std::size_t>(k)];
      minM = std::min(minM, h);
      maxM = std::max(maxM, h);
    }
    if (band->RasterIO(GF_Write, 0, static_cast<int>(row0), static_cast<int>(width),
                       static_cast<int>(rows),
                       o.float32 ? static_cast<void*>(stripFloat.data()) : strip.data(),
                       static_cast<int>(width), static_cast<int>(rows),
                       o.float32 ? GDT_Float32 : GDT_Int16, 0, 0) != CE_None) {
      std::fprintf(stderr, "pbdam_fractal_dem: %s: write failed\n", tmp.c_str());
      return 1;
    }
    std::fprintf(stderr, "\rpbdam_fractal_dem: %3.0f%%",
                 100.0 * static_cast<double>(row0 + rows) / static_cast<double>(height));
  }
  CPLErrorReset();
  out->FlushCache();
  GDALClose(GDALDataset::ToHandle(out.release()));
  if (CPLGetLastErrorType() >= CE_Failure) {
    std::fprintf(stderr, "\npbdam_fractal_dem: %s: %s\n", tmp.c_str(), CPLGetLastErrorMsg());
    return 1;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, o.out, ec);
  if (ec) {
    std::fprintf(stderr, "\npbdam_fractal_dem: %s: %s\n", o.out.c_str(), ec.message().c_str());
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "\n%s: %lld x %lld %s samples (%.3f G), %.5f deg spacing (%.0f m), %d octaves of "
      "detail (amplitude %.0f m, H %.2f, seed %d), heights %.0f .. %.0f m, %.1f s\n",
      o.out.c_str(), static_cast<long long>(width), static_cast<long long>(height),
      o.float32 ? "float32" : "int16", static_cast<double>(width * height) / 1e9, spacingDegrees,
      outputSpacingMeters, octaves, o.amplitudeMeters, o.hurst, o.seed, minM, maxM, seconds);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_fractal_dem: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "pbdam_fractal_dem: unknown exception\n");
  }
  return 1;
}
