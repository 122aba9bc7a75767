// Survey tiles as they come, measured (docs/performance.md "Survey tiles"): a real DEM with
// voids punched on its steepest slopes, joined as an inset to a real base, against the truth;
// the same DEM cut into 2 × 2 tiles — sharing edge rows, abutting — given as four insets, as a
// directory and as a VRT, against the single file. The inset is ETOPO5 (5′) over the Himalaya
// and Tibet, the base ETOPO20 (20′): no finer real DEM than the 95 × 90-sample Luxembourg
// GeoTIFF is at hand, and a 5′ inset on a 20′ base has the same shape of problem as a 3″ SRTM
// tile on ETOPO5 (voids of a few samples on slopes that change by kilometres between them).
//   pbdam_survey_tiles OUTDIR [--json FILE] [--fillnodata gdal_fillnodata.py]
// Writes OUTDIR/{truth,punched}.asc, OUTDIR/tiles-{shared,abutting}/, the datasets
// OUTDIR/{single,files,dir,vrt}, OUTDIR/filled.tif (GDAL's fill-nodata of the punched DEM, for
// the comparison), prints a table and, with --json, the figures.
#include <sys/resource.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pbdam/builder/Builder.h"
#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

namespace fs = std::filesystem;
using namespace pbdam;
using formats::HeightGrid;

namespace {

constexpr const char* kEtopo5 = "/usr/share/ferret-vis/data/etopo5.cdf";
constexpr const char* kEtopo20 = "/usr/share/ferret-vis/data/etopo20.cdf";
// The inset: 27–37°N, 74–94°E of ETOPO5 (120 × 240 samples).
constexpr double kNorth = 37.0, kSouth = 27.0, kWest = 74.0, kEast = 94.0;

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "pbdam_survey_tiles: %s\n", what.c_str());
  std::exit(1);
}

/// Rows × columns of heights (NaN nodata) with their north-west sample centre and spacing.
struct Grid {
  std::int64_t rows = 0, cols = 0;
  double north = 0.0, west = 0.0, step = 0.0;
  std::vector<float> h;
  float& at(std::int64_t r, std::int64_t c) { return h[static_cast<std::size_t>(r * cols + c)]; }
  float at(std::int64_t r, std::int64_t c) const {
    return h[static_cast<std::size_t>(r * cols + c)];
  }
  double lat(std::int64_t r) const { return north - static_cast<double>(r) * step; }
  double lon(std::int64_t c) const { return west + static_cast<double>(c) * step; }
};

/// Writes rows [r0, r1] × columns [c0, c1] as an ESRI ASCII grid (pixel-is-area).
void writeAsc(const fs::path& path, const Grid& g, std::int64_t r0, std::int64_t r1,
              std::int64_t c0, std::int64_t c1) {
  std::ofstream out(path);
  char header[256];
  std::snprintf(header, sizeof header,
                "ncols %lld\nnrows %lld\nxllcorner %.12f\nyllcorner %.12f\ncellsize %.12f\n"
                "NODATA_value -32768\n",
                static_cast<long long>(c1 - c0) + 1, static_cast<long long>(r1 - r0) + 1,
                g.lon(c0) - 0.5 * g.step, g.lat(r1) - 0.5 * g.step, g.step);
  out << header;
  for (std::int64_t r = r0; r <= r1; ++r) {
    for (std::int64_t c = c0; c <= c1; ++c) {
      const float v = g.at(r, c);
      out << (std::isnan(v) ? -32768.0f : v) << (c < c1 ? " " : "\n");
    }
  }
  if (!out) die("cannot write " + path.string());
}

/// Voids of 5, 13 and 29 samples (discs of radius 1, 2, 3) centred on the steepest samples,
/// at least 10 samples apart and 5 from the edge: radar shadow where it falls, on the slopes.
std::int64_t punchVoids(Grid& g, int count) {
  std::vector<std::pair<double, std::int64_t>> slopes;
  const double metresPerDegree = 111320.0;
  for (std::int64_t r = 5; r + 5 < g.rows; ++r) {
    for (std::int64_t c = 5; c + 5 < g.cols; ++c) {
      const double dy =
          static_cast<double>(g.at(r - 1, c) - g.at(r + 1, c)) / (2.0 * g.step * metresPerDegree);
      const double dx = static_cast<double>(g.at(r, c + 1) - g.at(r, c - 1)) /
                        (2.0 * g.step * metresPerDegree * std::cos(g.lat(r) * M_PI / 180.0));
      slopes.emplace_back(std::hypot(dx, dy), r * g.cols + c);
    }
  }
  std::sort(slopes.begin(), slopes.end(), std::greater<>());
  std::vector<std::int64_t> seeds;
  for (const auto& candidate : slopes) {
    const std::int64_t i = candidate.second;
    if (static_cast<int>(seeds.size()) == count) break;
    const bool near = std::any_of(seeds.begin(), seeds.end(), [&](std::int64_t s) {
      return std::abs(s / g.cols - i / g.cols) < 10 && std::abs(s % g.cols - i % g.cols) < 10;
    });
    if (!near) seeds.push_back(i);
  }
  std::int64_t punched = 0;
  for (std::size_t k = 0; k < seeds.size(); ++k) {
    const auto radius = static_cast<std::int64_t>(1 + k % 3);
    const std::int64_t r0 = seeds[k] / g.cols, c0 = seeds[k] % g.cols;
    for (std::int64_t dr = -radius; dr <= radius; ++dr) {
      for (std::int64_t dc = -radius; dc <= radius; ++dc) {
        if (dr * dr + dc * dc > radius * radius || std::isnan(g.at(r0 + dr, c0 + dc))) continue;
        g.at(r0 + dr, c0 + dc) = std::numeric_limits<float>::quiet_NaN();
        ++punched;
      }
    }
  }
  return punched;
}

builder::BuildOptions buildOptions(const fs::path& out, const std::vector<fs::path>& insets) {
  builder::BuildOptions o;
  o.demPath = kEtopo20;
  o.planetSpec = "earth";
  o.outDir = out;
  o.force = true;
  o.textureFormat = formats::TexelFormat::Rgba8;
  o.textureTileTexels = 64;
  for (const fs::path& p : insets) o.insets.push_back(builder::InsetSpec{p, {}, {}});
  return o;
}

struct Built {
  double cpuSeconds = 0.0;
  std::unique_ptr<streaming::MappedDataset> dataset;
};

Built build(const fs::path& out, const std::vector<fs::path>& insets) {
  const double t0 = cpuSeconds();
  auto summary = builder::buildDataset(buildOptions(out, insets));
  if (!summary) die("build " + out.string() + ": " + summary.error().message);
  Built b;
  b.cpuSeconds = cpuSeconds() - t0;
  auto opened = streaming::MappedDataset::open(out);
  if (!opened) die(opened.error().message);
  b.dataset = std::move(opened).value();
  std::printf("built %-28s %6.1f CPU-s\n", out.filename().c_str(), b.cpuSeconds);
  return b;
}

runtime::SurfaceHeight heightAt(const Built& b, double lat, double lon) {
  auto h = runtime::surfaceHeightAt(b.dataset->view(), lat, lon);
  if (!h) die(h.error().message);
  return *h;
}

/// The truth (ETOPO5 over the inset's box, read as pbdam reads it) and the same with voids.
std::pair<Grid, Grid> makeInset() {
  auto etopo5 = formats::readDem(kEtopo5);
  if (!etopo5) die(etopo5.error().message);
  Grid truth;
  truth.step = 1.0 / 12.0;
  truth.north = kNorth - 0.5 * truth.step;
  truth.west = kWest + 0.5 * truth.step;
  truth.rows = static_cast<std::int64_t>(std::lround((kNorth - kSouth) / truth.step));
  truth.cols = static_cast<std::int64_t>(std::lround((kEast - kWest) / truth.step));
  truth.h.resize(static_cast<std::size_t>(truth.rows * truth.cols));
  for (std::int64_t r = 0; r < truth.rows; ++r) {
    for (std::int64_t c = 0; c < truth.cols; ++c) {
      truth.at(r, c) =
          static_cast<float>(etopo5->sampleBilinear(truth.lat(r), truth.lon(c)).value_or(0.0));
    }
  }
  Grid punched = truth;
  punchVoids(punched, 60);
  return {std::move(truth), std::move(punched)};
}

/// 2 × 2 tiles: sharing the middle row and column (SRTM's convention), or abutting; a VRT of
/// the abutting ones.
void writeTiles(const fs::path& out, const Grid& g) {
  const std::int64_t rm = g.rows / 2, cm = g.cols / 2;
  for (const auto& [name, overlap] :
       {std::pair{"tiles-shared", 0}, std::pair{"tiles-abutting", 1}}) {
    const fs::path d = out / name;
    fs::create_directories(d);
    writeAsc(d / "nw.asc", g, 0, rm, 0, cm);
    writeAsc(d / "ne.asc", g, 0, rm, cm + overlap, g.cols - 1);
    writeAsc(d / "sw.asc", g, rm + overlap, g.rows - 1, 0, cm);
    writeAsc(d / "se.asc", g, rm + overlap, g.rows - 1, cm + overlap, g.cols - 1);
  }
  const std::string vrtCommand = "gdalbuildvrt -q '" + (out / "tiles.vrt").string() + "' '" +
                                 (out / "tiles-abutting").string() + "'/*.asc";
  if (std::system(vrtCommand.c_str()) != 0) die("gdalbuildvrt failed");
}

/// Of 10,000 random valid samples beyond the outer band, how many `pbdam height` gives within
/// the stored error + 0.5 m; and the worst excess over the stored error.
struct ValidCheck {
  int checked = 0, within = 0;
  double worstBeyond = 0.0;
};
ValidCheck checkValid(const Grid& punched, const builder::CompositeSurface& composite,
                      const Built& single, std::mt19937_64& random) {
  std::uniform_int_distribution<std::int64_t> row(0, punched.rows - 1), col(0, punched.cols - 1);
  ValidCheck v;
  while (v.checked < 10000) {
    const std::int64_t r = row(random), c = col(random);
    if (std::isnan(punched.at(r, c))) continue;
    const double lat = punched.lat(r), lon = punched.lon(c);
    if (composite.weightOf(0, lat, lon) < 1.0) continue;
    const runtime::SurfaceHeight h = heightAt(single, lat, lon);
    const double off = std::abs(h.heightMeters - static_cast<double>(punched.at(r, c)));
    ++v.checked;
    if (off <= h.leafErrorMeters + 0.5) {
      ++v.within;
    } else {
      v.worstBeyond = std::max(v.worstBeyond, off - h.leafErrorMeters);
    }
  }
  return v;
}

/// RMS against the truth over the punched samples: `pbdam height`, and GDAL's fill-nodata of
/// the punched DEM (NaN when the script is missing).
std::pair<double, double> voidRms(const fs::path& out, const Grid& truth, const Grid& punched,
                                  const Built& single, const std::string& fillScript) {
  const std::string fillCommand = fillScript + " -q -md 100 -si 0 '" +
                                  (out / "punched.asc").string() + "' '" +
                                  (out / "filled.tif").string() + "'";
  fs::remove(out / "filled.tif");
  std::optional<HeightGrid> gdalFilled;
  if (std::system(fillCommand.c_str()) == 0) {
    auto read = formats::readDem(out / "filled.tif");
    if (!read) die(read.error().message);
    gdalFilled = std::move(read).value();
  }
  double pbdamSquares = 0.0, gdalSquares = 0.0;
  std::int64_t holes = 0;
  for (std::int64_t r = 0; r < punched.rows; ++r) {
    for (std::int64_t c = 0; c < punched.cols; ++c) {
      if (!std::isnan(punched.at(r, c))) continue;
      const double t = static_cast<double>(truth.at(r, c));
      const double h = heightAt(single, punched.lat(r), punched.lon(c)).heightMeters;
      pbdamSquares += (h - t) * (h - t);
      if (gdalFilled) {
        const double g = static_cast<double>(gdalFilled->at(r, c));
        gdalSquares += (g - t) * (g - t);
      }
      ++holes;
    }
  }
  const auto n = static_cast<double>(holes);
  return {std::sqrt(pbdamSquares / n),
          gdalFilled ? std::sqrt(gdalSquares / n) : std::numeric_limits<double>::quiet_NaN()};
}

/// The worst difference of 1,000 random heights over the inset between the single file's
/// dataset and each tiled one.
double worstTileDifference(const Built& single, const std::vector<const Built*>& tiled,
                           std::mt19937_64& random) {
  std::uniform_real_distribution<double> lat(kSouth, kNorth), lon(kWest, kEast);
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const double la = lat(random), lo = lon(random);
    const double h = heightAt(single, la, lo).heightMeters;
    for (const Built* b : tiled) {
      worst = std::max(worst, std::abs(heightAt(*b, la, lo).heightMeters - h));
    }
  }
  return worst;
}

int run(int argc, char** argv) {
  if (argc < 2) die("usage: pbdam_survey_tiles OUTDIR [--json FILE] [--fillnodata SCRIPT]");
  const fs::path out = argv[1];
  std::string jsonPath, fillScript = "gdal_fillnodata.py";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--json") jsonPath = argv[i + 1];
    if (flag == "--fillnodata") fillScript = argv[i + 1];
  }
  fs::create_directories(out);
  const auto [truth, punched] = makeInset();
  writeAsc(out / "truth.asc", truth, 0, truth.rows - 1, 0, truth.cols - 1);
  writeAsc(out / "punched.asc", punched, 0, punched.rows - 1, 0, punched.cols - 1);
  writeTiles(out, punched);

  const Built single = build(out / "single", {out / "punched.asc"});
  const Built files =
      build(out / "files", {out / "tiles-shared/nw.asc", out / "tiles-shared/ne.asc",
                            out / "tiles-shared/sw.asc", out / "tiles-shared/se.asc"});
  const Built dir = build(out / "dir", {out / "tiles-abutting"});
  const Built vrt = build(out / "vrt", {out / "tiles.vrt"});

  // The composite the single build joined: which samples lie beyond the outer band.
  auto base = formats::readDem(kEtopo20);
  if (!base) die(base.error().message);
  auto composite = builder::CompositeSurface::read(
      *base, {builder::InsetSpec{out / "punched.asc", {}, {}}}, {}, "earth");
  if (!composite) die(composite.error().message);
  const builder::VoidReport& voids = composite->insets()[0].voids;
  std::mt19937_64 random(42);
  const ValidCheck valid = checkValid(punched, *composite, single, random);
  const auto [pbdamRms, gdalRms] = voidRms(out, truth, punched, single, fillScript);
  const double worstTiles = worstTileDifference(single, {&files, &dir, &vrt}, random);
  const double cpuRatio =
      std::max({files.cpuSeconds, dir.cpuSeconds, vrt.cpuSeconds}) / single.cpuSeconds;

  std::printf(
      "\ninset: ETOPO5 27–37°N 74–94°E (120 x 240 samples) on ETOPO20; %lld samples "
      "punched in %lld voids on the steepest slopes\n",
      static_cast<long long>(voids.voidSamples), static_cast<long long>(voids.voids));
  std::printf("voids: %lld filled from their rims (%lld samples), %lld left to the base\n",
              static_cast<long long>(voids.filledVoids),
              static_cast<long long>(voids.filledSamples),
              static_cast<long long>(voids.largeVoids));
  std::printf(
      "valid samples beyond the outer band within stored error + 0.5 m: %d of %d "
      "(%.2f%%), worst beyond the stored error %.2f m\n",
      valid.within, valid.checked, 100.0 * valid.within / valid.checked, valid.worstBeyond);
  std::printf(
      "punched samples, RMS against the truth: pbdam height %.1f m, "
      "gdal_fillnodata.py -md 100 %.1f m (ratio %.3f)\n",
      pbdamRms, gdalRms, pbdamRms / gdalRms);
  std::printf(
      "2 x 2 tiles (four files sharing edge rows, a directory of abutting tiles, a VRT) "
      "against the single file: worst of 1000 heights %.3f m; build CPU %.2fx\n",
      worstTiles, cpuRatio);
  if (!jsonPath.empty()) {
    nlohmann::ordered_json j;
    j["void_samples"] = voids.voidSamples;
    j["voids"] = voids.voids;
    j["filled_voids"] = voids.filledVoids;
    j["large_voids"] = voids.largeVoids;
    j["valid_checked"] = valid.checked;
    j["valid_within"] = valid.within;
    j["valid_share"] = static_cast<double>(valid.within) / valid.checked;
    j["punched_rms_pbdam_m"] = pbdamRms;
    j["punched_rms_gdal_fillnodata_m"] = gdalRms;
    j["punched_rms_ratio"] = pbdamRms / gdalRms;
    j["tiles_worst_height_m"] = worstTiles;
    j["build_cpu_s"] = {{"single", single.cpuSeconds},
                        {"files", files.cpuSeconds},
                        {"dir", dir.cpuSeconds},
                        {"vrt", vrt.cpuSeconds}};
    j["tiles_cpu_ratio"] = cpuRatio;
    j["seam_lat_deg"] = punched.lat(punched.rows / 2);
    j["seam_lon_deg"] = punched.lon(punched.cols / 2);
    std::ofstream(jsonPath) << j.dump(2) << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    die(e.what());
  }
}
