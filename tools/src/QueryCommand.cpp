// `pbdam query cut DIR (--camera POSE | --focus … | --focus-path …) --out MESH.ply [--json]`: the
// mesh of a cut selected by predicate (runtime/Selection.h) as a binary PLY, for analysis
// outside pbdam. Vertices are the patches' terrain points in planetocentric metres (doubles:
// floats would round Mars' radius to a quarter metre), welded across patches by their lattice
// point; no geomorph (every vertex at its own height).

#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "Commands.h"
#include "FocusOption.h"
#include "pbdam/builder/Checkpoint.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Selection.h"
#include "pbdam/streaming/MappedDataset.h"

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

/// A welded triangle mesh in planetocentric metres.
struct CutMesh final {
  std::vector<glm::dvec3> vertices;
  std::vector<std::uint32_t> indices;
  int minLevel = 1 << 30;
  int maxLevel = -1;
};

Result<CutMesh> meshOfCut(const DatasetView& view, const Cut& cut) {
  CutMesh mesh;
  std::unordered_map<PointKey, std::uint32_t> welded;
  PatchMesh patch;
  std::vector<std::byte> blob;
  std::vector<std::uint32_t> local;
  for (const CutPatch& p : cut.patches) {
    const NodeRecord record = view.node(p.node);
    if (record.blobBytes == 0) continue;
    const formats::FaceView& face = view.face(p.node.face);
    auto bytes = face.readPatchBlob(record, blob);
    if (!bytes) return std::move(bytes).error();
    if (auto r =
            decodePatch(*bytes, patch, face.context() + "@" + std::to_string(record.blobOffset));
        !r) {
      return std::move(r).error();
    }
    const PatchVertexPlacement placement(view, p.node, record);
    local.resize(patch.vertices.size());
    for (std::size_t v = 0; v < patch.vertices.size(); ++v) {
      LatticeXY q{0};
      if (!placement.latticePoint(patch.vertices[v].b1, patch.vertices[v].b2, q)) {
        return makeError(ErrorCode::CorruptData,
                         face.context() + "@" + std::to_string(record.blobOffset) +
                             ": a patch vertex is not a lattice point of its node");
      }
      const PointKey key = latticePointKey(view.latticeCells(), p.node.face, q);
      const auto [it, inserted] =
          welded.try_emplace(key, static_cast<std::uint32_t>(mesh.vertices.size()));
      if (inserted)
        mesh.vertices.push_back(placement.terrainPoint(q, patch.vertices[v].heightSteps));
      local[v] = it->second;
    }
    for (const std::uint16_t i : patch.indices) mesh.indices.push_back(local[i]);
    mesh.minLevel = std::min(mesh.minLevel, p.level);
    mesh.maxLevel = std::max(mesh.maxLevel, p.level);
  }
  return mesh;
}

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
  if (o.camera.empty() && o.focus.circle.empty() && o.focus.path.empty()) {
    return bad("give --camera, --focus or --focus-path (or a camera with focus regions)");
  }
  if (!std::isfinite(o.tolerancePixels) || o.tolerancePixels <= 0.0) {
    return bad("--tolerance-px must be a positive number of pixels");
  }
  auto dataset = MappedDataset::open(o.dir);
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
  auto mesh = meshOfCut(view, cut);
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
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("wrote %s: %zu patches (levels %d-%d), %zu vertices, %zu triangles\n",
                o.out.c_str(), cut.patches.size(), mesh->minLevel, mesh->maxLevel,
                mesh->vertices.size(), mesh->indices.size() / 3);
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
}

}  // namespace pbdam::tools
