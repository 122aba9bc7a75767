// `pbdam dem info`: what an elevation file or a set of tiles holds, as GDAL reads it and pbdam
// georeferences it — format, CRS/body, size, bounds, spacing, extremes with their positions,
// mean, nodata count, voids (enclosed nodata, and what a build would do with them), and the
// height sampled at a point. A set (a directory or a glob) is reported per surface: the tiles
// that touch at one spacing, read as one grid.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include "Commands.h"
#include "DemInputOptions.h"
#include "pbdam/builder/VoidFill.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/DemTileSet.h"
#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;

namespace pbdam::tools {
namespace {

struct DemInfoOptions {
  std::string file;
  std::string at;
  bool json = false;
  RawGridOptions raw;
};

std::string latLonText(double latDegrees, double lonDegrees) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.4f°%c %.4f°E", std::abs(latDegrees),
                latDegrees >= 0.0 ? 'N' : 'S', lonDegrees);
  return buf;
}

/// Parses "LAT,LON" into finite degrees with |LAT| ≤ 90.
Result<std::pair<double, double>> parseLatLon(const std::string& text) {
  std::vector<double> v;
  if (!parseNumberList(text, 2, v) || std::abs(v[0]) > 90.0) {
    return makeError(ErrorCode::InvalidArgument,
                     "--at '" + text + "': expected LAT,LON in degrees with -90 <= LAT <= 90");
  }
  const double lat = v[0];
  const double lon = v[1];
  return std::pair{lat, lon};
}

/// Everything `dem info` reports: the grid, its statistics and the optional sampled point.
struct DemInfoReport {
  const HeightGrid& grid;
  GridStats stats;
  std::optional<std::pair<double, double>> point;
  std::optional<double> bilinear;
  std::optional<double> bicubic;
  builder::VoidReport voids;
  std::size_t tiles = 1;  ///< files the grid was read from
};

nlohmann::ordered_json demInfoJson(const DemInfoReport& r) {
  const GridGeometry& g = r.grid.geometry();
  const GridSource& s = r.grid.source();
  const LatLonBounds b = r.grid.bounds();
  const GridStats& stats = r.stats;
  nlohmann::ordered_json j;
  j["file"] = s.path;
  if (!s.labelPath.empty()) j["label"] = s.labelPath;
  j["format"] = s.format;
  j["crs"] = s.crs;
  j["body"] = s.body.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(s.body);
  if (s.semiMajorMeters > 0.0) {
    j["semi_major_m"] = s.semiMajorMeters;
    j["flattening"] = s.flattening;
  }
  j["warped"] = s.warped;
  j["width"] = g.width;
  j["height"] = g.height;
  j["pixel_is_area"] = g.pixelIsArea;
  j["bounds_deg"] = {{"south", b.southDegrees},
                     {"west", b.westDegrees},
                     {"north", b.northDegrees},
                     {"east", b.eastDegrees}};
  j["spacing_deg"] = {{"lat", g.latSpacingDegrees}, {"lon", g.lonSpacingDegrees}};
  j["wraps_longitude"] = r.grid.wrapsLongitude();
  j["covers_poles"] = r.grid.coversPoles();
  j["units"] = s.units;
  j["nodata_value"] =
      s.noDataValue ? nlohmann::ordered_json(*s.noDataValue) : nlohmann::ordered_json(nullptr);
  j["nodata_count"] = stats.noDataCount;
  if (r.tiles > 1) j["tiles"] = r.tiles;
  j["voids"] = {{"count", r.voids.voids},
                {"samples", r.voids.voidSamples},
                {"fillable", r.voids.filledVoids},
                {"fillable_samples", r.voids.filledSamples},
                {"too_large", r.voids.largeVoids},
                {"too_large_samples", r.voids.belowSamples},
                {"outside_samples", r.voids.outsideSamples}};
  if (stats.validCount > 0) {
    j["min"] = {{"height_m", stats.minMeters},
                {"lat_deg", stats.minLatDegrees},
                {"lon_deg", stats.minLonDegrees}};
    j["max"] = {{"height_m", stats.maxMeters},
                {"lat_deg", stats.maxLatDegrees},
                {"lon_deg", stats.maxLonDegrees}};
    j["mean_m"] = stats.meanMeters;
  }
  if (r.point) {
    auto opt = [](const std::optional<double>& v) {
      return v ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
    };
    j["at"] = {{"lat_deg", r.point->first},
               {"lon_deg", r.point->second},
               {"bilinear_m", opt(r.bilinear)},
               {"bicubic_m", opt(r.bicubic)}};
  }
  return j;
}

void printDemInfoText(const DemInfoReport& r) {
  const GridGeometry& g = r.grid.geometry();
  const GridSource& s = r.grid.source();
  const LatLonBounds b = r.grid.bounds();
  const GridStats& stats = r.stats;
  std::printf("file:     %s%s\n", s.path.c_str(),
              r.tiles > 1 ? (" (" + std::to_string(r.tiles) + " tiles)").c_str() : "");
  if (!s.labelPath.empty()) std::printf("label:    %s\n", s.labelPath.c_str());
  std::printf("format:   %s\n", s.format.c_str());
  std::printf("crs:      %s%s\n", s.crs.c_str(), s.warped ? " (warped to geographic)" : "");
  if (s.semiMajorMeters > 0.0) {
    std::printf("body:     %s (semi-major axis %.1f m, flattening %.9g)\n",
                s.body.empty() ? "unknown" : s.body.c_str(), s.semiMajorMeters, s.flattening);
  } else {
    std::printf("body:     unknown (the file has no CRS: pass --planet when building)\n");
  }
  std::printf("size:     %lld x %lld samples, pixel-is-%s\n", static_cast<long long>(g.width),
              static_cast<long long>(g.height), g.pixelIsArea ? "area" : "point");
  std::printf("bounds:   S %.6f  W %.6f  N %.6f  E %.6f (degrees)%s%s\n", b.southDegrees,
              b.westDegrees, b.northDegrees, b.eastDegrees,
              r.grid.wrapsLongitude() ? ", wraps in longitude" : "",
              r.grid.coversPoles() ? ", reaches both poles" : "");
  std::printf("spacing:  %.9g° lat x %.9g° lon (%.4g x %.4g arc-seconds)\n", g.latSpacingDegrees,
              g.lonSpacingDegrees, g.latSpacingDegrees * 3600.0, g.lonSpacingDegrees * 3600.0);
  if (stats.validCount > 0) {
    std::printf("min:      %.1f m at %s\n", stats.minMeters,
                latLonText(stats.minLatDegrees, stats.minLonDegrees).c_str());
    std::printf("max:      %.1f m at %s\n", stats.maxMeters,
                latLonText(stats.maxLatDegrees, stats.maxLonDegrees).c_str());
    std::printf("mean:     %.2f m\n", stats.meanMeters);
  }
  if (s.noDataValue) {
    std::printf("nodata:   %lld samples (value %g)\n", static_cast<long long>(stats.noDataCount),
                *s.noDataValue);
  } else {
    std::printf("nodata:   %lld samples\n", static_cast<long long>(stats.noDataCount));
  }
  const builder::VoidReport& voids = r.voids;
  std::printf(
      "voids:    %lld enclosed (%lld samples): %lld fillable from their rims (%lld "
      "samples), %lld too large (%lld samples, the base shows there)\n",
      static_cast<long long>(voids.voids), static_cast<long long>(voids.voidSamples),
      static_cast<long long>(voids.filledVoids), static_cast<long long>(voids.filledSamples),
      static_cast<long long>(voids.largeVoids), static_cast<long long>(voids.belowSamples));
  if (r.point) {
    auto text = [](const std::optional<double>& v) {
      char buf[48];
      if (!v) return std::string("nodata");
      std::snprintf(buf, sizeof buf, "%.2f m", *v);
      return std::string(buf);
    };
    std::printf("at %s: bilinear %s, bicubic %s\n",
                latLonText(r.point->first, r.point->second).c_str(), text(r.bilinear).c_str(),
                text(r.bicubic).c_str());
  }
}

int runDemInfo(const DemInfoOptions& o) {
  DemReadOptions readOptions;
  auto raw = rawLayoutOf(o.raw);
  if (!raw) return reportError(raw.error());
  readOptions.raw = *raw;
  // A grid of 256 MB or more (a tile set's mosaic) is read into a mapped scratch file, as the
  // builder reads it, so that describing a country of tiles does not hold it in memory.
  std::error_code ec;
  readOptions.scratchDirectory = std::filesystem::temp_directory_path(ec);
  std::optional<std::pair<double, double>> point;
  if (!o.at.empty()) {
    auto parsed = parseLatLon(o.at);
    if (!parsed) return reportError(parsed.error());
    point = *parsed;
  }

  // One grid, or the surfaces of a set of tiles.
  std::vector<std::pair<std::vector<std::filesystem::path>, std::string>> surfaces;
  if (!readOptions.raw && namesDemSet(o.file)) {
    auto files = expandDemSet(o.file);
    if (!files) return reportError(files.error());
    auto tiles = probeDemTiles(*files);
    if (!tiles) return reportError(tiles.error());
    const auto groups = groupDemTiles(*tiles);
    for (std::size_t k = 0; k < groups.size(); ++k) {
      std::vector<std::filesystem::path> members;
      for (const std::size_t t : groups[k]) members.push_back((*files)[t]);
      surfaces.emplace_back(std::move(members),
                            groups.size() == 1 ? o.file
                                               : o.file + " (surface " + std::to_string(k + 1) +
                                                     " of " + std::to_string(groups.size()) + ")");
    }
  }
  if (!readOptions.raw && surfaces.empty()) noteDemLabel(o.file);
  const std::size_t count = std::max<std::size_t>(1, surfaces.size());
  nlohmann::ordered_json all = nlohmann::ordered_json::array();
  for (std::size_t k = 0; k < count; ++k) {
    auto grid = surfaces.empty()
                    ? readDem(o.file, readOptions)
                    : readDemMosaic(surfaces[k].first, surfaces[k].second, readOptions);
    if (!grid) return reportError(grid.error());
    auto voids = builder::findVoids(*grid);
    if (!voids) return reportError(voids.error());
    DemInfoReport report{*grid,
                         grid->computeStats(),
                         point,
                         std::nullopt,
                         std::nullopt,
                         *voids,
                         surfaces.empty() ? 1 : surfaces[k].first.size()};
    if (point && count == 1) {
      if (!grid->contains(point->first, point->second)) {
        return reportError(makeError(ErrorCode::InvalidArgument,
                                     o.file + ": point " + latLonText(point->first, point->second) +
                                         " is outside the grid"));
      }
    }
    if (point && grid->contains(point->first, point->second)) {
      report.bilinear = grid->sampleBilinear(point->first, point->second);
      report.bicubic = grid->sampleBicubic(point->first, point->second);
    } else {
      report.point.reset();
    }
    if (o.json) {
      all.push_back(demInfoJson(report));
    } else {
      if (k > 0) std::printf("\n");
      printDemInfoText(report);
    }
  }
  if (o.json) {
    // One grid: its object, as always; a set of several surfaces: an array of them.
    std::cout << (count == 1 ? all[0] : all).dump(2) << "\n";
  }
  return kExitOk;
}

}  // namespace

int reportError(const Error& error) {
  std::cerr << "pbdam: " << error.message << "\n";
  return error.code == ErrorCode::Internal || error.code == ErrorCode::IoError ||
                 error.code == ErrorCode::DeviceError
             ? kExitFailure
             : kExitBadInput;
}

Result<void> checkOutputDirectory(const std::string& out) {
  const std::filesystem::path parent = std::filesystem::path(out).parent_path();
  std::error_code ec;
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    return makeError(ErrorCode::InvalidArgument,
                     "--out '" + out + "': directory " + parent.string() + " does not exist");
  }
  return {};
}

void addDemCommands(CLI::App& app, CommandStatus& status) {
  CLI::App* dem = app.add_subcommand("dem", "Inspect elevation inputs (anything GDAL reads)");
  dem->require_subcommand(1);
  auto options = std::make_shared<DemInfoOptions>();
  CLI::App* info = dem->add_subcommand(
      "info", "Format, CRS/body, size, bounds, spacing, extremes, mean, nodata of a DEM");
  info->add_option("FILE", options->file,
                   "Elevation file (PDS3 .lbl, NetCDF, .hgt, GeoTIFF, VRT, raw), or a set of "
                   "tiles: a directory or a quoted glob")
      ->required();
  info->add_option("--at", options->at, "Also sample the height at LAT,LON (degrees)");
  info->add_flag("--json", options->json, "Machine-readable JSON output");
  addRawGridOptions(*info, options->raw);
  info->callback([options, &status] { status.exitCode = runDemInfo(*options); });
}

}  // namespace pbdam::tools
