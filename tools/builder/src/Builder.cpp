// The P-BDAM build pipeline (Builder.h; docs/builder.md; paper 004 §5).
#include "pbdam/builder/Builder.h"

#include <fcntl.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <unordered_map>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/builder/TextureBuilder.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

struct Sphere {
  glm::dvec3 center{0.0};
  double radius = 0.0;
};

/// The smallest sphere enclosing two spheres.
Sphere merge(const Sphere& a, const Sphere& b) {
  const double d = glm::length(b.center - a.center);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  const double r = 0.5 * (d + a.radius + b.radius);
  return Sphere{a.center + (b.center - a.center) * ((r - a.radius) / d), r};
}

/// Rounds a radius up to a float that still encloses (with a millimetre-scale margin).
float storedRadius(double r) {
  const double padded = r * (1.0 + 1e-6) + 1e-3;
  float f = static_cast<float>(padded);
  if (static_cast<double>(f) < padded) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

float roundUpToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

struct EdgeKeyHash {
  std::size_t operator()(const EdgeKey& k) const noexcept {
    return std::hash<std::uint64_t>()(k.first * 0x9E3779B97F4A7C15ULL ^ k.second);
  }
};

/// Everything the build keeps per node.
struct NodeData {
  NodeRecord record;
  std::vector<std::byte> blob;
  double measuredError = 0.0;
  Sphere sphere;  // of its own rendered vertices, then saturated
};

class Build {
 public:
  Build(const BuildOptions& o, const Planet& planet, const Lattice& lattice, std::uint32_t depth)
      : o_(o),
        planet_(planet),
        lattice_(lattice),
        depth_(depth),
        nodesPerTree_(Lattice::nodesPerTree(static_cast<int>(depth))),
        nodes_(12 * nodesPerTree_) {}

  std::uint64_t nodeId(const BinTriangle& t) const noexcept {
    return builder::nodeId(t, static_cast<int>(depth_));
  }
  BinTriangle triangleOf(std::uint64_t id) const noexcept {
    return triangleOfNode(lattice_, id, static_cast<int>(depth_));
  }
  std::vector<Diamond> diamondsOfLevel(int level) const {
    return builder::diamondsOfLevel(lattice_, static_cast<int>(depth_), level);
  }

  void store(std::uint64_t id, const BinTriangle& t, const WorkPatch& patch, const SampleGrid& grid,
             std::atomic<std::uint64_t>& rawBytes) {
    MeasuredPatch m = measurePatch(grid, t, patch, o_.heightStepMeters);
    optimizePatchForRendering(m.mesh);
    auto blob = encodePatch(m.mesh);
    NodeData& n = nodes_[id];
    if (!blob) {
      std::lock_guard lock(failureMutex_);
      if (!failed_) failure_ = "patch " + std::to_string(id) + ": " + blob.error().message;
      failed_ = true;
      return;
    }
    n.blob = std::move(blob).value();
    const NodeCorners corners = nodeCorners(grid, t);
    for (std::size_t c = 0; c < 3; ++c) {
      for (std::size_t a = 0; a < 3; ++a) {
        n.record.cornerPositions[c * 3 + a] = corners.positions[c][static_cast<int>(a)];
        n.record.cornerNormals[c * 3 + a] = corners.normals[c][static_cast<int>(a)];
      }
    }
    n.record.vertexCount = static_cast<std::uint32_t>(m.mesh.vertices.size());
    n.record.triangleCount = static_cast<std::uint32_t>(m.mesh.triangleCount());
    n.record.measuredErrorMeters = roundUpToFloat(m.errorMeters);
    n.record.minHeightMeters = static_cast<float>(m.minHeightMeters);
    n.record.maxHeightMeters = static_cast<float>(m.maxHeightMeters);
    n.measuredError = m.errorMeters;
    n.sphere = Sphere{m.sphereCenter, m.sphereRadiusMeters};
    rawBytes += 8ULL * n.record.vertexCount + 6ULL * n.record.triangleCount;
  }

  const BuildOptions& o_;
  Planet planet_;
  Lattice lattice_;
  std::uint32_t depth_;
  std::uint64_t nodesPerTree_;
  std::vector<NodeData> nodes_;
  std::atomic<bool> failed_{false};
  std::mutex failureMutex_;
  std::string failure_;
};

Result<void> writeAll(int fd, std::span<const std::byte> bytes, const fs::path& path,
                      std::uint32_t& crc) {
  crc = crc32(bytes, crc);
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return makeError(ErrorCode::IoError,
                       path.string() + ": write failed (" + std::strerror(errno) + ")");
    }
    done += static_cast<std::size_t>(n);
  }
  return {};
}

/// Writes `chunks` to `path` through a temporary file, fsync and rename (design.md §6).
Result<void> writeFileAtomically(const fs::path& path,
                                 const std::vector<std::span<const std::byte>>& chunks,
                                 std::uint32_t& crc) {
  std::string tmpName = ".";
  tmpName += path.filename().string();
  tmpName += ".tmp";
  const fs::path tmp = path.parent_path() / tmpName;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    return makeError(ErrorCode::IoError,
                     tmp.string() + ": cannot create (" + std::strerror(errno) + ")");
  }
  crc = 0;
  for (const auto& chunk : chunks) {
    if (auto r = writeAll(fd, chunk, tmp, crc); !r) {
      ::close(fd);
      return r;
    }
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    return makeError(ErrorCode::IoError, tmp.string() + ": fsync/close failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec)
    return makeError(ErrorCode::IoError, path.string() + ": rename failed (" + ec.message() + ")");
  return {};
}

void syncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

Error invalid(const std::string& what) { return makeError(ErrorCode::InvalidArgument, what); }

}  // namespace

Result<BuildSummary> buildDataset(const BuildOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  // ---- Options.
  const std::uint32_t leafCells = o.leafVertices - 1;
  if (o.leafVertices < 3 || !std::has_single_bit(leafCells) || leafCells > 256) {
    return invalid("--leaf-vertices " + std::to_string(o.leafVertices) +
                   ": must be 2^k + 1 between 3 and 257 (e.g. 17 or 33)");
  }
  if (o.patchVertices < 16 || o.patchVertices > kPatchMaxVertices) {
    return invalid("--patch-vertices " + std::to_string(o.patchVertices) +
                   ": must be between 16 and 65535");
  }
  if (o.textureTileTexels < 16 || o.textureTileTexels > 4096 || o.textureTileTexels % 4 != 0) {
    return invalid("--texture-tile " + std::to_string(o.textureTileTexels) +
                   ": must be a multiple of 4 between 16 and 4096");
  }
  if (o.depth && (*o.depth % 2 != 0 || *o.depth > 28)) {
    return invalid("--levels " + std::to_string(*o.depth) + ": must be an even depth up to 28");
  }
  if (!(o.heightStepMeters > 0.0) || o.threads < 0) return invalid("bad height step or threads");
  auto planet = Planet::fromSpec(o.planetSpec);
  if (!planet) return std::move(planet).error();
  std::error_code ec;
  if (fs::exists(o.outDir, ec) && !fs::is_directory(o.outDir, ec)) {
    return invalid(o.outDir.string() + ": exists and is not a directory");
  }
  if (fs::exists(o.outDir / kManifestFileName, ec) && !o.force) {
    return invalid(o.outDir.string() + ": already holds a dataset (use --force to replace it)");
  }

  // ---- Inputs.
  DemReadOptions readOptions;
  readOptions.raw = o.rawLayout;
  auto dem = readDem(o.demPath, readOptions);
  if (!dem) return std::move(dem).error();
  const std::string& body = dem->source().body;
  const std::string spec = planet->name();
  if (!body.empty() && spec.rfind(body, 0) != 0 && spec.rfind("sphere", 0) != 0 &&
      spec.rfind("ellipsoid", 0) != 0) {
    return invalid(o.demPath.string() + ": the DEM's CRS is on " + body + " but --planet is " +
                   spec);
  }
  std::optional<GeoImage> imagery;
  if (!o.texturePath.empty()) {
    auto image = readImage(o.texturePath);
    if (!image) return std::move(image).error();
    imagery = std::move(image).value();
  }

  // ---- Lattice size: at least the DEM's density across 90° of longitude.
  std::uint32_t depth = 0;
  std::uint32_t n = leafCells;
  if (o.depth) {
    depth = *o.depth;
    n = leafCells << (depth / 2);
  } else {
    const double across = 90.0 / dem->geometry().lonSpacingDegrees;
    n = std::max(leafCells, std::bit_ceil(static_cast<std::uint32_t>(std::ceil(across - 1e-9))));
    depth = 2 * static_cast<std::uint32_t>(std::countr_zero(n / leafCells));
  }
  if (n > 16384) {
    return invalid("the lattice would have " + std::to_string(n) +
                   " cells per face side; at most 16384 (choose --levels or larger leaves)");
  }
  const Lattice lattice(n);

  fs::create_directories(o.outDir, ec);
  if (ec) return makeError(ErrorCode::IoError, o.outDir.string() + ": " + ec.message());
  // A rebuild first makes the directory incomplete, so a crash never leaves a stale manifest
  // describing new face files.
  fs::remove(o.outDir / kManifestFileName, ec);

  BuildSummary summary;
  summary.latticeCells = n;
  summary.depth = depth;
  auto report = [&](std::string_view stage, double fraction) {
    if (o.progress) o.progress(stage, fraction);
  };

  tbb::task_arena arena(o.threads > 0 ? o.threads : tbb::task_arena::automatic);
  Result<BuildSummary> result = Error{};
  arena.execute([&] {
    // ---- Resample.
    SampleGrid grid = SampleGrid::build(
        *dem, *planet, lattice, SampleGrid::defaultBucketCells(lattice),
        [&](std::size_t done, std::size_t total) {
          report("resample", static_cast<double>(done) / static_cast<double>(total));
        });
    summary.sourceSamples = grid.sourceSampleCount();
    summary.latticeSamples = 6ULL * (n + 1ULL) * (n + 1ULL);
    summary.noDataPoints = grid.noDataPoints();

    Build build(o, *planet, lattice, depth);
    std::atomic<std::uint64_t> rawBytes{0};
    const auto d = static_cast<int>(depth);
    const std::uint64_t leafCount = 12ULL << depth;
    std::uint64_t patchesDone = 0;
    const std::uint64_t patchesTotal = 12 * build.nodesPerTree_;

    // ---- Leaves (regenerated on demand later instead of kept).
    {
      const std::uint64_t first = Lattice::firstIndexOfLevel(d);
      const std::uint64_t perTree = std::uint64_t{1} << depth;
      tbb::parallel_for(std::uint64_t{0}, leafCount, [&](std::uint64_t k) {
        const auto g = static_cast<int>(k / perTree);
        const BinTriangle t = lattice.triangle(g / 2, g % 2, d, first + k % perTree);
        build.store(build.nodeId(t), t, makeLeafPatch(t), grid, rawBytes);
      });
      patchesDone += leafCount;
      report("simplify", static_cast<double>(patchesDone) / static_cast<double>(patchesTotal));
    }

    // ---- Levels D−1 .. 0: one block per diamond.
    std::vector<std::vector<Diamond>> diamonds(depth + 1);
    diamonds[depth] = build.diamondsOfLevel(d);
    std::unordered_map<std::uint64_t, WorkPatch> below;  // level k+1 patches by node id
    std::atomic<std::uint64_t> retries{0};
    std::atomic<std::uint64_t> unsimplified{0};
    for (int level = d - 1; level >= 0; --level) {
      diamonds[static_cast<std::size_t>(level)] = build.diamondsOfLevel(level);
      const auto& levelDiamonds = diamonds[static_cast<std::size_t>(level)];
      std::vector<WorkPatch> made(2 * levelDiamonds.size());
      tbb::parallel_for(std::size_t{0}, levelDiamonds.size(), [&](std::size_t k) {
        const std::array<BinTriangle, 2> tri = {build.triangleOf(levelDiamonds[k][0]),
                                                build.triangleOf(levelDiamonds[k][1])};
        std::array<std::array<WorkPatch, 2>, 2> generated;
        std::array<std::array<const WorkPatch*, 2>, 2> children{};
        for (std::size_t s = 0; s < 2; ++s) {
          const auto kids = Lattice::children(tri[s]);
          for (std::size_t c = 0; c < 2; ++c) {
            if (level + 1 == d) {
              generated[s][c] = makeLeafPatch(kids[c]);
              children[s][c] = &generated[s][c];
            } else {
              children[s][c] = &below.at(build.nodeId(kids[c]));
            }
          }
        }
        BlockResult block = simplifyBlock(grid, tri, children, o.patchVertices);
        retries += block.stats.simplifyRetries;
        unsimplified += block.stats.halvesKeptUnsimplified;
        build.store(levelDiamonds[k][0], tri[0], block.first, grid, rawBytes);
        build.store(levelDiamonds[k][1], tri[1], block.second, grid, rawBytes);
        made[2 * k] = std::move(block.first);
        made[2 * k + 1] = std::move(block.second);
      });
      below.clear();
      for (std::size_t k = 0; k < levelDiamonds.size(); ++k) {
        below.emplace(levelDiamonds[k][0], std::move(made[2 * k]));
        below.emplace(levelDiamonds[k][1], std::move(made[2 * k + 1]));
      }
      patchesDone += 2 * levelDiamonds.size();
      report("simplify", static_cast<double>(patchesDone) / static_cast<double>(patchesTotal));
    }
    below.clear();
    summary.simplifyRetries = retries.load();
    summary.halvesKeptUnsimplified = unsimplified.load();
    if (build.failed_) {
      result = makeError(ErrorCode::Internal, "a patch could not be encoded: " + build.failure_);
      return;
    }

    // ---- Saturate errors and spheres bottom-up over the diamond DAG (across faces).
    std::unordered_map<EdgeKey, std::size_t, EdgeKeyHash> belowBySpine;
    std::vector<double> belowError;
    std::vector<Sphere> belowSphere;
    for (int level = d; level >= 0; --level) {
      const auto& levelDiamonds = diamonds[static_cast<std::size_t>(level)];
      std::vector<double> error(levelDiamonds.size());
      std::vector<Sphere> sphere(levelDiamonds.size());
      std::unordered_map<EdgeKey, std::size_t, EdgeKeyHash> bySpine;
      for (std::size_t k = 0; k < levelDiamonds.size(); ++k) {
        const NodeData& a = build.nodes_[levelDiamonds[k][0]];
        const NodeData& b = build.nodes_[levelDiamonds[k][1]];
        double e = std::max(a.measuredError, b.measuredError);
        Sphere s = merge(a.sphere, b.sphere);
        const BinTriangle ta = build.triangleOf(levelDiamonds[k][0]);
        const BinTriangle tb = build.triangleOf(levelDiamonds[k][1]);
        if (level < d) {
          // The four child diamonds are those whose spines are this diamond's legs.
          const std::array<EdgeKey, 4> legs = {lattice.edgeKey(ta.face, ta.apex, ta.left),
                                               lattice.edgeKey(ta.face, ta.apex, ta.right),
                                               lattice.edgeKey(tb.face, tb.apex, tb.left),
                                               lattice.edgeKey(tb.face, tb.apex, tb.right)};
          for (const EdgeKey& leg : legs) {
            const std::size_t child = belowBySpine.at(leg);
            e = std::max(e, belowError[child]);
            s = merge(s, belowSphere[child]);
          }
        }
        bySpine.emplace(lattice.edgeKey(ta.face, ta.left, ta.right), k);
        const float storedError = roundUpToFloat(e);
        const float radius = storedRadius(s.radius);
        error[k] = static_cast<double>(storedError);
        sphere[k] = Sphere{s.center, static_cast<double>(radius)};
        for (std::uint64_t id : levelDiamonds[k]) {
          NodeRecord& r = build.nodes_[id].record;
          r.errorMeters = storedError;
          r.sphereRadiusMeters = radius;
          r.sphereCenter = {s.center.x, s.center.y, s.center.z};
        }
      }
      belowBySpine = std::move(bySpine);
      belowError = std::move(error);
      belowSphere = std::move(sphere);
      if (level == d) {
        for (double e : belowError)
          summary.leafMaxErrorMeters = std::max(summary.leafMaxErrorMeters, e);
      }
      if (level == 0) {
        for (double e : belowError) summary.rootErrorMeters = std::max(summary.rootErrorMeters, e);
      }
    }

    // ---- Texture quadtree.
    const std::uint32_t border = 2;
    const std::uint32_t inner = o.textureTileTexels - 2 * border;
    const double ratio = static_cast<double>(n) / static_cast<double>(inner);
    const auto textureLevels =
        static_cast<std::uint32_t>(std::max(0.0, std::round(std::log2(std::max(ratio, 1.0))))) + 1;
    summary.textureLevels = textureLevels;
    const std::uint64_t tilesPerFace = ((std::uint64_t{1} << (2 * textureLevels)) - 1) / 3;
    std::vector<std::vector<std::byte>> tileBlobs(6 * tilesPerFace);
    std::vector<float> tileErrors(6 * tilesPerFace);
    TextureSource source;
    source.planet = *planet;
    source.heightMeters = heightFunctionFromGrid(*dem, true);
    source.ramp.hasOcean = grid.minHeightMeters() < 0.0f && body == "earth";
    if (!source.ramp.hasOcean && planet->name() == "earth") source.ramp.hasOcean = true;
    source.ramp.minMeters = static_cast<double>(grid.minHeightMeters());
    source.ramp.maxMeters =
        std::max(static_cast<double>(grid.maxHeightMeters()), source.ramp.minMeters + 1.0);
    if (imagery) {
      source.imagery = &*imagery;
      source.imageryShadingStrength = 0.35;
    }
    std::atomic<std::uint64_t> tilesDone{0};
    std::atomic<bool> textureFailed{false};
    tbb::parallel_for(std::uint64_t{0}, 6 * tilesPerFace, [&](std::uint64_t k) {
      const auto face = static_cast<int>(k / tilesPerFace);
      const std::uint64_t heap = k % tilesPerFace;
      std::uint32_t level = 0;
      while (((std::uint64_t{1} << (2 * (level + 1))) - 1) / 3 <= heap) ++level;
      const std::uint64_t within = heap - ((std::uint64_t{1} << (2 * level)) - 1) / 3;
      TextureTileRequest request;
      request.face = face;
      request.level = static_cast<int>(level);
      request.qi = static_cast<std::uint32_t>(within & ((std::uint64_t{1} << level) - 1));
      request.qj = static_cast<std::uint32_t>(within >> level);
      request.sizeTexels = o.textureTileTexels;
      request.borderTexels = border;
      auto tile = buildTextureTile(source, request);
      if (!tile) {
        textureFailed = true;
        return;
      }
      TextureTileImage image = std::move(tile->image);
      if (o.textureFormat == TexelFormat::Bc1) {
        auto bc1 = compressBc1(image, o.bc1Quality);
        if (!bc1) {
          textureFailed = true;
          return;
        }
        image = std::move(bc1).value();
      }
      auto blob = encodeTextureTile(image);
      if (!blob) {
        textureFailed = true;
        return;
      }
      tileBlobs[k] = std::move(blob).value();
      tileErrors[k] = roundUpToFloat(tile->textureErrorMeters);
      ++tilesDone;
    });
    report("texture", 1.0);
    if (textureFailed) {
      result = makeError(ErrorCode::Internal, "a texture tile could not be built");
      return;
    }
    summary.textureTiles = 6 * tilesPerFace;

    // ---- Face files, then the manifest.
    Manifest manifest;
    manifest.version = kDatasetFormatVersion;
    manifest.planetSpec = planet->name();
    manifest.equatorialRadiusMeters = planet->equatorialRadiusMeters();
    manifest.flattening = planet->flattening();
    manifest.latticeCells = n;
    manifest.leafCells = leafCells;
    manifest.depth = depth;
    manifest.patchVertices = o.patchVertices;
    manifest.heightStepMeters = o.heightStepMeters;
    manifest.textureLevels = textureLevels;
    manifest.textureTileTexels = o.textureTileTexels;
    manifest.textureBorderTexels = border;
    manifest.textureFormat = o.textureFormat == TexelFormat::Bc1 ? "bc1" : "rgba8";
    manifest.textureSource = "shaded-relief";
    if (imagery) {
      manifest.textureSource = "image:";
      manifest.textureSource += o.texturePath.filename().string();
    }
    manifest.sourceDem = o.demPath.filename().string();
    manifest.sourceFormat = dem->source().format;
    manifest.sourceSamples = summary.sourceSamples;
    manifest.minHeightMeters = static_cast<double>(grid.minHeightMeters());
    manifest.maxHeightMeters = static_cast<double>(grid.maxHeightMeters());

    for (int face = 0; face < 6; ++face) {
      FaceHeader h;
      h.face = static_cast<std::uint32_t>(face);
      h.latticeCells = n;
      h.leafCells = leafCells;
      h.depth = depth;
      h.textureLevels = textureLevels;
      h.textureTileTexels = o.textureTileTexels;
      h.textureBorderTexels = border;
      h.nodeCount = 2 * build.nodesPerTree_;
      h.nodeTableOffset = kFaceHeaderBytes;
      h.textureNodeCount = tilesPerFace;
      h.textureTableOffset = h.nodeTableOffset + h.nodeCount * kNodeRecordBytes;
      const std::uint64_t tablesEnd = h.textureTableOffset + tilesPerFace * kTextureRecordBytes;
      h.blobsOffset = (tablesEnd + 4095) / 4096 * 4096;  // page-aligned blob area
      std::uint64_t at = h.blobsOffset;
      std::vector<std::byte> nodeTable(h.nodeCount * kNodeRecordBytes);
      std::vector<std::span<const std::byte>> blobs;
      const std::uint64_t firstNode = static_cast<std::uint64_t>(face) * 2 * build.nodesPerTree_;
      for (std::uint64_t k = 0; k < h.nodeCount; ++k) {
        NodeData& node = build.nodes_[firstNode + k];
        node.record.blobOffset = at;
        node.record.blobBytes = static_cast<std::uint32_t>(node.blob.size());
        at += node.blob.size();
        blobs.emplace_back(node.blob);
        encodeNodeRecord(node.record,
                         std::span<std::byte, kNodeRecordBytes>(
                             nodeTable.data() + k * kNodeRecordBytes, kNodeRecordBytes));
        summary.patchBytesCompressed += node.blob.size();
        summary.totalTriangles += node.record.triangleCount;
        if (k % build.nodesPerTree_ >= Lattice::firstIndexOfLevel(d)) {
          summary.leafTriangles += node.record.triangleCount;
        }
      }
      std::vector<std::byte> textureTable(tilesPerFace * kTextureRecordBytes);
      for (std::uint64_t k = 0; k < tilesPerFace; ++k) {
        const auto& blob = tileBlobs[static_cast<std::size_t>(face) * tilesPerFace + k];
        TextureRecord t{at, static_cast<std::uint32_t>(blob.size()),
                        tileErrors[static_cast<std::size_t>(face) * tilesPerFace + k]};
        at += blob.size();
        blobs.emplace_back(blob);
        encodeTextureRecord(
            t, std::span<std::byte, kTextureRecordBytes>(
                   textureTable.data() + k * kTextureRecordBytes, kTextureRecordBytes));
      }
      h.fileBytes = at;
      h.nodeTableCrc = crc32(nodeTable);
      h.textureTableCrc = crc32(textureTable);
      std::array<std::byte, kFaceHeaderBytes> header{};
      encodeFaceHeader(h, header);
      std::vector<std::byte> padding(h.blobsOffset - tablesEnd);
      std::vector<std::span<const std::byte>> chunks = {header, nodeTable, textureTable, padding};
      chunks.insert(chunks.end(), blobs.begin(), blobs.end());
      const std::string name = "face" + std::to_string(face) + ".pbdam";
      std::uint32_t crc = 0;
      if (auto w = writeFileAtomically(o.outDir / name, chunks, crc); !w) {
        result = std::move(w).error();
        return;
      }
      manifest.faces[static_cast<std::size_t>(face)] = ManifestFace{name, h.fileBytes, crc};
      summary.datasetBytes += h.fileBytes;
      report("write", static_cast<double>(face + 1) / 6.0);
    }
    syncDirectory(o.outDir);
    const std::string json = manifestToJson(manifest);
    std::uint32_t crc = 0;
    if (auto w = writeFileAtomically(
            o.outDir / kManifestFileName,
            {std::as_bytes(std::span<const char>(json.data(), json.size()))}, crc);
        !w) {
      result = std::move(w).error();
      return;
    }
    syncDirectory(o.outDir);
    summary.datasetBytes += json.size();
    summary.patches = 12 * build.nodesPerTree_;
    summary.patchBytesRaw = rawBytes.load();
    result = summary;
  });
  if (result) {
    result->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return result;
}

}  // namespace pbdam::builder
