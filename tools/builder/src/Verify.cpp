// Dataset verification (Verify.h): every invariant that makes stateless top-down refinement of a
// P-BDAM produce crack-free, error-bounded cuts (paper 004 §3: nested errors and volumes, the
// edge error property), plus the integrity of every byte.
#include "pbdam/builder/Verify.h"

#include <tbb/parallel_for.h>

#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <unordered_map>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/streaming/MappedFile.h"

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

/// Collects violations from several threads.
class Violations {
 public:
  explicit Violations(std::size_t max) : max_(max) {}
  void add(std::string what) {
    std::lock_guard lock(mutex_);
    ++count_;
    if (list_.size() < max_) list_.push_back(std::move(what));
  }
  std::uint64_t count() const {
    std::lock_guard lock(mutex_);
    return count_;
  }
  std::vector<std::string> take() {
    std::lock_guard lock(mutex_);
    return std::move(list_);
  }

 private:
  mutable std::mutex mutex_;
  std::size_t max_;
  std::uint64_t count_ = 0;
  std::vector<std::string> list_;
};

std::string nodeName(const BinTriangle& t) {
  return "face " + std::to_string(t.face) + " tree " + std::to_string(t.tree) + " level " +
         std::to_string(t.level) + " node " + std::to_string(t.index);
}

/// The vertices one patch has on one of its edges: (canonical key, displacement) sorted.
using EdgeVertices = std::vector<std::pair<PointKey, std::int32_t>>;

/// A 64-bit digest of an edge's vertex list (splitmix64 over its count and entries): verify keeps
/// three per node instead of the lists (at the paper scale the lists took ~20 GB). Two lists
/// that differ collide with probability ~2^-64.
std::uint64_t edgeDigest(const EdgeVertices& list) noexcept {
  auto mix = [](std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ULL;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
    return x ^ (x >> 31);
  };
  std::uint64_t h = mix(list.size());
  for (const auto& [key, steps] : list) {
    h = mix(h ^ static_cast<std::uint64_t>(key));
    h = mix(h ^ static_cast<std::uint32_t>(steps));
  }
  return h;
}

struct EdgeKeyHash {
  std::size_t operator()(const EdgeKey& k) const noexcept {
    return static_cast<std::size_t>(static_cast<std::uint64_t>(k.first) * 0x9E3779B97F4A7C15ULL ^
                                    static_cast<std::uint64_t>(k.second));
  }
};

struct DecodedNode {
  NodeRecord record;
  std::array<std::uint64_t, 3> edges{};  // digests: apex–left, apex–right, left–right
  bool valid = false;
};

}  // namespace

Result<VerifyReport> verifyDataset(const VerifyOptions& o) {
  VerifyReport report;
  Violations violations(o.maxViolations);
  auto manifest = readManifest(o.datasetDir);
  if (!manifest) {
    if (manifest.error().code == ErrorCode::NotFound) return std::move(manifest).error();
    report.violations.push_back(manifest.error().message);
    report.violationCount = 1;
    return report;
  }
  auto planet = Planet::fromSpec(manifest->planetSpec);
  if (!planet) {
    report.violations.push_back("manifest planet: " + planet.error().message);
    report.violationCount = 1;
    return report;
  }
  const Lattice lattice(manifest->latticeCells);
  const int depth = static_cast<int>(manifest->depth);
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  auto progress = [&](std::string_view stage, double f) {
    if (o.progress) o.progress(stage, f);
  };

  // ---- Files: sizes, checksums, headers, tables.
  std::array<MappedFile, 6> files;
  std::array<std::optional<FaceView>, 6> views;
  for (std::size_t f = 0; f < 6; ++f) {
    const fs::path path = o.datasetDir / manifest->faces[f].file;
    auto mapped = MappedFile::open(path);
    if (!mapped) {
      violations.add(mapped.error().message);
      continue;
    }
    files[f] = std::move(mapped).value();
    if (files[f].size() != manifest->faces[f].bytes) {
      violations.add(path.string() + ": " + std::to_string(files[f].size()) +
                     " bytes, the manifest says " + std::to_string(manifest->faces[f].bytes));
    }
    // In 64 MB pieces, dropping the mapping's pages from this process after each: the file's
    // pages stay in the page cache but not in verify's RSS.
    std::uint32_t crc = 0;
    const std::span<const std::byte> all = files[f].bytes();
    for (std::size_t at = 0; at < all.size(); at += std::size_t{64} << 20) {
      crc = crc32(all.subspan(at, std::min(all.size() - at, std::size_t{64} << 20)), crc);
      (void)files[f].releaseResident();
    }
    if (crc != manifest->faces[f].crc32) {
      violations.add(path.string() + ": file checksum differs from the manifest");
    }
    auto view = FaceView::open(files[f].bytes(), path.string());
    if (!view) {
      violations.add(view.error().message);
      continue;
    }
    const FaceHeader& h = view->header();
    if (h.face != f || h.latticeCells != manifest->latticeCells ||
        h.leafCells != manifest->leafCells || h.depth != manifest->depth ||
        h.textureLevels != manifest->textureLevels) {
      violations.add(path.string() + ": header disagrees with the manifest");
      continue;
    }
    views[f] = std::move(view).value();
  }
  if (violations.count() > 0) {
    report.violationCount = violations.count();
    report.violations = violations.take();
    return report;
  }

  // ---- Optional source DEM, bucketed like the builder does.
  std::optional<SampleGrid> grid;
  if (!o.demPath.empty()) {
    DemReadOptions readOptions;
    readOptions.raw = o.rawLayout;
    // A large DEM is mapped from an unnamed file in TMPDIR rather than held in memory, and its
    // pages are dropped from this process every 250 ms while it is resampled and bucketed.
    readOptions.scratchDirectory = fs::temp_directory_path();
    auto dem = readDem(o.demPath, readOptions);
    if (!dem) return std::move(dem).error();
    const ResidentTrimmer demTrimmer(std::chrono::milliseconds(250),
                                     [&dem] { dem->releaseResident(); });
    progress("read dem", 1.0);
    // Out of core, as the builder does it: the lattice heights and the bucketed samples go to
    // files in a scratch directory (TMPDIR) and are mapped read-only. In memory they are 12 B
    // per source sample plus 4 B per lattice point, and the paper-scale check (537 M samples,
    // 1.61 G lattice points) was killed for memory at 23 GB. The files are unlinked as soon as
    // they are mapped, so nothing is left behind, whatever happens later.
    std::string pattern = (fs::temp_directory_path() / "pbdam-verify-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      return makeError(ErrorCode::IoError, "verify --dem: cannot create a scratch directory in " +
                                               fs::temp_directory_path().string() + " (TMPDIR)");
    }
    const fs::path scratch = pattern;
    struct RemoveScratch {
      fs::path dir;
      ~RemoveScratch() {
        std::error_code ec;
        fs::remove_all(dir, ec);
      }
    } removeScratch{scratch};
    const std::uint32_t bucketCells = SampleGrid::defaultBucketCells(lattice);
    const std::size_t latticeRows = 6 * (std::size_t{lattice.sideCells()} + 1);
    auto stats = SampleGrid::writeHeightRows(
        *dem, *planet, lattice, scratch / "heights.f32", 0, latticeRows,
        [&](std::size_t doneRows, std::size_t total) {
          progress("resample", static_cast<double>(doneRows) /
                                   static_cast<double>(std::max<std::size_t>(total, 1)));
        });
    if (!stats) return std::move(stats).error();
    if (auto r = SampleGrid::writeSourceBuckets(*dem, *planet, lattice, bucketCells,
                                                scratch / "samples.bin", 0,
                                                static_cast<std::size_t>(dem->height()));
        !r) {
      return std::move(r).error();
    }
    auto opened = SampleGrid::open(lattice, *planet, scratch / "heights.f32",
                                   {scratch / "samples.bin"}, bucketCells, *stats);
    if (!opened) return std::move(opened).error();
    grid.emplace(std::move(opened).value());
  }

  // ---- Every node: decode, coverage, orientation, sphere, edges, error against the DEM.
  const std::uint64_t totalNodes = 12 * perTree;
  std::vector<DecodedNode> nodes(totalNodes);
  std::atomic<std::uint64_t> demSamples{0};
  std::mutex ratioMutex;
  double worstRatio = 0.0;
  std::atomic<std::uint64_t> done{0};
  // RSS bound: the face files' and the scratch grid's pages are dropped from this process every
  // 250 ms while the nodes are checked (they stay in the page cache), as the builder does.
  std::optional<ResidentTrimmer> trimmer;
  trimmer.emplace(std::chrono::milliseconds(250), [&files, &grid] {
    for (const MappedFile& f : files) (void)f.releaseResident();
    if (grid) grid->releaseResident();
  });
  tbb::parallel_for(std::uint64_t{0}, totalNodes, [&](std::uint64_t id) {
    const BinTriangle t = triangleOfNode(lattice, id, depth);
    const FaceView& view = *views[static_cast<std::size_t>(t.face)];
    const std::uint64_t tableIndex = static_cast<std::uint64_t>(t.tree) * perTree + t.index;
    DecodedNode& node = nodes[id];
    node.record = view.nodeAt(tableIndex);
    const std::string where = view.context() + " " + nodeName(t);
    PatchMesh mesh;
    const std::string context =
        view.context() + " offset " + std::to_string(node.record.blobOffset);
    if (auto r = decodePatch(view.patchBlob(node.record), mesh, context); !r) {
      violations.add(r.error().message + " (" + nodeName(t) + ")");
      return;
    }
    ++done;
    if (mesh.vertices.size() != node.record.vertexCount ||
        mesh.triangleCount() != node.record.triangleCount) {
      violations.add(where + ": vertex/triangle counts differ from its node record");
    }
    // Vertices as lattice points: apex + (b1·(left−apex) + b2·(right−apex)) / 2^15, exactly.
    const LatticeXY e1 = t.left - t.apex;
    const LatticeXY e2 = t.right - t.apex;
    std::vector<LatticeXY> points(mesh.vertices.size());
    bool exact = true;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const std::int64_t b1 = mesh.vertices[v].b1;
      const std::int64_t b2 = mesh.vertices[v].b2;
      const std::int64_t x = b1 * e1.x + b2 * e2.x;
      const std::int64_t y = b1 * e1.y + b2 * e2.y;
      if (x % kPatchBarycentricOne != 0 || y % kPatchBarycentricOne != 0) exact = false;
      points[v] = t.apex + LatticeXY{static_cast<std::int32_t>(x / kPatchBarycentricOne),
                                     static_cast<std::int32_t>(y / kPatchBarycentricOne)};
    }
    if (!exact) {
      violations.add(where + ": a vertex is not on the lattice");
      return;
    }
    // Coverage without flips: positive triangles whose areas add up to the node's.
    std::int64_t area = 0;
    for (std::size_t k = 0; k < mesh.indices.size(); k += 3) {
      const std::int64_t a = doubleArea(points[mesh.indices[k]], points[mesh.indices[k + 1]],
                                        points[mesh.indices[k + 2]]);
      if (a <= 0) {
        violations.add(where + ": triangle " + std::to_string(k / 3) + " is flipped or degenerate");
        return;
      }
      area += a;
    }
    if (area != std::abs(doubleArea(t.apex, t.left, t.right))) {
      violations.add(where + ": triangles cover " + std::to_string(area) + "/2 cells, the node " +
                     std::to_string(std::abs(doubleArea(t.apex, t.left, t.right))) +
                     "/2 (a hole or an overlap)");
    }
    // Rendered positions inside the node's sphere.
    const auto& P = node.record.cornerPositions;
    const auto& N = node.record.cornerNormals;
    const glm::dvec3 p0{P[0], P[1], P[2]}, p1{P[3], P[4], P[5]}, p2{P[6], P[7], P[8]};
    const glm::dvec3 n0{N[0], N[1], N[2]}, n1{N[3], N[4], N[5]}, n2{N[6], N[7], N[8]};
    const glm::dvec3 c{node.record.sphereCenter[0], node.record.sphereCenter[1],
                       node.record.sphereCenter[2]};
    std::vector<double> heights(mesh.vertices.size());
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const double b1 = mesh.vertices[v].b1 / double{kPatchBarycentricOne};
      const double b2 = mesh.vertices[v].b2 / double{kPatchBarycentricOne};
      const glm::dvec3 nb = n0 + b1 * (n1 - n0) + b2 * (n2 - n0);
      const glm::dvec3 p = p0 + b1 * (p1 - p0) + b2 * (p2 - p0) +
                           (mesh.vertices[v].heightSteps * manifest->heightStepMeters) * nb;
      if (glm::length(p - c) > static_cast<double>(node.record.sphereRadiusMeters) + 1e-3) {
        violations.add(where + ": vertex " + std::to_string(v) + " lies outside its sphere");
        break;
      }
      heights[v] = planet->ecefToGeodetic(p).heightMeters;
    }
    // Vertices on the three edges.
    const std::array<std::array<LatticeXY, 2>, 3> edgeEnds = {
        {{t.apex, t.left}, {t.apex, t.right}, {t.left, t.right}}};
    EdgeVertices edge;
    for (std::size_t e = 0; e < 3; ++e) {
      edge.clear();
      for (std::size_t v = 0; v < points.size(); ++v) {
        const LatticeXY a = edgeEnds[e][0];
        const LatticeXY b = edgeEnds[e][1];
        if (doubleArea(a, b, points[v]) != 0) continue;
        edge.emplace_back(lattice.key(t.face, points[v]), mesh.vertices[v].heightSteps);
      }
      std::sort(edge.begin(), edge.end());
      node.edges[e] = edgeDigest(edge);
    }
    node.valid = true;
    // The stored error bounds the deviation from every source sample the patch covers.
    if (grid) {
      double worst = 0.0;
      std::uint64_t checked = 0;
      for (std::size_t k = 0; k < mesh.indices.size(); k += 3) {
        const std::array<std::uint16_t, 3> tri = {mesh.indices[k], mesh.indices[k + 1],
                                                  mesh.indices[k + 2]};
        grid->forEachSourceSampleIn(
            t.face, points[tri[0]], points[tri[1]], points[tri[2]],
            [&](double l0, double l1, double l2, const SourceSample& s) {
              const double hp = l0 * heights[tri[0]] + l1 * heights[tri[1]] + l2 * heights[tri[2]];
              worst = std::max(worst, std::abs(hp - static_cast<double>(s.heightMeters)));
              ++checked;
            });
      }
      demSamples += checked;
      const double stored = static_cast<double>(node.record.errorMeters);
      if (worst > stored * (1.0 + 1e-6) + 1e-3) {
        violations.add(where + ": deviates " + std::to_string(worst) +
                       " m from the source DEM, more than its stored error " +
                       std::to_string(stored) + " m");
      }
      std::lock_guard lock(ratioMutex);
      if (stored > 0.0) worstRatio = std::max(worstRatio, worst / stored);
    }
    if (done % 4096 == 0)
      progress("patches", static_cast<double>(done) / static_cast<double>(totalNodes));
  });
  trimmer.reset();
  report.patchesDecoded = done.load();
  report.nodesChecked = totalNodes;
  report.demSamplesChecked = demSamples.load();
  report.worstErrorRatio = worstRatio;

  // ---- Shared edges: every patch bordering an edge has the same vertices there (and the same
  // displacements), so every conforming cut is crack-free.
  {
    std::unordered_map<EdgeKey, std::pair<std::uint64_t, std::uint64_t>, EdgeKeyHash> firstSeen;
    firstSeen.reserve(static_cast<std::size_t>(totalNodes));
    for (std::uint64_t id = 0; id < totalNodes; ++id) {
      const DecodedNode& node = nodes[id];
      if (!node.valid) continue;
      const BinTriangle t = triangleOfNode(lattice, id, depth);
      const std::array<EdgeKey, 3> keys = {lattice.edgeKey(t.face, t.apex, t.left),
                                           lattice.edgeKey(t.face, t.apex, t.right),
                                           lattice.edgeKey(t.face, t.left, t.right)};
      for (std::size_t e = 0; e < 3; ++e) {
        const auto [it, inserted] = firstSeen.try_emplace(keys[e], id, node.edges[e]);
        if (inserted) continue;
        ++report.edgesCompared;
        if (it->second.second != node.edges[e]) {
          violations.add(nodeName(t) + " and " +
                         nodeName(triangleOfNode(lattice, it->second.first, depth)) +
                         " disagree on the vertices of a shared edge");
        }
      }
    }
  }

  // ---- The diamond DAG: partners share error and sphere; parents bound children.
  for (int level = depth; level >= 0; --level) {
    const auto diamonds = diamondsOfLevel(lattice, depth, level);
    std::map<EdgeKey, Diamond> childBySpine;
    if (level < depth) {
      for (const Diamond& dm : diamondsOfLevel(lattice, depth, level + 1)) {
        const BinTriangle t = triangleOfNode(lattice, dm[0], depth);
        childBySpine.emplace(lattice.edgeKey(t.face, t.left, t.right), dm);
      }
    }
    for (const Diamond& dm : diamonds) {
      const NodeRecord& a = nodes[dm[0]].record;
      const NodeRecord& b = nodes[dm[1]].record;
      const BinTriangle ta = triangleOfNode(lattice, dm[0], depth);
      if (a.errorMeters != b.errorMeters || a.sphereCenter != b.sphereCenter ||
          a.sphereRadiusMeters != b.sphereRadiusMeters) {
        violations.add(nodeName(ta) + ": diamond partners differ in error or sphere");
      }
      if (a.errorMeters < a.measuredErrorMeters || b.errorMeters < b.measuredErrorMeters) {
        violations.add(nodeName(ta) + ": saturated error below its own measured error");
      }
      if (level == depth) continue;
      const BinTriangle tb = triangleOfNode(lattice, dm[1], depth);
      const std::array<EdgeKey, 4> legs = {
          lattice.edgeKey(ta.face, ta.apex, ta.left), lattice.edgeKey(ta.face, ta.apex, ta.right),
          lattice.edgeKey(tb.face, tb.apex, tb.left), lattice.edgeKey(tb.face, tb.apex, tb.right)};
      const glm::dvec3 pc{a.sphereCenter[0], a.sphereCenter[1], a.sphereCenter[2]};
      for (const EdgeKey& leg : legs) {
        const auto it = childBySpine.find(leg);
        if (it == childBySpine.end()) {
          violations.add(nodeName(ta) + ": a child diamond is missing");
          continue;
        }
        const NodeRecord& child = nodes[it->second[0]].record;
        if (child.errorMeters > a.errorMeters) {
          violations.add(nodeName(ta) + ": error " + std::to_string(a.errorMeters) +
                         " m is below a child diamond's " + std::to_string(child.errorMeters) +
                         " m (nesting)");
        }
        const glm::dvec3 cc{child.sphereCenter[0], child.sphereCenter[1], child.sphereCenter[2]};
        if (glm::length(cc - pc) + static_cast<double>(child.sphereRadiusMeters) >
            static_cast<double>(a.sphereRadiusMeters) * (1.0 + 1e-7) + 1e-3) {
          violations.add(nodeName(ta) + ": sphere does not contain a child diamond's sphere");
        }
      }
    }
  }

  // ---- Texture tiles: decodable, errors nested.
  for (std::size_t f = 0; f < 6; ++f) {
    const FaceView& view = *views[f];
    const std::uint32_t levels = view.header().textureLevels;
    for (std::uint32_t level = 0; level < levels; ++level) {
      for (std::uint32_t qj = 0; qj < (1U << level); ++qj) {
        for (std::uint32_t qi = 0; qi < (1U << level); ++qi) {
          const TextureRecord r = view.textureNode(textureHeapIndex(level, qi, qj));
          auto tile = decodeTextureTile(view.textureBlob(r),
                                        view.context() + " offset " + std::to_string(r.blobOffset));
          if (!tile) {
            violations.add(tile.error().message);
            continue;
          }
          ++report.tilesDecoded;
          if (tile->sizeTexels != view.header().textureTileTexels) {
            violations.add(view.context() + ": texture tile of the wrong size");
          }
          if (level > 0) {
            const TextureRecord parent =
                view.textureNode(textureHeapIndex(level - 1, qi / 2, qj / 2));
            if (parent.errorMeters < r.errorMeters) {
              violations.add(view.context() + ": texture error not nested at level " +
                             std::to_string(level));
            }
          }
        }
      }
    }
  }
  report.violationCount = violations.count();
  report.violations = violations.take();
  return report;
}

}  // namespace pbdam::builder
