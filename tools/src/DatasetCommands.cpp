// `pbdam info` (what a dataset holds: counts, bytes per section, compression, errors per level)
// and `pbdam verify` (every invariant; tools/builder/Verify.h).
#include <nlohmann/json.hpp>

#include <bit>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>

#include "Commands.h"
#include "DemInputOptions.h"
#include "Progress.h"
#include "pbdam/builder/Verify.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/streaming/MappedFile.h"

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::tools {
namespace {

struct LevelStats {
  std::uint64_t nodes = 0;
  std::uint64_t leaves = 0;
  std::uint64_t vertices = 0;
  std::uint64_t triangles = 0;
  std::uint64_t compressedBytes = 0;
  std::uint64_t minTriangles = std::numeric_limits<std::uint64_t>::max();  ///< per patch
  std::uint64_t maxTriangles = 0;
  double minError = std::numeric_limits<double>::infinity();
  double maxError = 0.0;
};

/// Adds every node of a face to the statistics of its level.
void addNodeStats(const FaceView& view, std::vector<LevelStats>& levels) {
  for (std::uint64_t k = 0; k < view.header().nodeCount; ++k) {
    const NodeRecord n = view.nodeAt(k);
    const auto level = static_cast<std::size_t>(std::bit_width(n.heapIndex + 1) - 1);
    LevelStats& s = levels[level];
    ++s.nodes;
    s.leaves += n.leaf() ? 1U : 0U;
    s.vertices += n.vertexCount;
    s.triangles += n.triangleCount;
    s.minTriangles = std::min<std::uint64_t>(s.minTriangles, n.triangleCount);
    s.maxTriangles = std::max<std::uint64_t>(s.maxTriangles, n.triangleCount);
    s.compressedBytes += n.blobBytes;
    s.minError = std::min(s.minError, static_cast<double>(n.errorMeters));
    s.maxError = std::max(s.maxError, static_cast<double>(n.errorMeters));
  }
}

/// The bytes of a dataset's files by what they hold.
struct InfoBytes {
  std::uint64_t file = 0, headers = 0, nodeTables = 0, textureTables = 0, textures = 0;
  std::uint64_t normals = 0, tiles = 0;
};

/// `pbdam info --json`: the manifest's essentials, the totals and the per-level statistics.
void printInfoJson(const std::string& dir, const Manifest& m, const std::vector<LevelStats>& levels,
                   const LevelStats& total, const InfoBytes& b, std::uint64_t rawBytes,
                   double ratio) {
  nlohmann::ordered_json j;
  j["dataset"] = dir;
  j["planet"] = m.planetSpec;
  j["equatorial_radius_m"] = m.equatorialRadiusMeters;
  j["lattice_cells"] = m.latticeCells;
  j["leaf_cells"] = m.leafCells;
  j["depth"] = m.depth;
  j["texture_levels"] = m.textureLevels;
  j["texture_format"] = m.textureFormat;
  j["texture_normal_format"] = m.textureNormalFormat;
  j["texture_source"] = m.textureSource;
  j["source_dem"] = m.sourceDem;
  if (!m.insets.empty()) j["insets"] = nlohmann::ordered_json::parse(manifestInsetsJson(m));
  j["nodes"] = total.nodes;
  j["patches"] = total.nodes;
  j["vertices"] = total.vertices;
  j["triangles"] = total.triangles;
  j["texture_tiles"] = b.tiles;
  j["bytes"] = {{"total", b.file},
                {"headers", b.headers},
                {"node_tables", b.nodeTables},
                {"texture_tables", b.textureTables},
                {"patches", total.compressedBytes},
                {"textures", b.textures},
                {"normal_maps", b.normals}};
  j["patch_bytes_uncompressed"] = rawBytes;
  j["compression_ratio"] = ratio;
  nlohmann::ordered_json per = nlohmann::ordered_json::array();
  for (std::size_t l = 0; l < levels.size(); ++l) {
    per.push_back({{"level", l},
                   {"nodes", levels[l].nodes},
                   {"leaves", levels[l].leaves},
                   {"triangles", levels[l].triangles},
                   {"vertices", levels[l].vertices},
                   {"patch_triangles_min", levels[l].nodes > 0 ? levels[l].minTriangles : 0},
                   {"patch_triangles_max", levels[l].maxTriangles},
                   {"error_min_m", levels[l].minError},
                   {"error_max_m", levels[l].maxError}});
  }
  j["levels"] = per;
  std::cout << j.dump(2) << "\n";
}

int runInfo(const std::string& dir, bool json) {
  auto manifest = readManifest(dir);
  if (!manifest) return reportError(manifest.error());
  const Manifest& m = *manifest;
  std::vector<LevelStats> levels(m.depth + 1);
  InfoBytes b;
  for (const ManifestFace& f : m.faces) {
    auto file = MappedFile::open(std::filesystem::path(dir) / f.file);
    if (!file) return reportError(file.error());
    auto view = FaceView::open(file->bytes(), (std::filesystem::path(dir) / f.file).string());
    if (!view) return reportError(view.error());
    const FaceHeader& h = view->header();
    b.file += h.fileBytes;
    b.headers += kFaceHeaderBytes;
    b.nodeTables += h.nodeCount * kNodeRecordBytes;
    b.textureTables += h.textureNodeCount * kTextureRecordBytes;
    addNodeStats(*view, levels);
    for (std::uint64_t k = 0; k < h.textureNodeCount; ++k) {
      b.textures += view->textureAt(k).blobBytes;
      b.normals += view->textureAt(k).normalBytes;
      ++b.tiles;
    }
  }
  LevelStats total;
  for (const LevelStats& s : levels) {
    total.nodes += s.nodes;
    total.vertices += s.vertices;
    total.triangles += s.triangles;
    total.compressedBytes += s.compressedBytes;
  }
  const std::uint64_t rawBytes = 8 * total.vertices + 6 * total.triangles;
  const double ratio =
      rawBytes > 0 ? static_cast<double>(total.compressedBytes) / static_cast<double>(rawBytes)
                   : 0.0;
  if (json) {
    printInfoJson(dir, m, levels, total, b, rawBytes, ratio);
    return kExitOk;
  }
  std::printf("dataset   %s\n", dir.c_str());
  std::printf("planet    %s (equatorial radius %.0f m, flattening %.9g)\n", m.planetSpec.c_str(),
              m.equatorialRadiusMeters, m.flattening);
  std::printf("source    %s (%s), heights %.0f .. %.0f m\n", m.sourceDem.c_str(),
              m.sourceFormat.c_str(), m.minHeightMeters, m.maxHeightMeters);
  for (const ManifestInset& i : m.insets) {
    std::printf(
        "inset     %s (%s), %llu samples over %.4f..%.4f°N %.4f..%.4f°E, leaves at level "
        "%u, band %u samples, offset %g m, texture %s\n",
        i.file.c_str(), i.format.c_str(), static_cast<unsigned long long>(i.samples),
        i.southDegrees, i.northDegrees, i.westDegrees, i.eastDegrees, i.leafLevel, i.bandSamples,
        i.offsetMeters, i.texture.c_str());
  }
  std::printf("lattice   %u cells per face side, leaves of %u cells, bintree levels 0..%u\n",
              m.latticeCells, m.leafCells, m.depth);
  std::printf("patches   %llu (%llu vertices, %llu triangles)\n",
              static_cast<unsigned long long>(total.nodes),
              static_cast<unsigned long long>(total.vertices),
              static_cast<unsigned long long>(total.triangles));
  std::printf("textures  %llu tiles of %u texels, %u levels, %s, %s; %s normal maps of %u texels\n",
              static_cast<unsigned long long>(b.tiles), m.textureTileTexels, m.textureLevels,
              m.textureFormat.c_str(), m.textureSource.c_str(), m.textureNormalFormat.c_str(),
              m.normalTileTexels());
  std::printf(
      "bytes     %.2f MB: patches %.2f MB (%.2f MB raw, ratio %.2f), textures %.2f MB, "
      "normal maps %.2f MB, node tables %.2f MB, texture tables %.3f MB\n",
      static_cast<double>(b.file) / 1e6, static_cast<double>(total.compressedBytes) / 1e6,
      static_cast<double>(rawBytes) / 1e6, ratio, static_cast<double>(b.textures) / 1e6,
      static_cast<double>(b.normals) / 1e6, static_cast<double>(b.nodeTables) / 1e6,
      static_cast<double>(b.textureTables) / 1e6);
  std::printf(
      "level  nodes  leaves  triangles  per patch min / mean / max  error min .. max (m)\n");
  for (std::size_t l = 0; l < levels.size(); ++l) {
    const LevelStats& s = levels[l];
    const double mean =
        s.nodes > 0 ? static_cast<double>(s.triangles) / static_cast<double>(s.nodes) : 0.0;
    std::printf("%5zu %6llu %7llu %10llu  %8llu / %6.0f / %6llu   %9.2f .. %.2f\n", l,
                static_cast<unsigned long long>(s.nodes), static_cast<unsigned long long>(s.leaves),
                static_cast<unsigned long long>(s.triangles),
                static_cast<unsigned long long>(s.nodes > 0 ? s.minTriangles : 0), mean,
                static_cast<unsigned long long>(s.maxTriangles), s.minError, s.maxError);
  }
  return kExitOk;
}

struct VerifyCliOptions {
  std::string dir;
  std::string dem;
  std::vector<std::string> insets;
  std::vector<double> insetOffsets;
  bool json = false;
  bool quiet = false;
  RawGridOptions raw;
};

int runVerify(const VerifyCliOptions& c) {
  builder::VerifyOptions o;
  o.datasetDir = c.dir;
  o.demPath = c.dem;
  auto raw = rawLayoutOf(c.raw);
  if (!raw) return reportError(raw.error());
  if (*raw && c.dem.empty()) {
    return reportError(makeError(ErrorCode::InvalidArgument,
                                 "--raw-size, --raw-type, --bounds and --raw-header describe the "
                                 "--dem file: pass --dem FILE too"));
  }
  o.rawLayout = *raw;
  if (!c.dem.empty() && !o.rawLayout) noteDemLabel(c.dem);
  auto insets = insetSpecsOf(c.insets, c.insetOffsets);
  if (!insets) return reportError(insets.error());
  if (!insets->empty() && c.dem.empty()) {
    return reportError(makeError(ErrorCode::InvalidArgument,
                                 "--inset joins an inset to the --dem base: pass --dem FILE too"));
  }
  o.insets = std::move(insets).value();
  Progress progress(c.quiet || c.json);
  o.progress = [&](std::string_view stage, double f) { progress.update(stage, f); };
  auto report = builder::verifyDataset(o);
  progress.finish();
  if (!report) return reportError(report.error());
  const auto& r = *report;
  if (c.json) {
    nlohmann::ordered_json j;
    j["dataset"] = c.dir;
    j["ok"] = r.ok();
    j["violation_count"] = r.violationCount;
    j["violations"] = r.violations;
    j["nodes_checked"] = r.nodesChecked;
    j["patches_decoded"] = r.patchesDecoded;
    j["morph_targets_checked"] = r.morphTargetsChecked;
    j["tiles_decoded"] = r.tilesDecoded;
    j["edges_compared"] = r.edgesCompared;
    j["dem_samples_checked"] = r.demSamplesChecked;
    j["worst_error_ratio"] = r.worstErrorRatio;
    std::cout << j.dump(2) << "\n";
  } else if (r.ok()) {
    std::printf(
        "ok: %llu patches and %llu texture tiles decode; %llu patches' morph targets match "
        "their ancestors; %llu shared edges agree; errors and spheres nest over the diamond DAG",
        static_cast<unsigned long long>(r.patchesDecoded),
        static_cast<unsigned long long>(r.tilesDecoded),
        static_cast<unsigned long long>(r.morphTargetsChecked),
        static_cast<unsigned long long>(r.edgesCompared));
    if (r.demSamplesChecked > 0) {
      std::printf("; %llu DEM samples within stored errors (worst at %.0f%% of the bound)",
                  static_cast<unsigned long long>(r.demSamplesChecked), 100.0 * r.worstErrorRatio);
    }
    std::printf("\n");
  } else {
    std::fprintf(stderr, "pbdam: %s: %llu violations; the first:\n", c.dir.c_str(),
                 static_cast<unsigned long long>(r.violationCount));
    for (const auto& v : r.violations) std::fprintf(stderr, "  %s\n", v.c_str());
  }
  return r.ok() ? kExitOk : kExitBadInput;
}

}  // namespace

void addDatasetCommands(CLI::App& app, CommandStatus& status) {
  auto infoDir = std::make_shared<std::string>();
  auto infoJson = std::make_shared<bool>(false);
  CLI::App* info = app.add_subcommand(
      "info", "Summarise a dataset: planet, levels, counts, bytes per section, errors per level");
  info->add_option("DIR", *infoDir, "Dataset directory")->required();
  info->add_flag("--json", *infoJson, "Machine-readable JSON output");
  info->callback([infoDir, infoJson, &status] { status.exitCode = runInfo(*infoDir, *infoJson); });

  auto v = std::make_shared<VerifyCliOptions>();
  CLI::App* verify = app.add_subcommand(
      "verify", "Check a dataset's checksums and every P-BDAM invariant (exit 2 on violations)");
  verify->add_option("DIR", v->dir, "Dataset directory")->required();
  verify->add_option("--dem", v->dem, "Also check stored errors against this source DEM");
  addRawGridOptions(*verify, v->raw);
  addInsetOptions(*verify, v->insets, v->insetOffsets);
  verify->add_flag("--json", v->json, "Machine-readable JSON report");
  verify->add_flag("--quiet", v->quiet, "No progress output");
  verify->callback([v, &status] { status.exitCode = runVerify(*v); });
}

}  // namespace pbdam::tools
