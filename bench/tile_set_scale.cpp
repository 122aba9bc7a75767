// A tile set's cost against its tile count (docs/performance.md "Survey tiles"): reads one set of
// tiles as `pbdam build` reads an inset (CompositeSurface::read: probe, group, mosaic, voids,
// edge distances) out of core — every grid and per-sample array in a mapped scratch file — and
// reports the process's peak resident memory, the read's CPU time and the cost of a height query
// at random points of the set. Run once per set (bench/tile_set_scale.sh), each in its own
// process so that the peak is that set's.
//   pbdam_tile_set_scale SET BASE SCRATCHDIR [--queries N] [--in-memory]
// SET: a directory, glob or VRT of tiles; BASE: the base DEM. --in-memory reads as a small set is
// read (grids and arrays in process memory), for the comparison. Prints one JSON object.
#include <sys/resource.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"

namespace fs = std::filesystem;
using namespace pbdam;

namespace {

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double peakRssMiB() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // kB on Linux
}

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "pbdam_tile_set_scale: %s\n", what.c_str());
  std::exit(1);
}

int run(int argc, char** argv) {
  if (argc < 4) {
    die("usage: pbdam_tile_set_scale SET BASE SCRATCHDIR [--queries N] [--in-memory]");
  }
  const fs::path set = argv[1], basePath = argv[2], scratch = argv[3];
  int queries = 200000;
  bool inMemory = false;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--queries" && i + 1 < argc) {
      queries = std::atoi(argv[++i]);
    } else if (a == "--in-memory") {
      inMemory = true;
    } else {
      die("unknown argument " + a);
    }
  }
  auto base = formats::readDem(basePath);
  if (!base) die(base.error().message);
  const double baseRss = peakRssMiB();
  formats::DemReadOptions options;
  builder::VoidFillOptions fill;
  if (!inMemory) {
    options.scratchDirectory = scratch;
    options.mapAtBytes = 0;
    fill.scratchDirectory = scratch;
  }
  const double cpu0 = cpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  auto composite = builder::CompositeSurface::read(*base, {builder::InsetSpec{set, {}, {}}},
                                                   options, "earth", fill);
  if (!composite) die(composite.error().message);
  const double readCpu = cpuSeconds() - cpu0;
  const double readWall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double readPeak = peakRssMiB();
  std::int64_t samples = 0;
  std::size_t tiles = 0;
  formats::LatLonBounds box{90.0, 360.0, -90.0, -360.0};
  for (const auto& inset : composite->insets()) {
    samples += inset.grid.width() * inset.grid.height();
    tiles += inset.tiles;
    const formats::LatLonBounds b = inset.grid.bounds();
    box = formats::LatLonBounds{
        std::min(box.southDegrees, b.southDegrees), std::min(box.westDegrees, b.westDegrees),
        std::max(box.northDegrees, b.northDegrees), std::max(box.eastDegrees, b.eastDegrees)};
  }
  // Height queries at random points of the set: the first pass brings the pages in, the second
  // is timed.
  std::mt19937_64 random(11);
  std::uniform_real_distribution<double> lat(box.southDegrees, box.northDegrees);
  std::uniform_real_distribution<double> lon(box.westDegrees, box.eastDegrees);
  std::vector<std::pair<double, double>> points(static_cast<std::size_t>(queries));
  for (auto& p : points) p = {lat(random), lon(random)};
  double sum = 0.0;
  for (const auto& [la, lo] : points) sum += composite->heightAt(la, lo).value_or(0.0);
  const auto q0 = std::chrono::steady_clock::now();
  for (const auto& [la, lo] : points) sum += composite->heightAt(la, lo).value_or(0.0);
  const double queryNs =
      std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - q0).count() /
      static_cast<double>(points.size());
  nlohmann::json out{{"set", set.string()},
                     {"tiles", tiles},
                     {"surfaces", composite->insets().size()},
                     {"samples", samples},
                     {"out_of_core", !inMemory},
                     {"read_cpu_s", readCpu},
                     {"read_wall_s", readWall},
                     {"base_peak_rss_mib", baseRss},
                     {"read_peak_rss_mib", readPeak},
                     {"height_query_ns", queryNs},
                     {"checksum", sum}};
  std::printf("%s\n", out.dump().c_str());
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
