// `pbdam query cut DIR (--camera POSE | --focus … | --focus-path …) --out MESH.ply [--json]`: the
// mesh of a cut selected by predicate (runtime/Selection.h) as a binary PLY, for analysis
// outside pbdam. Vertices are the patches' terrain points in planetocentric metres (doubles:
// floats would round Mars' radius to a quarter metre), welded across patches by their lattice
// point; no geomorph (every vertex at its own height).
//
// `pbdam query los DIR --from LAT,LON,H --to LAT,LON,H [--json]`: whether the segment between
// two points H metres above the rendered terrain crosses it, tested on the device
// (gpu/GpuSightline.h) against the cut with leaves along the segment's ground track.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "Commands.h"
#include "FocusOption.h"
#include "ViewshedOutput.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/gpu/GpuViewshed.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/CutMesh.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/runtime/Viewshed.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::tools {
namespace {

struct QueryCutOptions {
  std::string dir;
  std::string camera;
  std::string out;
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
  double fovDegrees = 60.0;
  double tolerancePixels = 3.0;
  FocusCliOptions focus;
  bool json = false;
};

Result<void> writePly(const std::string& path, const CutMesh& mesh) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment pbdam query cut: planetocentric metres\n"
      "element vertex " +
      std::to_string(mesh.vertices.size()) +
      "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
      std::to_string(mesh.indices.size() / 3) +
      "\nproperty list uchar uint vertex_indices\nend_header\n";
  std::vector<std::byte> body(mesh.vertices.size() * 24 + mesh.indices.size() / 3 * 13);
  std::byte* at = body.data();
  for (const glm::dvec3& v : mesh.vertices) {
    const double xyz[3] = {v.x, v.y, v.z};
    std::memcpy(at, xyz, sizeof xyz);
    at += sizeof xyz;
  }
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    *at++ = std::byte{3};
    std::memcpy(at, &mesh.indices[t], 3 * sizeof(std::uint32_t));
    at += 3 * sizeof(std::uint32_t);
  }
  std::uint32_t crc = 0;
  return builder::writeFileAtomically(
      path, {std::as_bytes(std::span<const char>(header.data(), header.size())), body}, crc);
}

int runQueryCut(const QueryCutOptions& o) {
  const auto bad = [](const std::string& what) {
    return reportError(makeError(ErrorCode::InvalidArgument, what));
  };
  if (o.out.empty()) return bad("--out is required");
  if (auto r = checkOutputDirectory(o.out); !r) return reportError(r.error());
  if (o.camera.empty() && o.focus.circle.empty() && o.focus.path.empty()) {
    return bad("give --camera, --focus or --focus-path (or a camera with focus regions)");
  }
  if (!std::isfinite(o.tolerancePixels) || o.tolerancePixels <= 0.0) {
    return bad("--tolerance-px must be a positive number of pixels");
  }
  auto dataset = MappedDataset::open(o.dir, faceOptionsFor(cgroupMemoryLimit()));
  if (!dataset) return reportError(dataset.error());
  const DatasetView& view = (*dataset)->view();
  auto focus = focusRegions(o.focus, view.planet());
  if (!focus) return reportError(focus.error());
  SelectionOptions options;
  options.focus = std::move(*focus);
  options.refinement.morphRange = 0.0;
  // Without a camera: the focus regions alone, over the whole planet (no split by screen error,
  // no culling); the camera is then only a formality of select().
  CameraPose pose{0.0, 0.0, 10.0 * view.planet().equatorialRadiusMeters(), 0.0, -90.0, 0.0};
  options.refinement.tolerancePixels = std::numeric_limits<double>::infinity();
  options.refinement.frustumCulling = false;
  if (!o.camera.empty()) {
    auto parsed = parseCameraPose(o.camera);
    if (!parsed) return reportError(parsed.error());
    if (auto r = validateCameraPose(*parsed, view.planet()); !r) return reportError(r.error());
    pose = *parsed;
    options.refinement.tolerancePixels = o.tolerancePixels;
    options.refinement.frustumCulling = true;
  }
  const Viewport viewport{o.width, o.height, o.fovDegrees};
  if (auto r = validateViewport(viewport); !r) return reportError(r.error());
  const Camera camera = Camera::fromPose(view.planet(), pose, viewport);
  const CutSelector selector(view);
  SelectionStats stats;
  const Cut cut = selector.select(camera, options, &stats);
  auto mesh = cutMesh(view, cut);
  if (!mesh) return reportError(mesh.error());
  if (auto w = writePly(o.out, *mesh); !w) return reportError(w.error());
  if (o.json) {
    nlohmann::ordered_json j;
    j["out"] = o.out;
    j["patches"] = cut.patches.size();
    j["vertices"] = mesh->vertices.size();
    j["triangles"] = mesh->indices.size() / 3;
    j["min_level"] = mesh->minLevel;
    j["max_level"] = mesh->maxLevel;
    j["predicate_splits"] = stats.predicateSplits;
    j["closure_splits"] = stats.closureSplits;
    if (!options.focus.empty()) {
      // The patches the focus regions reach, and how fine they are (leaves: the dataset's depth).
      std::uint64_t reached = 0;
      int finest = -1, coarsest = 1 << 30;
      for (const CutPatch& patch : cut.patches) {
        const NodeRecord record = view.node(patch.node);
        const glm::dvec3 centre(record.sphereCenter[0], record.sphereCenter[1],
                                record.sphereCenter[2]);
        const auto reaches = [&](const FocusRegion& f) {
          return f.reaches(centre, static_cast<double>(record.sphereRadiusMeters));
        };
        if (std::none_of(options.focus.begin(), options.focus.end(), reaches)) continue;
        ++reached;
        finest = std::max(finest, patch.level);
        coarsest = std::min(coarsest, patch.level);
      }
      j["in_focus"] = {{"patches", reached},
                       {"min_level", reached > 0 ? coarsest : -1},
                       {"max_level", finest},
                       {"leaf_level", view.depth()}};
    }
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("wrote %s: %zu patches (levels %d-%d), %zu vertices, %zu triangles\n",
                o.out.c_str(), cut.patches.size(), mesh->minLevel, mesh->maxLevel,
                mesh->vertices.size(), mesh->indices.size() / 3);
  }
  return kExitOk;
}

struct QueryLosOptions {
  std::string dir;
  std::string from;
  std::string to;
  std::string device;
  bool json = false;
};

/// `LAT,LON,H` as a point H metres above the ground.
Result<gpu::GroundPoint> groundPoint(const std::string& option, const std::string& text) {
  std::vector<double> v;
  if (!parseNumberList(text, 3, v)) {
    return makeError(ErrorCode::InvalidArgument,
                     option + " '" + text + "': expected LAT,LON,HEIGHT_ABOVE_GROUND_M");
  }
  return gpu::GroundPoint{v[0], v[1], v[2]};
}

int runQueryLos(const QueryLosOptions& o) {
  auto dataset = MappedDataset::open(o.dir, faceOptionsFor(cgroupMemoryLimit()));
  if (!dataset) return reportError(dataset.error());
  const DatasetView& view = (*dataset)->view();
  const Planet& planet = view.planet();
  auto from = groundPoint("--from", o.from);
  if (!from) return reportError(from.error());
  auto to = groundPoint("--to", o.to);
  if (!to) return reportError(to.error());
  gpu::ContextOptions contextOptions;
  contextOptions.device = o.device;
  auto context = gpu::VulkanContext::create(contextOptions);
  if (!context) return reportError(context.error());
  auto line = gpu::sightlineOverTerrain(*context, view, *from, *to);
  if (!line) return reportError(line.error());
  const gpu::SightlineResult* sight = &line->result;
  const double length = glm::length(line->to - line->from);
  const glm::dvec3 blocked = line->from + sight->nearestFraction * (line->to - line->from);
  const GeodeticPosition at = planet.ecefToGeodetic(blocked);
  if (o.json) {
    std::cout << sightlineJson(planet, *line).dump(2) << "\n";
  } else if (sight->visible) {
    std::printf("visible: %.0f m of clear line (%llu triangles tested)\n", length,
                static_cast<unsigned long long>(line->triangles));
  } else {
    std::printf("blocked %.0f m from --from, at %.5f, %.5f, %.0f m (of %.0f m; %llu crossings)\n",
                sight->nearestFraction * length, at.latDegrees, at.lonDegrees, at.heightMeters,
                length, static_cast<unsigned long long>(sight->crossings));
  }
  return kExitOk;
}

struct QueryViewshedOptions {
  std::string dir;
  std::string at;
  std::optional<double> radiusMeters;
  std::optional<double> cellMeters;
  std::string out;
  std::string checkDem;
  std::string device;
  bool json = false;
};

int runQueryViewshed(const QueryViewshedOptions& o) {
  if (auto r = checkOutputDirectory(o.out); !r) return reportError(r.error());
  auto dataset = MappedDataset::open(o.dir, faceOptionsFor(cgroupMemoryLimit()));
  if (!dataset) return reportError(dataset.error());
  const DatasetView& view = (*dataset)->view();
  auto at = groundPoint("--at", o.at);
  if (!at) return reportError(at.error());
  const ViewshedRequest request{at->latDegrees, at->lonDegrees, at->heightAboveGroundMeters,
                                o.radiusMeters, o.cellMeters};
  // A bad request is refused before the device is made.
  auto grid = viewshedGrid(view, request);
  if (!grid) return reportError(grid.error());
  std::optional<HeightGrid> dem;
  if (!o.checkDem.empty()) {
    auto read = readDem(o.checkDem);
    if (!read) return reportError(read.error());
    dem = std::move(*read);
  }
  gpu::ContextOptions contextOptions;
  contextOptions.device = o.device;
  auto context = gpu::VulkanContext::create(contextOptions);
  if (!context) return reportError(context.error());
  auto viewshed = gpu::viewshedOverTerrain(*context, view, *grid);
  if (!viewshed) return reportError(viewshed.error());
  auto tiff = viewshedGeoTiff(*viewshed);
  if (!tiff) return reportError(tiff.error());
  std::uint32_t crc = 0;
  if (auto w = builder::writeFileAtomically(o.out, {*tiff}, crc); !w) return reportError(w.error());
  nlohmann::ordered_json j = viewshedJson(*viewshed, at->heightAboveGroundMeters);
  j["out"] = o.out;
  if (dem) {
    // The DEM's own answer: the eye the same height above the DEM's ground.
    const auto start = std::chrono::steady_clock::now();
    const auto ground = demHeight(*dem, grid->latDegrees, grid->lonDegrees);
    if (!ground) {
      return reportError(makeError(ErrorCode::InvalidArgument,
                                   "--check-dem " + o.checkDem + ": does not cover the observer"));
    }
    const glm::dvec3 eye = grid->planet.geodeticToEcef(grid->latDegrees, grid->lonDegrees,
                                                       *ground + at->heightAboveGroundMeters);
    const auto reference = viewshedByRayMarch(*grid, *dem, eye);
    const ViewshedAgreement agreement = compareViewsheds(viewshed->mask, reference);
    const ViewshedStats demStats = viewshedStats(*grid, reference);
    j["check"] = {{"dem", o.checkDem},
                  {"dem_ground_m", *ground},
                  {"cells_compared", agreement.compared},
                  {"agreement", agreement.fraction()},
                  {"visible_only_on_terrain", agreement.visibleOnlyInFirst},
                  {"visible_only_on_dem", agreement.visibleOnlyInSecond},
                  {"dem_visible_cells", demStats.visibleCells},
                  {"visible_agreement", agreement.visibleFraction()},
                  {"ray_march_ms", std::chrono::duration<double, std::milli>(
                                       std::chrono::steady_clock::now() - start)
                                       .count()}};
  }
  if (o.json) {
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf(
        "wrote %s: %d x %d cells of %.0f m, %.1f%% of %llu cells visible (%.0f km2), "
        "farthest %.0f m; %.0f ms\n",
        o.out.c_str(), viewshed->grid.cells, viewshed->grid.cells, viewshed->grid.cellMeters,
        100.0 * j["visible_fraction"].get<double>(),
        static_cast<unsigned long long>(viewshed->stats.cellsInRadius),
        j["visible_area_km2"].get<double>(), viewshed->stats.farthestVisibleMeters,
        viewshed->totalMilliseconds);
    if (dem) {
      std::printf(
          "ray march over %s agrees on %.2f%% of %llu cells\n", o.checkDem.c_str(),
          100.0 * j["check"]["agreement"].get<double>(),
          static_cast<unsigned long long>(j["check"]["cells_compared"].get<std::uint64_t>()));
    }
  }
  return kExitOk;
}

}  // namespace

void addQueryCommands(CLI::App& app, CommandStatus& status) {
  CLI::App* query = app.add_subcommand("query", "Queries on a dataset's cuts");
  query->require_subcommand(1);
  auto o = std::make_shared<QueryCutOptions>();
  CLI::App* cut = query->add_subcommand(
      "cut",
      "Write the mesh of a cut (a camera's screen-error cut, focus regions, or both; closed "
      "upward so it is conforming) as a binary PLY of planetocentric metres");
  cut->add_option("DIR", o->dir, "Dataset directory")->required();
  cut->add_option("--camera", o->camera,
                  "LAT,LON,ALT[,HEADING,PITCH,ROLL]: the screen-error cut of this camera "
                  "(culled to its view); without it, the focus regions alone over the planet");
  cut->add_option("--out", o->out, "PLY file")->required();
  cut->add_option("--width", o->width, "Image width of the camera")->capture_default_str();
  cut->add_option("--height", o->height, "Image height of the camera")->capture_default_str();
  cut->add_option("--fov-deg", o->fovDegrees, "Vertical field of view")->capture_default_str();
  cut->add_option("--tolerance-px", o->tolerancePixels, "Screen-space error tolerance")
      ->capture_default_str();
  addFocusOptions(*cut, o->focus);
  cut->add_flag("--json", o->json, "Print the figures as JSON");
  cut->callback([o, &status] { status.exitCode = runQueryCut(*o); });

  auto los = std::make_shared<QueryLosOptions>();
  CLI::App* sight = query->add_subcommand(
      "los",
      "Line of sight between two points above the terrain, tested on the device against the "
      "mesh with leaves along the line's ground track");
  sight->add_option("DIR", los->dir, "Dataset directory")->required();
  sight->add_option("--from", los->from, "LAT,LON,HEIGHT_ABOVE_GROUND_M of the observer")
      ->required();
  sight->add_option("--to", los->to, "LAT,LON,HEIGHT_ABOVE_GROUND_M of the target")->required();
  sight->add_option("--device", los->device, kDeviceOptionHelp);
  sight->add_flag("--json", los->json, "Print the answer as JSON");
  sight->callback([los, &status] { status.exitCode = runQueryLos(*los); });

  auto vs = std::make_shared<QueryViewshedOptions>();
  CLI::App* viewshed = query->add_subcommand(
      "viewshed",
      "The terrain an eye above the ground sees within a radius, decided on the device over the "
      "rendered leaves; a GeoTIFF mask (1 visible, 0 hidden, 255 nodata) in the eye's azimuthal "
      "equidistant projection");
  viewshed->add_option("DIR", vs->dir, "Dataset directory")->required();
  viewshed->add_option("--at", vs->at, "LAT,LON,HEIGHT_ABOVE_GROUND_M of the eye")->required();
  viewshed->add_option("--radius-m", vs->radiusMeters,
                       "Radius along the surface (default: 256 cells, or the horizon limit if "
                       "nearer)");
  viewshed->add_option("--cell-m", vs->cellMeters,
                       "Cell size (default: the leaf lattice's spacing)");
  viewshed->add_option("--out", vs->out, "GeoTIFF file")->required();
  viewshed->add_option("--check-dem", vs->checkDem,
                       "Also decide every cell by a brute-force ray march over this DEM (the "
                       "dataset's source) and report the agreement");
  viewshed->add_option("--device", vs->device, kDeviceOptionHelp);
  viewshed->add_flag("--json", vs->json, "Print the figures as JSON");
  viewshed->callback([vs, &status] { status.exitCode = runQueryViewshed(*vs); });
}

}  // namespace pbdam::tools
