// `pbdam build`: a DEM (+ imagery) into a P-BDAM dataset (tools/builder/Builder.h), in one
// process or, under `mpirun -np N`, distributed over N ranks (docs/builder.md "Distributed
// build").
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "Commands.h"
#include "DemInputOptions.h"
#include "MpiLauncher.h"
#include "Progress.h"
#include "pbdam/builder/Builder.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/FileWrite.h"

using namespace pbdam::formats;

namespace pbdam::tools {
namespace {

struct BuildCliOptions {
  std::string dem;
  std::string texture;
  std::string planet;
  std::string out;
  std::uint32_t leafVertices = 33;
  std::uint32_t minPatchTriangles = 512;
  double errorMargin = 0.25;
  std::uint32_t textureTile = 256;
  std::string levels = "auto";
  std::vector<std::string> deepRegions;  ///< "S,W,N,E@LEVEL"
  std::vector<std::string> insets;
  std::vector<double> insetOffsets;
  std::vector<std::string> insetTextures;
  std::string textureFormat = "bc1";
  std::string textureQuality = "fast";
  int threads = 0;
  std::uint64_t residentMib = 768;
  bool force = false;
  bool resume = false;
  std::string freeCheckpoint = "auto";
  bool quiet = false;
  std::string stats;
  RawGridOptions raw;
};

/// The exit code reportError would give, without printing (ranks other than 0 stay silent).
int exitCodeOf(const Error& error) {
  return error.code == ErrorCode::Internal || error.code == ErrorCode::IoError ||
                 error.code == ErrorCode::DeviceError
             ? kExitFailure
             : kExitBadInput;
}

// What the ranks work on in the current stage, for the SIGTERM handler: when a rank dies,
// mpirun stops the others with SIGTERM, and rank 0 then says what every rank was doing. Two
// buffers so that the handler never reads one being written.
constexpr std::size_t kStageTextBytes = 4096;
char stageText[2][kStageTextBytes];
std::atomic<int> stageTextIndex{-1};

void onTerminate(int signal) {
  const int index = stageTextIndex.load();
  const char* lead =
      "\npbdam: rank 0: the job was stopped (SIGTERM: a rank failed or the job was cancelled; "
      "mpirun names the rank above) during ";
  ssize_t ignored = ::write(STDERR_FILENO, lead, std::strlen(lead));
  if (index >= 0) {
    ignored = ::write(STDERR_FILENO, stageText[index], std::strlen(stageText[index]));
  }
  const char* tail = ". Rerun the same command with --resume to continue.\n";
  ignored = ::write(STDERR_FILENO, tail, std::strlen(tail));
  (void)ignored;
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

void rememberStage(std::string_view text) {
  const int next = stageTextIndex.load() == 0 ? 1 : 0;
  const std::size_t n = std::min(text.size(), kStageTextBytes - 1);
  std::memcpy(stageText[next], text.data(), n);
  stageText[next][n] = '\0';
  stageTextIndex.store(next);
}

/// PBDAM_TEST_FAIL_RANK / PBDAM_TEST_FAIL_LEVEL / PBDAM_TEST_FAIL_MODE (kill | error): the
/// fault-injection aid of the distributed-build tests.
builder::BuildOptions::FaultInjection faultFromEnvironment() {
  builder::BuildOptions::FaultInjection f;
  const char* rank = std::getenv("PBDAM_TEST_FAIL_RANK");
  const char* level = std::getenv("PBDAM_TEST_FAIL_LEVEL");
  if (rank != nullptr && level != nullptr) {
    f.failRank = std::atoi(rank);
    f.failLevel = std::atoi(level);
    const char* mode = std::getenv("PBDAM_TEST_FAIL_MODE");
    f.failByKill = mode == nullptr || std::strcmp(mode, "error") != 0;
  }
  return f;
}

/// Parses every --deep-region "S,W,N,E@LEVEL" into `o`; an error names the bad one.
Result<void> parseDeepRegions(const std::vector<std::string>& texts, builder::BuildOptions& o) {
  for (const std::string& text : texts) {
    const auto at = text.find('@');
    const auto bad = [&text] {
      return makeError(ErrorCode::InvalidArgument,
                       "--deep-region '" + text +
                           "': expected S,W,N,E@LEVEL (degrees, -90 <= S < N <= 90, W < E; an "
                           "even bintree level deeper than --levels)");
    };
    if (at == std::string::npos) return bad();
    RawLayout box;
    if (!parseRawBounds(std::string_view(text).substr(0, at), box)) return bad();
    try {
      std::size_t used = 0;
      const std::string level = text.substr(at + 1);
      const int leafLevel = std::stoi(level, &used);
      if (used != level.size() || leafLevel <= 0 ||
          leafLevel > static_cast<int>(formats::kMaxBintreeDepth))
        return bad();
      o.deepRegions.push_back(builder::DeepRegion{box.bounds, leafLevel});
    } catch (const std::exception&) {
      return bad();
    }
  }
  return {};
}

/// What a build did, on stdout.
void printBuildSummary(const std::string& out, const builder::BuildSummary& s) {
  std::printf("built %s in %.1f s\n", out.c_str(), s.seconds);
  if (s.ranks > 1) {
    std::printf("  ranks       %d MPI ranks (rank 0 wrote the dataset)\n", s.ranks);
  }
  if (s.resumedAfterLevel) {
    std::printf("  resumed     after level %d%s of the checkpoint\n", *s.resumedAfterLevel,
                s.resumedAfterTexture ? " and the textures" : "");
  }
  std::printf("  lattice     %u cells per face side, bintree depth %u, %u texture levels\n",
              s.latticeCells, s.depth, s.textureLevels);
  std::printf("  input       %llu source samples -> %llu lattice samples (%.2f M samples/s)\n",
              static_cast<unsigned long long>(s.sourceSamples),
              static_cast<unsigned long long>(s.latticeSamples),
              static_cast<double>(s.latticeSamples) / s.seconds / 1e6);
  std::printf("  patches     %llu (%llu triangles, %llu at full resolution)\n",
              static_cast<unsigned long long>(s.patches),
              static_cast<unsigned long long>(s.totalTriangles),
              static_cast<unsigned long long>(s.leafTriangles));
  std::printf("  errors      leaves <= %.2f m, roots %.1f m\n", s.leafMaxErrorMeters,
              s.rootErrorMeters);
  std::printf(
      "  geometry    %.1f MB compressed from %.1f MB (ratio %.2f)\n",
      static_cast<double>(s.patchBytesCompressed) / 1e6, static_cast<double>(s.patchBytesRaw) / 1e6,
      s.patchBytesRaw > 0
          ? static_cast<double>(s.patchBytesCompressed) / static_cast<double>(s.patchBytesRaw)
          : 0.0);
  std::printf("  morphing    %.1f MB of morph targets\n",
              static_cast<double>(s.morphTargetBytes) / 1e6);
  std::printf("  textures    %llu tiles\n", static_cast<unsigned long long>(s.textureTiles));
  std::printf("  dataset     %.1f MB on disk\n", static_cast<double>(s.datasetBytes) / 1e6);
  for (const builder::InsetSurfaceSummary& inset : s.insets) {
    const builder::VoidReport& v = inset.voids;
    std::printf(
        "  inset       %s: %zu tile%s, %lld voids (%lld samples): %lld filled from their "
        "rims (%lld samples), %lld left to the surface below (%lld samples)\n",
        inset.name.c_str(), inset.tiles, inset.tiles == 1 ? "" : "s",
        static_cast<long long>(v.voids), static_cast<long long>(v.voidSamples),
        static_cast<long long>(v.filledVoids), static_cast<long long>(v.filledSamples),
        static_cast<long long>(v.largeVoids), static_cast<long long>(v.belowSamples));
    if (v.largeVoids > 0) {
      std::printf(
          "  note        the surface below shows through %s's largest void at "
          "%.4f..%.4f°N %.4f..%.4f°E (%lld samples)\n",
          inset.name.c_str(), v.largestBelow.southDegrees, v.largestBelow.northDegrees,
          v.largestBelow.westDegrees, v.largestBelow.eastDegrees,
          static_cast<long long>(v.largestBelowSamples));
    }
  }
  if (s.noDataPoints > 0) {
    std::printf("  note        %llu lattice points had no DEM data (height 0)\n",
                static_cast<unsigned long long>(s.noDataPoints));
  }
  if (s.halvesOverTarget > 0) {
    std::printf("  note        %llu patches reached 65535 vertices before their error target\n",
                static_cast<unsigned long long>(s.halvesOverTarget));
  }
  // CPU seconds per stage (each with its unit, so that README checks mask them): the levels'
  // sum in build order among the others, then each level on a line of its own, leaves first.
  double total = 0.0;
  double levelsTotal = 0.0;
  std::string before;
  std::string after;
  std::string levels;
  char buf[64];
  for (const auto& [stage, cpu] : s.cpuSeconds) {
    total += cpu;
    if (stage.rfind("level ", 0) == 0) {
      levelsTotal += cpu;
      std::snprintf(buf, sizeof buf, "%s%s: %.1f s", levels.empty() ? "" : ", ", stage.c_str() + 6,
                    cpu);
      levels += buf;
      continue;
    }
    std::snprintf(buf, sizeof buf, ", %s %.1f s", stage.c_str(), cpu);
    (levels.empty() ? before : after) += buf;
  }
  if (!levels.empty()) {
    std::snprintf(buf, sizeof buf, ", levels %.1f s", levelsTotal);
    before += buf;
  }
  const std::string joined = before + after;
  const std::string stages = joined.size() > 2 ? joined.substr(2) : joined;  // each begins ", "
  std::printf("  cpu         %.1f s%s: %s\n", total, s.ranks > 1 ? " on rank 0" : "",
              stages.c_str());
  if (!levels.empty()) std::printf("  cpu levels  %s\n", levels.c_str());
}

/// The summary as JSON (--stats): what the CLI prints, in numbers.
bool writeBuildStats(const std::string& path, const builder::BuildSummary& s) {
  nlohmann::ordered_json j;
  j["seconds"] = s.seconds;
  j["ranks"] = s.ranks;
  j["lattice_cells"] = s.latticeCells;
  j["depth"] = s.depth;
  j["source_samples"] = s.sourceSamples;
  j["lattice_samples"] = s.latticeSamples;
  j["patches"] = s.patches;
  j["triangles"] = s.totalTriangles;
  j["root_error_m"] = s.rootErrorMeters;
  j["dataset_bytes"] = s.datasetBytes;
  nlohmann::ordered_json cpu = nlohmann::ordered_json::object();
  double total = 0.0;
  for (const auto& [stage, seconds] : s.cpuSeconds) {
    total += seconds;
    cpu[stage] = seconds;
  }
  cpu["total"] = total;
  j["cpu_seconds"] = cpu;
  nlohmann::ordered_json insets = nlohmann::ordered_json::array();
  for (const builder::InsetSurfaceSummary& inset : s.insets) {
    const builder::VoidReport& v = inset.voids;
    insets.push_back({{"name", inset.name},
                      {"tiles", inset.tiles},
                      {"voids", v.voids},
                      {"void_samples", v.voidSamples},
                      {"filled_voids", v.filledVoids},
                      {"filled_samples", v.filledSamples},
                      {"voids_left_to_surface_below", v.largeVoids},
                      {"samples_left_to_surface_below", v.belowSamples}});
  }
  j["insets"] = insets;
  std::ofstream out(path);
  out << j.dump() << "\n";
  return static_cast<bool>(out);
}

int runBuild(const BuildCliOptions& c) {
  // Past the file-size limit (ulimit -f) a write fails with EFBIG, which the builder reports
  // (exit code 2, the file and the bytes) like a full disk, instead of the signal killing it.
  std::signal(SIGXFSZ, SIG_IGN);
  if (const char* part = std::getenv("PBDAM_TEST_FAIL_WRITE"); part != nullptr) {
    formats::failWritesForTesting(part);
  }
  // Under mpirun: join the job first, so that every rank reports errors the same way.
  std::unique_ptr<MpiJob> job;
  if (launchedByMpi()) {
    auto joined = joinMpiJob();
    if (!joined) {
      return isMpiRankOtherThanZero() ? exitCodeOf(joined.error()) : reportError(joined.error());
    }
    job = std::move(joined).value();
  }
  builder::Communicator* comm = job ? job->communicator : nullptr;
  const bool root = comm == nullptr || comm->rank() == 0;
  builder::BuildOptions o;
  o.communicator = comm;
  o.resume = c.resume;
  using Free = builder::BuildOptions::FreeCheckpoint;
  o.freeCheckpoint = c.freeCheckpoint == "always"  ? Free::Always
                     : c.freeCheckpoint == "never" ? Free::Never
                                                   : Free::Auto;
  o.fault = faultFromEnvironment();
  o.demPath = c.dem;
  o.texturePath = c.texture;
  o.planetSpec = c.planet;
  o.outDir = c.out;
  o.leafVertices = c.leafVertices;
  o.minPatchTriangles = c.minPatchTriangles;
  o.errorMargin = c.errorMargin;
  o.textureTileTexels = c.textureTile;
  o.threads = c.threads;
  o.residentBudgetBytes = c.residentMib << 20;
  o.force = c.force;
  if (c.levels != "auto") {
    try {
      std::size_t used = 0;
      const int depth = std::stoi(c.levels, &used);
      if (used != c.levels.size() || depth < 0) throw std::invalid_argument("levels");
      o.depth = static_cast<std::uint32_t>(depth);
    } catch (const std::exception&) {
      if (root)
        std::cerr << "pbdam: --levels '" << c.levels << "': expected 'auto' or an even depth\n";
      return kExitBadInput;
    }
  }
  if (auto r = parseDeepRegions(c.deepRegions, o); !r) {
    return root ? reportError(r.error()) : exitCodeOf(r.error());
  }
  auto insets = insetSpecsOf(c.insets, c.insetOffsets, c.insetTextures);
  if (!insets) return root ? reportError(insets.error()) : exitCodeOf(insets.error());
  o.insets = std::move(insets).value();
  if (c.textureFormat == "bc1") {
    o.textureFormat = TexelFormat::Bc1;
  } else if (c.textureFormat == "rgba8") {
    o.textureFormat = TexelFormat::Rgba8;
  } else {
    if (root)
      std::cerr << "pbdam: --texture-format '" << c.textureFormat << "': expected bc1 or rgba8\n";
    return kExitBadInput;
  }
  o.bc1Quality = c.textureQuality == "high" ? Bc1Quality::High : Bc1Quality::Fast;
  auto raw = rawLayoutOf(c.raw);
  if (!raw) return root ? reportError(raw.error()) : exitCodeOf(raw.error());
  o.rawLayout = *raw;
  if (root && !o.rawLayout) noteDemLabel(o.demPath);
  Progress progress(c.quiet || !root);
  o.progress = [&](std::string_view stage, double f) { progress.update(stage, f); };
  if (!c.quiet) {
    o.log = [&](std::string_view line) {
      progress.finish();
      std::fprintf(stderr, "%.*s\n", static_cast<int>(line.size()), line.data());
    };
  }
  if (comm != nullptr && comm->size() > 1 && root) {
    o.stageStarted = rememberStage;
    std::signal(SIGTERM, onTerminate);
  }
  auto summary = builder::buildDataset(o);
  progress.finish();
  if (!root) return summary ? kExitOk : exitCodeOf(summary.error());
  std::signal(SIGTERM, SIG_DFL);
  if (!summary) return reportError(summary.error());
  printBuildSummary(c.out, *summary);
  if (!c.stats.empty() && !writeBuildStats(c.stats, *summary)) {
    std::cerr << "pbdam: --stats '" << c.stats << "': cannot write the file\n";
    return kExitBadInput;
  }
  return kExitOk;
}

}  // namespace

void addBuildCommand(CLI::App& app, CommandStatus& status) {
  auto c = std::make_shared<BuildCliOptions>();
  CLI::App* cmd = app.add_subcommand("build", "Build a P-BDAM dataset from a DEM (+ imagery)");
  cmd->add_option("--dem", c->dem, "Elevation file (anything `pbdam dem info` reads)")->required();
  cmd->add_option("--texture", c->texture,
                  "Equirectangular image for the texture (default: shaded relief)");
  cmd->add_option("--planet", c->planet,
                  "mars | mars-iau2000 | earth | moon | sphere:R | ellipsoid:A,F")
      ->required();
  cmd->add_option("--out", c->out, "Dataset directory to write")->required();
  cmd->add_option("--leaf-vertices", c->leafVertices, "Vertices along a leaf patch leg (2^k+1)")
      ->capture_default_str();
  cmd->add_option("--min-patch-triangles", c->minPatchTriangles,
                  "Fewest triangles of a simplified patch (unless its block is exact with fewer)")
      ->capture_default_str();
  cmd->add_option("--error-margin", c->errorMargin,
                  "r >= 0.25: each level's error is at least (1 + r) x its children's")
      ->capture_default_str();
  cmd->add_option("--texture-tile", c->textureTile, "Texture tile side in texels (border incl.)")
      ->capture_default_str();
  cmd->add_option("--texture-format", c->textureFormat, "bc1 or rgba8")->capture_default_str();
  cmd->add_option("--texture-quality", c->textureQuality, "BC1 fit: fast or high")
      ->check(CLI::IsMember({"fast", "high"}))
      ->capture_default_str();
  cmd->add_option("--levels", c->levels, "Bintree depth (even) or 'auto' from the DEM density")
      ->capture_default_str();
  cmd->add_option("--deep-region", c->deepRegions,
                  "S,W,N,E@LEVEL: leaves of this even level (deeper than --levels) over the box, "
                  "the forest closed around it (repeatable; the lattice is that of the deepest)")
      ->type_name("BOX@LEVEL");
  addInsetOptions(*cmd, c->insets, c->insetOffsets);
  addInsetTextureOption(*cmd, c->insetTextures);
  cmd->add_option("--threads", c->threads, "Worker threads (0: all cores)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  cmd->add_option("--resident-mib", c->residentMib,
                  "File pages (the lattice, source samples, checkpoint parts) kept resident "
                  "before they are dropped, per process, in MiB (0: drop them every quarter "
                  "second, the lowest memory and the most page faults)")
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1} << 30))
      ->capture_default_str();
  cmd->add_flag("--force", c->force, "Replace an existing dataset in --out");
  cmd->add_flag("--resume", c->resume,
                "Continue an interrupted build from its checkpoint (OUT/.build-checkpoint)");
  cmd->add_option("--free-checkpoint", c->freeCheckpoint,
                  "Free the checkpoint's level files as the face files are written, so both need "
                  "not fit on the disk at once (a failed assembly then cannot resume): auto "
                  "(when the disk is short), always or never")
      ->check(CLI::IsMember({"auto", "always", "never"}))
      ->capture_default_str();
  cmd->add_flag("--quiet", c->quiet, "No progress output");
  cmd->add_option(
      "--stats", c->stats,
      "Write the build's figures (CPU seconds per stage included) as JSON to this file");
  addRawGridOptions(*cmd, c->raw);
  cmd->callback([c, &status] { status.exitCode = runBuild(*c); });
}

}  // namespace pbdam::tools
