// Dataset verification (Verify.h): every invariant that makes stateless top-down refinement of a
// P-BDAM produce crack-free, error-bounded cuts ([P-BDAM 2003] §3: nested errors and volumes, the
// edge error property), plus the integrity of every byte.
#include "pbdam/builder/Verify.h"

#include <tbb/parallel_for.h>

#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <bit>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <unordered_map>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/MorphTargets.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/runtime/TerrainPoint.h"
#include "pbdam/streaming/MappedFile.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

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

/// The vertices one patch has on one of its edges: (canonical key, height steps) sorted.
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

/// One run of verifyDataset: the dataset's files and what the checks have found so far.
class DatasetVerifier final {
 public:
  DatasetVerifier(const VerifyOptions& o, const Manifest& manifest, const Planet& planet)
      : o_(o),
        manifest_(manifest),
        planet_(planet),
        lattice_(manifest.latticeCells),
        depth_(static_cast<int>(manifest.depth)),
        perTree_(Lattice::nodesPerTree(depth_)),
        violations_(o.maxViolations) {}

  Result<VerifyReport> run();

 private:
  void progress(std::string_view stage, double f) const {
    if (o_.progress) o_.progress(stage, f);
  }
  /// Sizes, checksums, headers, tables of the six face files.
  void openFaces();
  /// The source DEM, resampled and bucketed like the builder does.
  Result<void> openDemGrid();
  /// The nodes the face tables hold, by dataset-wide id (ascending), with their table rows.
  void listNodes();
  void checkNodes();
  void checkNode(std::size_t k);
  /// The node's morph targets decode and are what its ancestors' patches give.
  void checkMorphTargets(const BinTriangle& t, const FaceView& view, const PatchMesh& mesh,
                         std::span<const std::byte> blob, const std::string& where);
  /// The node's vertices as lattice points, or nothing (a violation) when one is not on it.
  std::optional<std::vector<LatticeXY>> latticePoints(const BinTriangle& t, const PatchMesh& mesh,
                                                      const std::string& where);
  /// Coverage without flips: positive triangles whose areas add up to the node's.
  bool checkCoverage(const BinTriangle& t, const PatchMesh& mesh,
                     const std::vector<LatticeXY>& points, const std::string& where);
  /// Rendered positions (the vertices' terrain points, as the runtime draws them) inside the
  /// node's sphere; the rendered vertices' heights.
  std::vector<double> checkSphere(const BinTriangle& t, const NodeRecord& record,
                                  const PatchMesh& mesh, const std::vector<LatticeXY>& points,
                                  const std::string& where);
  void digestEdges(const BinTriangle& t, const PatchMesh& mesh,
                   const std::vector<LatticeXY>& points, DecodedNode& node) const;
  /// The stored error bounds the deviation from every source sample the patch covers.
  void checkAgainstDem(const BinTriangle& t, const NodeRecord& record, const PatchMesh& mesh,
                       const std::vector<LatticeXY>& points, const std::vector<double>& heights,
                       const std::string& where);
  void checkSharedEdges();
  void checkDiamondDag();
  void checkDiamondLevel(int level);
  void checkTextures();

  const VerifyOptions& o_;
  const Manifest& manifest_;
  const Planet& planet_;
  const Lattice lattice_;
  const int depth_;
  const std::uint64_t perTree_;
  VerifyReport report_;
  Violations violations_;
  std::array<MappedFile, 6> files_;
  std::array<std::optional<FaceView>, 6> views_;
  std::optional<SampleGrid> grid_;
  std::vector<std::uint64_t> ids_;   ///< nodeId of every node that exists, ascending
  std::vector<std::uint64_t> rows_;  ///< its row in its face's node table
  std::vector<DecodedNode> nodes_;   ///< same order
  std::vector<std::vector<std::size_t>> levelNodes_;  ///< per level, indices into ids_
  std::atomic<std::uint64_t> demSamples_{0};
  std::mutex ratioMutex_;
  double worstRatio_ = 0.0;
  std::atomic<std::uint64_t> done_{0};
  std::atomic<std::uint64_t> morphChecked_{0};
};

void DatasetVerifier::openFaces() {
  for (std::size_t f = 0; f < 6; ++f) {
    const fs::path path = o_.datasetDir / manifest_.faces[f].file;
    auto mapped = MappedFile::open(path);
    if (!mapped) {
      violations_.add(mapped.error().message);
      continue;
    }
    files_[f] = std::move(mapped).value();
    if (files_[f].size() != manifest_.faces[f].bytes) {
      violations_.add(path.string() + ": " + std::to_string(files_[f].size()) +
                      " bytes, the manifest says " + std::to_string(manifest_.faces[f].bytes));
    }
    // In 64 MB pieces, dropping the mapping's pages from this process after each: the file's
    // pages stay in the page cache but not in verify's RSS.
    // Read through guarded copies: a file truncated while it is checked is a violation, not
    // a SIGBUS.
    std::uint32_t crc = 0;
    const std::span<const std::byte> all = files_[f].bytes();
    for (std::size_t at = 0; at < all.size(); at += std::size_t{64} << 20) {
      const std::size_t n = std::min(all.size() - at, std::size_t{64} << 20);
      auto piece = crc32Mapped(all, at, n, path.string(), crc);
      (void)files_[f].releaseResident();
      if (!piece) {
        violations_.add(piece.error().message);
        break;
      }
      crc = *piece;
    }
    if (crc != manifest_.faces[f].crc32) {
      violations_.add(path.string() + ": file checksum differs from the manifest");
    }
    auto view = FaceView::open(files_[f].bytes(), path.string());
    if (!view) {
      violations_.add(view.error().message);
      continue;
    }
    const FaceHeader& h = view->header();
    if (h.face != f || h.latticeCells != manifest_.latticeCells ||
        h.leafCells != manifest_.leafCells || h.depth != manifest_.depth ||
        h.textureLevels != manifest_.textureLevels) {
      violations_.add(path.string() + ": header disagrees with the manifest");
      continue;
    }
    views_[f] = std::move(view).value();
  }
}

Result<void> DatasetVerifier::openDemGrid() {
  DemReadOptions readOptions;
  readOptions.raw = o_.rawLayout;
  // A large DEM is mapped from an unnamed file in TMPDIR rather than held in memory, and its
  // pages are dropped from this process every 250 ms while it is resampled and bucketed.
  readOptions.scratchDirectory = fs::temp_directory_path();
  auto dem = readDem(o_.demPath, readOptions);
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
  // Buckets sized by the samples (which samples a triangle tests does not depend on it).
  const std::uint32_t bucketCells = SampleGrid::bucketCellsFor(
      lattice_, static_cast<std::uint64_t>(dem->width() * dem->height()));
  // Patches are checked against the source samples only, never against lattice heights, so
  // the lattice is reduced to each face's corners (one tile per face at the face's spacing):
  // a deep adaptive forest's lattice would otherwise be resampled densely for nothing.
  const std::uint32_t n = lattice_.sideCells();
  const LatticeTiles corners(
      n, n, std::vector<std::uint8_t>(6, static_cast<std::uint8_t>(std::countr_zero(n))));
  auto stats = SampleGrid::writeHeightRows(
      *dem, planet_, lattice_, corners, scratch / "heights.f32", 0, corners.rowCount(),
      [&](std::size_t doneRows, std::size_t total) {
        progress("resample", static_cast<double>(doneRows) /
                                 static_cast<double>(std::max<std::size_t>(total, 1)));
      });
  if (!stats) return std::move(stats).error();
  if (o_.insets.empty()) {
    if (auto r = SampleGrid::writeSourceBuckets(*dem, planet_, lattice_, bucketCells,
                                                scratch / "samples.bin", 0,
                                                static_cast<std::size_t>(dem->height()));
        !r) {
      return std::move(r).error();
    }
  } else {
    // The composite's samples, as the builder measured its errors against them.
    DemReadOptions insetOptions = readOptions;
    insetOptions.raw.reset();  // the raw-grid options describe --dem only
    auto read =
        CompositeSurface::read(*dem, o_.insets, insetOptions, planet_.name(),
                               VoidFillOptions{.scratchDirectory = insetOptions.scratchDirectory});
    if (!read) return std::move(read).error();
    const CompositeSurface& composite = *read;
    const SampleEnumerator samples =
        [&composite](const std::function<void(double, double, double)>& fn) {
          composite.forEachSample(
              [&fn](int, double lat, double lon, double height) { fn(lat, lon, height); });
        };
    if (auto r = SampleGrid::writeSourceBuckets(samples, 0, ~std::uint64_t{0}, planet_, lattice_,
                                                bucketCells, scratch / "samples.bin");
        !r) {
      return std::move(r).error();
    }
  }
  auto opened = SampleGrid::open(lattice_, corners, planet_, scratch / "heights.f32",
                                 {scratch / "samples.bin"}, bucketCells, *stats);
  if (!opened) return std::move(opened).error();
  grid_.emplace(std::move(opened).value());
  return {};
}

std::optional<std::vector<LatticeXY>> DatasetVerifier::latticePoints(const BinTriangle& t,
                                                                     const PatchMesh& mesh,
                                                                     const std::string& where) {
  auto points = patchLatticePoints(t, mesh);
  if (!points) violations_.add(where + ": a vertex is not on the lattice");
  return points;
}

bool DatasetVerifier::checkCoverage(const BinTriangle& t, const PatchMesh& mesh,
                                    const std::vector<LatticeXY>& points,
                                    const std::string& where) {
  std::int64_t area = 0;
  for (std::size_t k = 0; k < mesh.indices.size(); k += 3) {
    const std::int64_t a = doubleArea(points[mesh.indices[k]], points[mesh.indices[k + 1]],
                                      points[mesh.indices[k + 2]]);
    if (a <= 0) {
      violations_.add(where + ": triangle " + std::to_string(k / 3) + " is flipped or degenerate");
      return false;
    }
    area += a;
  }
  if (area != std::abs(doubleArea(t.apex, t.left, t.right))) {
    violations_.add(where + ": triangles cover " + std::to_string(area) + "/2 cells, the node " +
                    std::to_string(std::abs(doubleArea(t.apex, t.left, t.right))) +
                    "/2 (a hole or an overlap)");
  }
  return true;
}

std::vector<double> DatasetVerifier::checkSphere(const BinTriangle& t, const NodeRecord& record,
                                                 const PatchMesh& mesh,
                                                 const std::vector<LatticeXY>& points,
                                                 const std::string& where) {
  const glm::dvec3 c{record.sphereCenter[0], record.sphereCenter[1], record.sphereCenter[2]};
  std::vector<double> heights(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const double h = mesh.vertices[v].heightSteps * manifest_.heightStepMeters;
    const glm::dvec3 p = latticeTerrainPoint(planet_, lattice_.sideCells(), t.face, points[v], h);
    if (glm::length(p - c) > static_cast<double>(record.sphereRadiusMeters) + 1e-3) {
      violations_.add(where + ": vertex " + std::to_string(v) + " lies outside its sphere");
      break;
    }
    heights[v] = planet_.ecefToGeodetic(p).heightMeters;
  }
  return heights;
}

void DatasetVerifier::digestEdges(const BinTriangle& t, const PatchMesh& mesh,
                                  const std::vector<LatticeXY>& points, DecodedNode& node) const {
  const std::array<std::array<LatticeXY, 2>, 3> edgeEnds = {
      {{t.apex, t.left}, {t.apex, t.right}, {t.left, t.right}}};
  EdgeVertices edge;
  for (std::size_t e = 0; e < 3; ++e) {
    edge.clear();
    for (std::size_t v = 0; v < points.size(); ++v) {
      const LatticeXY a = edgeEnds[e][0];
      const LatticeXY b = edgeEnds[e][1];
      if (doubleArea(a, b, points[v]) != 0) continue;
      edge.emplace_back(lattice_.key(t.face, points[v]), mesh.vertices[v].heightSteps);
    }
    std::sort(edge.begin(), edge.end());
    node.edges[e] = edgeDigest(edge);
  }
}

void DatasetVerifier::checkAgainstDem(const BinTriangle& t, const NodeRecord& record,
                                      const PatchMesh& mesh, const std::vector<LatticeXY>& points,
                                      const std::vector<double>& heights,
                                      const std::string& where) {
  double worst = 0.0;
  std::uint64_t checked = 0;
  for (std::size_t k = 0; k < mesh.indices.size(); k += 3) {
    const std::array<std::uint16_t, 3> tri = {mesh.indices[k], mesh.indices[k + 1],
                                              mesh.indices[k + 2]};
    grid_->forEachSourceSampleIn(
        t.face, points[tri[0]], points[tri[1]], points[tri[2]],
        [&](double l0, double l1, double l2, const SourceSample& s) {
          const double hp = l0 * heights[tri[0]] + l1 * heights[tri[1]] + l2 * heights[tri[2]];
          worst = std::max(worst, std::abs(hp - static_cast<double>(s.heightMeters)));
          ++checked;
        });
  }
  demSamples_ += checked;
  const double stored = static_cast<double>(record.errorMeters);
  if (worst > stored * (1.0 + 1e-6) + 1e-3) {
    violations_.add(where + ": deviates " + std::to_string(worst) +
                    " m from the source DEM, more than its stored error " + std::to_string(stored) +
                    " m");
  }
  std::lock_guard lock(ratioMutex_);
  if (stored > 0.0) worstRatio_ = std::max(worstRatio_, worst / stored);
}

void DatasetVerifier::checkMorphTargets(const BinTriangle& t, const FaceView& view,
                                        const PatchMesh& mesh, std::span<const std::byte> blob,
                                        const std::string& where) {
  // The stored targets must be what the node's parent and grandparent patches give
  // (MorphTargets.h): decode both again and recompute.
  std::vector<std::int32_t> stored;
  if (auto r = decodeMorphTargets(blob, mesh, stored, where); !r) {
    violations_.add(r.error().message);
    return;
  }
  const std::uint64_t id = nodeId(t, depth_);
  const NodeAncestors up = nodeAncestors(id, perTree_);
  std::array<PatchMesh, 2> ancestors;
  std::vector<std::byte> buffer;
  const auto decodeAncestor = [&](std::uint64_t ancestor, PatchMesh& out) {
    const auto row = view.findNode(static_cast<std::uint32_t>(t.tree), ancestor % perTree_);
    if (!row) return false;
    auto bytes = view.readPatchBlob(view.nodeAt(*row), buffer);
    return bytes && decodePatch(*bytes, out, where);
  };
  if (up.parent && !decodeAncestor(*up.parent, ancestors[0])) return;  // reported at its node
  if (up.grandparent && !decodeAncestor(*up.grandparent, ancestors[1])) return;
  std::uint64_t missed = 0;
  const MorphGeometry geometry{&planet_, &lattice_, manifest_.heightStepMeters};
  const auto expected =
      nodeMorphTargets(geometry, id, depth_, mesh, up.parent ? &ancestors[0] : nullptr,
                       up.grandparent ? &ancestors[1] : nullptr, missed);
  if (!expected) return;  // a vertex off the lattice: reported by latticePoints
  if (!up.parent ? !blob.empty() : (missed != 0 || stored != *expected)) {
    violations_.add(where + ": morph targets differ from its parent's and grandparent's patches");
  }
  ++morphChecked_;
}

void DatasetVerifier::checkNode(std::size_t k) {
  const BinTriangle t = triangleOfNode(lattice_, ids_[k], depth_);
  const FaceView& view = *views_[static_cast<std::size_t>(t.face)];
  DecodedNode& node = nodes_[k];
  node.record = view.nodeAt(rows_[k]);
  const std::string where = view.context() + " " + nodeName(t);
  PatchMesh mesh;
  const std::string context = view.context() + " offset " + std::to_string(node.record.blobOffset);
  thread_local std::vector<std::byte> blob;
  auto bytes = view.readPatchBlobs(node.record, blob);
  if (!bytes) {
    violations_.add(bytes.error().message + " (" + nodeName(t) + ")");
    return;
  }
  if (auto r = decodePatch(bytes->patch, mesh, context); !r) {
    violations_.add(r.error().message + " (" + nodeName(t) + ")");
    return;
  }
  ++done_;
  checkMorphTargets(t, view, mesh, bytes->morph, where);
  if (mesh.vertices.size() != node.record.vertexCount ||
      mesh.triangleCount() != node.record.triangleCount) {
    violations_.add(where + ": vertex/triangle counts differ from its node record");
  }
  const auto points = latticePoints(t, mesh, where);
  if (!points || !checkCoverage(t, mesh, *points, where)) return;
  const std::vector<double> heights = checkSphere(t, node.record, mesh, *points, where);
  digestEdges(t, mesh, *points, node);
  node.valid = true;
  if (grid_) checkAgainstDem(t, node.record, mesh, *points, heights, where);
  if (done_ % 4096 == 0) {
    progress("patches", static_cast<double>(done_) / static_cast<double>(nodes_.size()));
  }
}

void DatasetVerifier::listNodes() {
  levelNodes_.assign(static_cast<std::size_t>(depth_) + 1, {});
  for (std::size_t f = 0; f < 6; ++f) {
    const FaceView& view = *views_[f];
    for (std::uint64_t row = 0; row < view.header().nodeCount; ++row) {
      const std::uint64_t heap = view.nodeAt(row).heapIndex;
      const std::uint64_t tree = row >= view.treeFirstNode(1) ? 1 : 0;
      ids_.push_back((f * 2 + tree) * perTree_ + heap);
      rows_.push_back(row);
      levelNodes_[static_cast<std::size_t>(bintreeLevel(heap))].push_back(ids_.size() - 1);
    }
  }
}

void DatasetVerifier::checkNodes() {
  const std::size_t totalNodes = ids_.size();
  nodes_.assign(totalNodes, DecodedNode{});
  // RSS bound: the face files' and the scratch grid's pages are dropped from this process every
  // 250 ms while the nodes are checked (they stay in the page cache), as the builder does.
  std::optional<ResidentTrimmer> trimmer;
  trimmer.emplace(std::chrono::milliseconds(250), [this] {
    for (const MappedFile& f : files_) (void)f.releaseResident();
    if (grid_) grid_->releaseResident();
  });
  tbb::parallel_for(std::size_t{0}, totalNodes, [&](std::size_t k) { checkNode(k); });
  trimmer.reset();
  report_.patchesDecoded = done_.load();
  report_.morphTargetsChecked = morphChecked_.load();
  report_.nodesChecked = totalNodes;
  report_.demSamplesChecked = demSamples_.load();
  report_.worstErrorRatio = worstRatio_;
}

void DatasetVerifier::checkSharedEdges() {
  std::unordered_map<EdgeKey, std::pair<std::uint64_t, std::uint64_t>, EdgeKeyHash> firstSeen;
  firstSeen.reserve(nodes_.size());
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const DecodedNode& node = nodes_[k];
    if (!node.valid) continue;
    const std::uint64_t id = ids_[k];
    const BinTriangle t = triangleOfNode(lattice_, id, depth_);
    const std::array<EdgeKey, 3> keys = {lattice_.edgeKey(t.face, t.apex, t.left),
                                         lattice_.edgeKey(t.face, t.apex, t.right),
                                         lattice_.edgeKey(t.face, t.left, t.right)};
    for (std::size_t e = 0; e < 3; ++e) {
      const auto [it, inserted] = firstSeen.try_emplace(keys[e], id, node.edges[e]);
      if (inserted) continue;
      ++report_.edgesCompared;
      if (it->second.second != node.edges[e]) {
        violations_.add(nodeName(t) + " and " +
                        nodeName(triangleOfNode(lattice_, it->second.first, depth_)) +
                        " disagree on the vertices of a shared edge");
      }
    }
  }
}

void DatasetVerifier::checkDiamondLevel(int level) {
  // The level's nodes by spine: two for a diamond, one for a leaf whose partner does not exist
  // (its hypotenuse lies on a coarser leaf's leg).
  const auto spineOf = [&](std::size_t k) {
    const BinTriangle t = triangleOfNode(lattice_, ids_[k], depth_);
    return lattice_.edgeKey(t.face, t.left, t.right);
  };
  std::map<EdgeKey, std::vector<std::size_t>> bySpine;
  for (const std::size_t k : levelNodes_[static_cast<std::size_t>(level)]) {
    bySpine[spineOf(k)].push_back(k);
  }
  std::map<EdgeKey, std::size_t> childBySpine;
  if (level < depth_) {
    for (const std::size_t k : levelNodes_[static_cast<std::size_t>(level) + 1]) {
      childBySpine.emplace(spineOf(k), k);
    }
  }
  for (const auto& [spine, members] : bySpine) {
    const NodeRecord& a = nodes_[members[0]].record;
    const BinTriangle ta = triangleOfNode(lattice_, ids_[members[0]], depth_);
    if (members.size() == 2) {
      const NodeRecord& b = nodes_[members[1]].record;
      if (a.errorMeters != b.errorMeters || a.sphereCenter != b.sphereCenter ||
          a.sphereRadiusMeters != b.sphereRadiusMeters) {
        violations_.add(nodeName(ta) + ": diamond partners differ in error or sphere");
      }
      if (a.leaf() != b.leaf()) {
        violations_.add(nodeName(ta) + ": a diamond is split on one side only");
      }
    } else if (!a.leaf()) {
      violations_.add(nodeName(ta) + ": split, but its diamond partner does not exist");
    }
    for (const std::size_t k : members) {
      const NodeRecord& r = nodes_[k].record;
      if (r.errorMeters < r.measuredErrorMeters) {
        violations_.add(nodeName(ta) + ": saturated error below its own measured error");
      }
    }
    if (a.leaf()) continue;
    const glm::dvec3 pc{a.sphereCenter[0], a.sphereCenter[1], a.sphereCenter[2]};
    for (const std::size_t k : members) {
      const BinTriangle t = triangleOfNode(lattice_, ids_[k], depth_);
      for (const EdgeKey& leg :
           {lattice_.edgeKey(t.face, t.apex, t.left), lattice_.edgeKey(t.face, t.apex, t.right)}) {
        const auto it = childBySpine.find(leg);
        if (it == childBySpine.end()) {
          violations_.add(nodeName(ta) + ": a child diamond is missing");
          continue;
        }
        const NodeRecord& child = nodes_[it->second].record;
        if (child.errorMeters > a.errorMeters) {
          violations_.add(nodeName(ta) + ": error " + std::to_string(a.errorMeters) +
                          " m is below a child diamond's " + std::to_string(child.errorMeters) +
                          " m (nesting)");
        }
        const glm::dvec3 cc{child.sphereCenter[0], child.sphereCenter[1], child.sphereCenter[2]};
        if (glm::length(cc - pc) + static_cast<double>(child.sphereRadiusMeters) >
            static_cast<double>(a.sphereRadiusMeters) * (1.0 + 1e-7) + 1e-3) {
          violations_.add(nodeName(ta) + ": sphere does not contain a child diamond's sphere");
        }
      }
    }
  }
}

void DatasetVerifier::checkDiamondDag() {
  for (int level = depth_; level >= 0; --level) checkDiamondLevel(level);
}

void DatasetVerifier::checkTextures() {
  std::vector<std::byte> blob;
  for (std::size_t f = 0; f < 6; ++f) {
    const FaceView& view = *views_[f];
    for (std::uint64_t row = 0; row < view.header().textureNodeCount; ++row) {
      const TextureRecord r = view.textureAt(row);
      auto bytes = view.readTextureBlobs(r, blob);
      if (!bytes) {
        violations_.add(bytes.error().message);
        continue;
      }
      auto tile = decodeTextureTile(bytes->colour,
                                    view.context() + " offset " + std::to_string(r.blobOffset));
      if (!tile) {
        violations_.add(tile.error().message);
        continue;
      }
      ++report_.tilesDecoded;
      if (tile->sizeTexels != view.header().textureTileTexels) {
        violations_.add(view.context() + ": texture tile of the wrong size");
      }
      // Its normal map: half the size and border, two channels.
      auto normals = decodeTextureTile(
          bytes->normal, view.context() + " offset " + std::to_string(r.blobOffset + r.blobBytes));
      if (!normals) {
        violations_.add(normals.error().message);
      } else if (normals->sizeTexels != view.header().textureTileTexels / 2 ||
                 normals->borderTexels != view.header().textureBorderTexels / 2 ||
                 (normals->format != TexelFormat::Bc5 && normals->format != TexelFormat::Rg8)) {
        violations_.add(view.context() + ": normal-map tile at offset " +
                        std::to_string(r.blobOffset + r.blobBytes) +
                        " is not a half-size two-channel tile");
      }
      const std::uint32_t level = textureLevelOfHeap(r.heapIndex);
      if (level == 0) continue;
      // The parent exists (FaceView::open checked the quadtree's shape).
      const std::uint64_t inLevel = r.heapIndex - textureHeapIndex(level, 0, 0);
      const auto qi = static_cast<std::uint32_t>(inLevel & ((std::uint64_t{1} << level) - 1));
      const auto qj = static_cast<std::uint32_t>(inLevel >> level);
      if (view.textureNode(textureHeapIndex(level - 1, qi / 2, qj / 2)).errorMeters <
          r.errorMeters) {
        violations_.add(view.context() + ": texture error not nested at level " +
                        std::to_string(level));
      }
    }
  }
}

Result<VerifyReport> DatasetVerifier::run() {
  // ---- Files: sizes, checksums, headers, tables.
  openFaces();
  if (violations_.count() > 0) {
    report_.violationCount = violations_.count();
    report_.violations = violations_.take();
    return std::move(report_);
  }
  // ---- Optional source DEM, bucketed like the builder does.
  if (!o_.demPath.empty()) {
    if (auto r = openDemGrid(); !r) return std::move(r).error();
  }
  // ---- Every node: decode, coverage, orientation, sphere, edges, error against the DEM.
  listNodes();
  checkNodes();
  // ---- Shared edges: every patch bordering an edge has the same vertices there (and the same
  // heights), so every conforming cut is crack-free.
  checkSharedEdges();
  // ---- The diamond DAG: partners share error and sphere; parents bound children.
  checkDiamondDag();
  // ---- Texture tiles: decodable, errors nested.
  checkTextures();
  report_.violationCount = violations_.count();
  report_.violations = violations_.take();
  return std::move(report_);
}

}  // namespace

Result<VerifyReport> verifyDataset(const VerifyOptions& o) {
  auto manifest = readManifest(o.datasetDir);
  if (!manifest) {
    if (manifest.error().code == ErrorCode::NotFound) return std::move(manifest).error();
    VerifyReport report;
    report.violations.push_back(manifest.error().message);
    report.violationCount = 1;
    return report;
  }
  auto planet = Planet::fromSpec(manifest->planetSpec);
  if (!planet) {
    VerifyReport report;
    report.violations.push_back("manifest planet: " + planet.error().message);
    report.violationCount = 1;
    return report;
  }
  DatasetVerifier verifier(o, *manifest, *planet);
  return verifier.run();
}

}  // namespace pbdam::builder
