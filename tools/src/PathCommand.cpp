// `pbdam path great-circle|waypoints …`: camera-path CSV files (docs/architecture.md "Formats") for
// `pbdam render
// --path` and `pbdam bench`, flown along geodesics (runtime/FlightPath.h).
#include <cstdio>
#include <memory>
#include <vector>

#include "Commands.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/runtime/FlightPath.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {
namespace {

struct PathCliOptions {
  std::vector<std::string> points;  // --from/--to or --via, in order
  std::string from, to;
  double duration = 10.0;
  double fps = 30.0;
  std::string planet;
  std::string dataset;
  std::string out;
  std::optional<double> pitch;
};

Result<Waypoint> parseWaypoint(const std::string& option, const std::string& text) {
  std::vector<double> v;
  if (!parseNumberList(text, 3, v)) {
    return makeError(ErrorCode::InvalidArgument,
                     option + " '" + text + "': expected LAT,LON,ALT (degrees, metres)");
  }
  return Waypoint{v[0], v[1], v[2]};
}

Result<Planet> choosePlanet(const PathCliOptions& o) {
  if (!o.planet.empty() && !o.dataset.empty()) {
    return makeError(ErrorCode::InvalidArgument, "give --planet or --dataset, not both");
  }
  if (!o.dataset.empty()) {
    auto manifest = readManifest(o.dataset);
    if (!manifest) return std::move(manifest).error();
    return Planet::fromSpec(manifest->planetSpec);
  }
  if (o.planet.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "the path needs a planet: --planet mars|earth|… or --dataset DIR");
  }
  return Planet::fromSpec(o.planet);
}

int runPath(const PathCliOptions& o, const std::vector<std::string>& names) {
  std::vector<Waypoint> waypoints;
  for (std::size_t k = 0; k < o.points.size(); ++k) {
    auto w = parseWaypoint(names[k], o.points[k]);
    if (!w) return reportError(w.error());
    waypoints.push_back(*w);
  }
  auto planet = choosePlanet(o);
  if (!planet) return reportError(planet.error());
  FlightOptions options{o.duration, o.fps, o.pitch};
  auto path = waypointFlight(*planet, waypoints, options);
  if (!path) return reportError(path.error());
  if (auto written = writeCameraPath(o.out, *path); !written) return reportError(written.error());
  std::printf("%s: %zu poses over %.1f s on %s, mean speed %.1f km/s\n", o.out.c_str(),
              path->size(), o.duration, planet->name().c_str(),
              meanSpeedMetersPerSecond(*planet, *path) / 1e3);
  return kExitOk;
}

void addCommonOptions(CLI::App* cmd, PathCliOptions& o) {
  cmd->add_option("--duration", o.duration, "Flight time in seconds")->required();
  cmd->add_option("--fps", o.fps, "Poses per second")->capture_default_str();
  cmd->add_option("--planet", o.planet, "mars | earth | moon | sphere:R | ellipsoid:A,F");
  cmd->add_option("--dataset", o.dataset, "Take the planet from this dataset's manifest");
  cmd->add_option("--pitch-deg", o.pitch,
                  "Fixed pitch (default: -15 at 1 km altitude easing to -90 at one radius)");
  cmd->add_option("--out", o.out, "CSV file to write (t,lat,lon,alt,heading,pitch,roll)")
      ->required();
}

}  // namespace

void addPathCommands(CLI::App& app, CommandStatus& status) {
  CLI::App* path = app.add_subcommand("path", "Write camera paths for render and bench");
  path->require_subcommand(1);

  auto gc = std::make_shared<PathCliOptions>();
  CLI::App* greatCircle = path->add_subcommand(
      "great-circle", "Fly along the geodesic between two points with a smooth altitude profile");
  greatCircle->add_option("--from", gc->from, "Start LAT,LON,ALT")->required();
  greatCircle->add_option("--to", gc->to, "End LAT,LON,ALT")->required();
  addCommonOptions(greatCircle, *gc);
  greatCircle->callback([gc, &status] {
    gc->points = {gc->from, gc->to};
    status.exitCode = runPath(*gc, {"--from", "--to"});
  });

  auto wp = std::make_shared<PathCliOptions>();
  CLI::App* waypoints = path->add_subcommand(
      "waypoints",
      "Fly through waypoints along geodesics, time per leg proportional to its length");
  waypoints->add_option("--via", wp->points, "LAT,LON,ALT (repeat, at least twice)")
      ->required()
      ->take_all();
  addCommonOptions(waypoints, *wp);
  waypoints->callback([wp, &status] {
    status.exitCode = runPath(*wp, std::vector<std::string>(wp->points.size(), "--via"));
  });
}

}  // namespace pbdam::tools
