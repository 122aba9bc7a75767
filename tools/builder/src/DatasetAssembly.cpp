// Face files and manifest from the checkpoint's part files (DatasetAssembly.h; docs/builder.md
// "Distributed build", docs/format.md for the face file layout).
#include "DatasetAssembly.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>

#include <tbb/parallel_for.h>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/MorphTargets.h"
#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/FileWrite.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;
using namespace pbdam::streaming;

namespace pbdam::builder {

std::uint32_t textureLevelCount(std::uint32_t latticeCells, std::uint32_t tileTexels,
                                std::uint32_t borderTexels) {
  const std::uint32_t inner = tileTexels - 2 * borderTexels;
  const double ratio = static_cast<double>(latticeCells) / static_cast<double>(inner);
  return static_cast<std::uint32_t>(std::max(0.0, std::round(std::log2(std::max(ratio, 1.0))))) + 1;
}

namespace {

/// Nodes whose morph targets the assembly makes and writes at a time: what it holds of them is
/// this many nodes' targets (a few KB each), never a face's.
constexpr std::uint64_t kAssemblyBatchNodes = 8192;

/// Where one node's record and blob are inside the mapped part files.
struct Located {
  const std::byte* record = nullptr;
  std::span<const std::byte> blob;
};

/// Every texture tile's blob and error, by tile index (face-major, then heap order).
struct Tiles {
  std::vector<std::span<const std::byte>> blobs;
  std::vector<std::span<const std::byte>> normalBlobs;
  std::vector<float> errors;
  std::uint64_t perFace = 0;
};

/// The morph targets of a batch of a face's nodes as they are made, on several threads.
struct MorphBatch final {
  MorphGeometry geometry;
  std::uint64_t firstSlot = 0;
  std::vector<std::vector<std::byte>> blobs;  ///< by node, from firstSlot
  std::mutex failedMutex;
  std::optional<Error> failed;  ///< the first error met
  std::atomic<std::uint64_t> missed{0};
  void fail(Error e) {
    std::lock_guard lock(failedMutex);
    if (!failed) failed = std::move(e);
  }
};

/// The assembly of one dataset: the mappings it keeps and what it has located in them.
class Assembly final {
 public:
  Assembly(const AssemblyInputs& in, BuildSummary& summary)
      : in_(in),
        summary_(summary),
        d_(static_cast<int>(in.depth)),
        nodesPerTree_(Lattice::nodesPerTree(d_)),
        ids_(in.plan.nodeIds()),
        textureLevels_(textureLevelCount(in.latticeCells, in.options.textureTileTexels,
                                         kTextureBorderTexels)) {}
  Assembly(const Assembly&) = delete;
  Assembly& operator=(const Assembly&) = delete;
  ~Assembly() { in_.mappings.clear(); }  // before the mappings go, on every return

  Result<void> run();

 private:
  /// Keeps a mapping for the rest of the assembly and lets the trimmer release its pages.
  const MappedFile& keep(MappedFile mapped) {
    mappings_.push_back(std::make_unique<MappedFile>(std::move(mapped)));
    in_.mappings.add(mappings_.back().get());
    return *mappings_.back();
  }
  std::uint32_t levelParts(int level) const {
    const auto it = in_.state.levelParts.find(level);
    return it == in_.state.levelParts.end() ? 1u : it->second;
  }
  Result<void> locateNodes();
  Result<void> locateLevelPart(int level, std::uint32_t part);
  /// Whether to free the level files' pages as the faces are written (BuildOptions::
  /// freeCheckpoint): Auto when the filesystem's free space is short of the face files'
  /// estimate. Logs the decision when it frees.
  Result<bool> decideFreeing() const;
  /// Frees the pages of every level file that hold only nodes of faces up to `face`, after
  /// recording in the checkpoint's state (once) that its levels can no longer be resumed from.
  Result<void> freeLevelPages(int face);
  Result<void> locateTiles();
  Manifest makeManifest() const;
  Result<ManifestFace> writeFace(int face);
  /// Appends the face's patch and morph-target blobs from `at` on, a batch of nodes at a time,
  /// and writes their records into the node table's place in the prefix; returns the table's
  /// CRC-32.
  Result<std::uint32_t> appendNodes(AtomicFileWriter& file, const formats::FaceHeader& h,
                                    std::uint64_t firstSlot, std::uint64_t& at);
  Result<std::vector<std::vector<std::byte>>> faceMorphTargets(std::uint64_t firstSlot,
                                                               std::uint64_t count);
  /// Decodes node `id`'s patch into `mesh`: false when it has none, or on an error (recorded in
  /// `batch`).
  bool decodeNode(MorphBatch& batch, std::uint64_t id, formats::PatchMesh& mesh) const;
  /// The morph targets of the batch's nodes [begin, end), a group that shares its coarser
  /// patches (faceMorphTargets).
  void groupMorphTargets(MorphBatch& batch, std::uint64_t begin, std::uint64_t end) const;

  const AssemblyInputs& in_;
  BuildSummary& summary_;
  /// Where node `id` is in located_: its index among the ids that exist (the id itself for a
  /// complete forest).
  std::uint64_t slotOf(std::uint64_t id) const noexcept {
    if (ids_.empty()) return id;
    const auto it = std::lower_bound(ids_.begin(), ids_.end(), id);
    return it != ids_.end() && *it == id ? static_cast<std::uint64_t>(it - ids_.begin())
                                         : located_.size();
  }
  /// The first slot of an id at least `id`.
  std::uint64_t slotFrom(std::uint64_t id) const noexcept {
    if (ids_.empty()) return id;
    return static_cast<std::uint64_t>(std::lower_bound(ids_.begin(), ids_.end(), id) -
                                      ids_.begin());
  }
  std::uint64_t idAt(std::uint64_t slot) const noexcept { return ids_.empty() ? slot : ids_[slot]; }

  int d_;
  std::uint64_t nodesPerTree_;
  std::vector<std::uint64_t> ids_;  ///< the node ids that exist, ascending (empty: complete)
  std::uint32_t textureLevels_;
  std::vector<std::unique_ptr<MappedFile>> mappings_;
  std::vector<Located> located_;
  /// One level part file's byte ranges, [begin, end) in the file, by the face whose nodes they
  /// hold (adjacent ranges merged), and the ranges written so far, for freeing its pages.
  struct PartRanges {
    std::filesystem::path path;
    std::array<std::vector<std::pair<std::uint64_t, std::uint64_t>>, 6> byFace;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> written;
  };
  std::vector<PartRanges> partRanges_;
  std::uint64_t partBytes_ = 0;  ///< the level and texture part files' bytes
  bool freeing_ = false;
  bool stateMarked_ = false;
  Tiles tiles_;
  std::vector<std::uint64_t> tileKeys_;  ///< the tiles that exist (empty: all), ascending
};

Result<void> Assembly::locateNodes() {
  located_.assign(ids_.empty() ? 12 * nodesPerTree_ : ids_.size(), Located{});
  for (int level = 0; level <= d_; ++level) {
    for (std::uint32_t part = 0; part < levelParts(level); ++part) {
      if (auto r = locateLevelPart(level, part); !r) return r;
    }
  }
  for (std::uint64_t slot = 0; slot < located_.size(); ++slot) {
    if (located_[slot].record == nullptr) {
      return makeError(ErrorCode::CorruptData, in_.checkpoint.directory().string() + ": node " +
                                                   std::to_string(idAt(slot)) + " is missing");
    }
  }
  return {};
}

Result<void> Assembly::locateLevelPart(int level, std::uint32_t part) {
  constexpr std::size_t kReleaseEvery = std::size_t{64} << 20;
  const Checkpoint& checkpoint = in_.checkpoint;
  std::span<const std::byte> payload;
  auto mapped = checkpoint.openFile(Checkpoint::Kind::Nodes, level, part, payload);
  if (!mapped) return std::move(mapped).error();
  // RSS bound: the walk below reads a record header on nearly every page (blobs average a
  // few KB), so the mapping is handed to the trimmer first and released every 64 MB —
  // registered only afterwards, a paper-scale leaf level's 11 GB file became resident whole.
  const MappedFile& nodesFile = keep(std::move(mapped).value());
  auto view =
      LevelPartView::parse(payload, checkpoint.file(Checkpoint::Kind::Nodes, level, part).string());
  if (!view) return std::move(view).error();
  summary_.insertedPoints += view->footer().insertedPoints;
  summary_.halvesOverTarget += view->footer().halvesOverTarget;
  summary_.patchBytesRaw += view->footer().patchBytesRaw;
  std::size_t releasedUpTo = 0;
  partBytes_ += nodesFile.size();
  PartRanges& ranges = partRanges_.emplace_back();
  ranges.path = nodesFile.path();
  const auto entriesAt = static_cast<std::uint64_t>(payload.data() - nodesFile.bytes().data());
  std::uint64_t entryBegin = entriesAt;
  auto walked = view->forEachNode([&](const NodeEntry& node, std::size_t readBytes) {
    const std::uint64_t slot = slotOf(node.id);
    if (slot >= located_.size()) return false;
    const std::uint64_t entryEnd = entriesAt + readBytes;
    auto& faceRanges = ranges.byFace[static_cast<std::size_t>(node.id / (2 * nodesPerTree_))];
    if (!faceRanges.empty() && faceRanges.back().second == entryBegin) {
      faceRanges.back().second = entryEnd;
    } else {
      faceRanges.emplace_back(entryBegin, entryEnd);
    }
    entryBegin = entryEnd;
    if (readBytes - releasedUpTo >= kReleaseEvery) {
      (void)nodesFile.releaseResident();
      releasedUpTo = readBytes;
    }
    located_[slot] = Located{node.record.data(), node.blob};
    const NodeRecord rec = decodeNodeRecord(node.record);
    if (in_.plan.isLeaf(level, node.id)) {
      summary_.leafMaxErrorMeters =
          std::max(summary_.leafMaxErrorMeters, static_cast<double>(rec.errorMeters));
    }
    if (level == 0) {
      summary_.rootErrorMeters =
          std::max(summary_.rootErrorMeters, static_cast<double>(rec.errorMeters));
    }
    return true;
  });
  if (!walked) return walked;
  (void)nodesFile.releaseResident();
  return {};
}

Result<bool> Assembly::decideFreeing() const {
  using Free = BuildOptions::FreeCheckpoint;
  if (in_.options.freeCheckpoint != Free::Auto) return in_.options.freeCheckpoint == Free::Always;
  std::error_code ec;
  const std::filesystem::space_info space = std::filesystem::space(in_.options.outDir, ec);
  if (ec) return false;  // unknown: keep the checkpoint (a short disk then fails as NoSpace)
  // The face files hold the part files' blobs and records plus the morph targets, which the
  // assembly makes: at most about half the patch bytes again on the datasets measured
  // (docs/builder.md "Disk at assembly"); 1 GiB for what else fills the disk meanwhile.
  const std::uint64_t estimate = partBytes_ + partBytes_ / 2 + (std::uint64_t{1} << 30);
  if (space.available >= estimate) return false;
  if (in_.log) {
    char line[240];
    std::snprintf(line, sizeof line,
                  "write: %.1f GB free on %s, the face files need about %.1f GB beside the "
                  "%.1f GB checkpoint: freeing its level files' pages as the faces are written "
                  "(a failed assembly then builds the levels again)",
                  static_cast<double>(space.available) / 1e9, in_.options.outDir.c_str(),
                  static_cast<double>(estimate) / 1e9, static_cast<double>(partBytes_) / 1e9);
    in_.log(line);
  }
  return true;
}

Result<void> Assembly::freeLevelPages(int face) {
  if (!stateMarked_) {
    CheckpointState state = in_.state;
    state.assemblyFreedLevels = true;
    if (auto w = in_.checkpoint.writeState(state); !w) return w;
    stateMarked_ = true;
  }
  for (PartRanges& part : partRanges_) {
    auto& mine = part.byFace[static_cast<std::size_t>(face)];
    part.written.insert(part.written.end(), mine.begin(), mine.end());
    mine = {};
    // Merged, the ranges of faces written so far cover whole stretches of the file: nodes are
    // in diamond order, nearly face by face (a diamond across a face edge has a node on each).
    std::sort(part.written.begin(), part.written.end());
    std::vector<std::pair<std::uint64_t, std::uint64_t>> merged;
    for (const auto& range : part.written) {
      if (!merged.empty() && merged.back().second >= range.first) {
        merged.back().second = std::max(merged.back().second, range.second);
      } else {
        merged.push_back(range);
      }
    }
    part.written = merged;
    auto freed = freeFileRanges(part.path, part.written);
    if (!freed) return std::move(freed).error();
  }
  return {};
}

Result<void> Assembly::locateTiles() {
  tiles_.perFace = ((std::uint64_t{1} << (2 * textureLevels_)) - 1) / 3;
  tileKeys_ = in_.plan.tiles(textureLevels_);
  const std::uint64_t count = tileKeys_.empty() ? 6 * tiles_.perFace : tileKeys_.size();
  tiles_.blobs.assign(count, {});
  tiles_.normalBlobs.assign(count, {});
  tiles_.errors.assign(count, 0.0f);
  std::uint64_t seen = 0;
  const Checkpoint& checkpoint = in_.checkpoint;
  for (std::uint32_t part = 0; part < std::max(1u, in_.state.textureParts); ++part) {
    std::span<const std::byte> payload;
    auto mapped = checkpoint.openFile(Checkpoint::Kind::Texture, 0, part, payload);
    if (!mapped) return std::move(mapped).error();
    auto view = TexturePartView::parse(
        payload, checkpoint.file(Checkpoint::Kind::Texture, 0, part).string());
    if (!view) return std::move(view).error();
    auto walked =
        view->forEachTile([&](std::uint64_t k, float textureErrorMeters,
                              std::span<const std::byte> blob, std::span<const std::byte> normal) {
          if (k >= tiles_.blobs.size()) return false;
          tiles_.errors[k] = textureErrorMeters;
          tiles_.blobs[k] = blob;
          tiles_.normalBlobs[k] = normal;
          ++seen;
          return true;
        });
    if (!walked) return walked;
    partBytes_ += keep(std::move(mapped).value()).size();
  }
  if (seen != tiles_.blobs.size()) {
    return makeError(ErrorCode::CorruptData,
                     checkpoint.file(Checkpoint::Kind::Texture, 0).string() + ": incomplete");
  }
  return {};
}

Manifest Assembly::makeManifest() const {
  const BuildOptions& o = in_.options;
  Manifest manifest;
  manifest.version = kDatasetFormatVersion;
  manifest.planetSpec = in_.planet.name();
  manifest.equatorialRadiusMeters = in_.planet.equatorialRadiusMeters();
  manifest.flattening = in_.planet.flattening();
  manifest.latticeCells = in_.latticeCells;
  manifest.leafCells = in_.leafCells;
  manifest.depth = in_.depth;
  manifest.minPatchTriangles = o.minPatchTriangles;
  manifest.errorMargin = o.errorMargin;
  manifest.heightStepMeters = o.heightStepMeters;
  manifest.textureLevels = textureLevels_;
  manifest.textureTileTexels = o.textureTileTexels;
  manifest.textureBorderTexels = kTextureBorderTexels;
  manifest.textureFormat = o.textureFormat == TexelFormat::Bc1 ? "bc1" : "rgba8";
  manifest.textureNormalFormat = o.textureFormat == TexelFormat::Bc1 ? "bc5" : "rg8";
  manifest.textureSource = "shaded-relief";
  if (in_.hasImagery) {
    manifest.textureSource = "image:";
    manifest.textureSource += o.texturePath.filename().string();
  }
  manifest.sourceDem = o.demPath.filename().string();
  manifest.sourceFormat = in_.sourceFormat;
  manifest.sourceSamples = summary_.sourceSamples;
  manifest.minHeightMeters = in_.minHeightMeters;
  manifest.maxHeightMeters = in_.maxHeightMeters;
  manifest.insets = in_.insets;
  return manifest;
}

Result<std::vector<std::vector<std::byte>>> Assembly::faceMorphTargets(std::uint64_t firstSlot,
                                                                       std::uint64_t count) {
  // Every node's targets from its own, its parent's and its grandparent's patches (decoded
  // again here: the checkpoint keeps no meshes). In heap order a grandparent's grandchildren
  // are adjacent (on level 1, a root's children, next to its grandchildren on level 2), so the
  // nodes go in groups of adjacent nodes with the same grandparent, or parent where they have
  // none: a group decodes each of its coarser patches once and makes each of their surfaces
  // once, over the union of the regions its nodes ask, where node by node each was decoded
  // and made again for every child and grandchild. Surfaces answer the same over any region
  // that holds the point asked (CoarserSurface), so the targets are those made node by node.
  const Lattice lattice(in_.latticeCells);
  MorphBatch batch;
  batch.geometry = MorphGeometry{&in_.planet, &lattice, in_.options.heightStepMeters};
  batch.firstSlot = firstSlot;
  batch.blobs.resize(count);
  const auto groupKey = [&](std::uint64_t k) -> std::optional<std::uint64_t> {
    const NodeAncestors a = nodeAncestors(idAt(firstSlot + k), nodesPerTree_);
    return a.grandparent ? a.grandparent : a.parent;
  };
  std::vector<std::uint64_t> groupStarts;  // the groups' first nodes, then `count`
  for (std::uint64_t k = 0; k < count; ++k) {
    if (k == 0 || !groupKey(k) || groupKey(k) != groupKey(k - 1)) groupStarts.push_back(k);
  }
  groupStarts.push_back(count);
  tbb::parallel_for(std::size_t{0}, groupStarts.size() - 1, [&](std::size_t g) {
    groupMorphTargets(batch, groupStarts[g], groupStarts[g + 1]);
  });
  if (batch.failed) return std::move(*batch.failed);
  if (batch.missed.load() != 0) {
    return makeError(ErrorCode::Internal,
                     std::to_string(batch.missed.load()) +
                         " patch vertices lie outside their coarser patch; no morph target");
  }
  return std::move(batch.blobs);
}

bool Assembly::decodeNode(MorphBatch& batch, std::uint64_t id, PatchMesh& mesh) const {
  const std::uint64_t slot = slotOf(id);
  if (slot >= located_.size()) {
    batch.fail(makeError(ErrorCode::CorruptData, in_.checkpoint.directory().string() + ": node " +
                                                     std::to_string(id) + " is missing"));
    return false;
  }
  if (located_[slot].blob.empty()) return false;  // no patch: no targets
  auto r = decodePatch(located_[slot].blob, mesh, "node " + std::to_string(id));
  if (r) return true;
  batch.fail(std::move(r).error());
  return false;
}

void Assembly::groupMorphTargets(MorphBatch& batch, std::uint64_t begin, std::uint64_t end) const {
  /// A coarser patch of the group, decoded on first use, and its surfaces as a parent and as a
  /// grandparent, made on first use.
  struct Coarse {
    std::uint64_t id = 0;
    bool usable = false;
    PatchMesh mesh;
    std::array<bool, 2> surfaceTried{};
    std::array<std::optional<CoarserSurface>, 2> surface;
  };
  constexpr std::size_t kMaxGroup = 6;   // a root's children and grandchildren
  constexpr std::size_t kMaxCoarse = 3;  // the key node and its two children
  constexpr std::size_t kAsParent = 0;
  constexpr std::size_t kAsGrandparent = 1;
  if (end - begin > kMaxGroup) {
    batch.fail(makeError(ErrorCode::Internal,
                         "a morph-target group of " + std::to_string(end - begin) + " nodes"));
    return;
  }
  const Lattice& lattice = *batch.geometry.lattice;
  std::array<runtime::BinTriangle, kMaxGroup> self{};
  std::array<NodeAncestors, kMaxGroup> ancestors{};
  for (std::uint64_t k = begin; k < end; ++k) {
    const std::uint64_t id = idAt(batch.firstSlot + k);
    self[k - begin] = triangleOfNode(lattice, id, d_);
    ancestors[k - begin] = nodeAncestors(id, nodesPerTree_);
  }
  thread_local std::array<Coarse, kMaxCoarse> coarse;
  thread_local PatchMesh mesh;
  std::size_t coarseUsed = 0;
  const auto coarsePatch = [&](std::uint64_t id) -> Coarse* {
    for (std::size_t c = 0; c < coarseUsed; ++c) {
      if (coarse[c].id == id) return coarse[c].usable ? &coarse[c] : nullptr;
    }
    if (coarseUsed == kMaxCoarse) {
      batch.fail(makeError(ErrorCode::Internal, "a morph-target group of too many patches"));
      return nullptr;
    }
    Coarse& c = coarse[coarseUsed++];
    c.id = id;
    c.usable = decodeNode(batch, id, c.mesh);
    return c.usable ? &c : nullptr;
  };
  // The surface of coarser patch `c` as the parent or grandparent of the group's nodes, over
  // the union of the boxes they ask it: their own boxes, or their hypotenuses'.
  const auto surfaceOf = [&](Coarse& c, std::size_t role) -> const CoarserSurface* {
    if (!c.surfaceTried[role]) {
      c.surfaceTried[role] = true;
      bool asked = false;
      runtime::LatticeXY low{0};
      runtime::LatticeXY high{0};
      for (std::uint64_t k = 0; k < end - begin; ++k) {
        const auto& by = role == kAsParent ? ancestors[k].parent : ancestors[k].grandparent;
        if (by != c.id) continue;
        const runtime::BinTriangle& t = self[k];
        runtime::LatticeXY lo = glm::min(t.left, t.right);
        runtime::LatticeXY hi = glm::max(t.left, t.right);
        if (role == kAsParent) {
          lo = glm::min(lo, t.apex);
          hi = glm::max(hi, t.apex);
        }
        low = asked ? glm::min(low, lo) : lo;
        high = asked ? glm::max(high, hi) : hi;
        asked = true;
      }
      const runtime::BinTriangle t = triangleOfNode(lattice, c.id, d_);
      auto corners = patchLatticePoints(t, c.mesh);
      if (asked && corners) {
        c.surface[role].emplace(batch.geometry, t, c.mesh, std::move(*corners), low, high);
      }
    }
    return c.surface[role] ? &*c.surface[role] : nullptr;
  };
  for (std::uint64_t k = begin; k < end; ++k) {
    const std::uint64_t id = idAt(batch.firstSlot + k);
    const NodeAncestors& a = ancestors[k - begin];
    if (!a.parent || !decodeNode(batch, id, mesh)) continue;
    Coarse* parent = coarsePatch(*a.parent);
    Coarse* grandparent =
        parent != nullptr && a.grandparent ? coarsePatch(*a.grandparent) : nullptr;
    if (parent == nullptr || (a.grandparent && grandparent == nullptr)) continue;
    const CoarserSurface* up = surfaceOf(*parent, kAsParent);
    const CoarserSurface* upUp =
        grandparent != nullptr ? surfaceOf(*grandparent, kAsGrandparent) : nullptr;
    std::uint64_t misses = 0;
    std::optional<std::vector<std::int32_t>> targets;
    if (up != nullptr && (grandparent == nullptr || upUp != nullptr)) {
      targets = nodeMorphTargets(self[k - begin], mesh, *up, upUp, misses);
    }
    if (!targets) {
      batch.fail(makeError(ErrorCode::CorruptData, "node " + std::to_string(id) +
                                                       ": a patch vertex is not on the lattice"));
      continue;
    }
    batch.missed += misses;
    auto blob = encodeMorphTargets(mesh, *targets);
    if (!blob) {
      batch.fail(std::move(blob).error());
      continue;
    }
    batch.blobs[k] = std::move(blob).value();
  }
  // The surfaces refer to this batch's geometry: none outlives the group. The meshes keep
  // their capacity for the next.
  for (std::size_t c = 0; c < coarseUsed; ++c) {
    for (auto& surface : coarse[c].surface) surface.reset();
    coarse[c].surfaceTried = {};
  }
}

Result<std::uint32_t> Assembly::appendNodes(AtomicFileWriter& file, const FaceHeader& h,
                                            std::uint64_t firstSlot, std::uint64_t& at) {
  std::uint32_t nodeTableCrc = 0;
  std::vector<std::byte> nodeTable;
  for (std::uint64_t k0 = 0; k0 < h.nodeCount; k0 += kAssemblyBatchNodes) {
    const std::uint64_t n = std::min(kAssemblyBatchNodes, h.nodeCount - k0);
    auto morph = faceMorphTargets(firstSlot + k0, n);
    if (!morph) return std::move(morph).error();
    nodeTable.assign(n * kNodeRecordBytes, std::byte{0});
    for (std::uint64_t b = 0; b < n; ++b) {
      const std::uint64_t k = k0 + b;
      const Located& node = located_[firstSlot + k];
      NodeRecord record = decodeNodeRecord(
          std::span<const std::byte, kNodeRecordBytes>(node.record, kNodeRecordBytes));
      record.blobOffset = at;
      record.blobBytes = static_cast<std::uint32_t>(node.blob.size());
      const std::uint64_t id = idAt(firstSlot + k);
      record.heapIndex = id % nodesPerTree_;
      const bool leaf = in_.plan.isLeaf(runtime::bintreeLevel(record.heapIndex), id);
      record.flags = leaf ? kRecordLeaf : 0;
      record.sources = 0;
      if (leaf && in_.leafSources) {
        record.sources = in_.leafSources(
            triangleOfNode(Lattice(in_.latticeCells), id, static_cast<int>(in_.depth)));
      }
      const std::vector<std::byte>& targets = (*morph)[b];
      record.morphBytes = static_cast<std::uint32_t>(targets.size());
      at += node.blob.size() + record.morphBytes;
      if (auto w = file.append(node.blob); !w) return std::move(w).error();
      if (auto w = file.append(targets); !w) return std::move(w).error();
      summary_.morphTargetBytes += record.morphBytes;
      encodeNodeRecord(record, std::span<std::byte, kNodeRecordBytes>(
                                   nodeTable.data() + b * kNodeRecordBytes, kNodeRecordBytes));
      summary_.patchBytesCompressed += node.blob.size();
      summary_.totalTriangles += record.triangleCount;
      if (leaf) summary_.leafTriangles += record.triangleCount;
    }
    if (auto w = file.writePrefix(h.nodeTableOffset + k0 * kNodeRecordBytes, nodeTable); !w) {
      return std::move(w).error();
    }
    nodeTableCrc = crc32(nodeTable, nodeTableCrc);
  }
  return nodeTableCrc;
}

Result<ManifestFace> Assembly::writeFace(int face) {
  FaceHeader h;
  h.face = static_cast<std::uint32_t>(face);
  h.latticeCells = in_.latticeCells;
  h.leafCells = in_.leafCells;
  h.depth = in_.depth;
  h.textureLevels = textureLevels_;
  h.textureTileTexels = in_.options.textureTileTexels;
  h.textureBorderTexels = kTextureBorderTexels;
  // The face's nodes: slots [firstSlot, endSlot) of located_, tree 0 then tree 1 in heap order.
  const std::uint64_t faceFirst = static_cast<std::uint64_t>(face) * 2 * nodesPerTree_;
  const std::uint64_t firstSlot = slotFrom(faceFirst);
  const std::uint64_t tree1Slot = slotFrom(faceFirst + nodesPerTree_);
  const std::uint64_t endSlot = slotFrom(faceFirst + 2 * nodesPerTree_);
  h.nodeCount = endSlot - firstSlot;
  h.tree1FirstNode = tree1Slot - firstSlot;
  h.nodeTableOffset = kFaceHeaderBytes;
  // The face's tiles: [firstTile, endTile) of tiles_ (all of a complete quadtree).
  const std::uint64_t faceTiles = static_cast<std::uint64_t>(face) * tiles_.perFace;
  const auto tileSlot = [&](std::uint64_t key) -> std::uint64_t {
    if (tileKeys_.empty()) return key;
    return static_cast<std::uint64_t>(std::lower_bound(tileKeys_.begin(), tileKeys_.end(), key) -
                                      tileKeys_.begin());
  };
  const std::uint64_t firstTile = tileSlot(faceTiles);
  h.textureNodeCount = tileSlot(faceTiles + tiles_.perFace) - firstTile;
  h.textureTableOffset = h.nodeTableOffset + h.nodeCount * kNodeRecordBytes;
  const std::uint64_t tablesEnd = h.textureTableOffset + h.textureNodeCount * kTextureRecordBytes;
  h.blobsOffset = (tablesEnd + 4095) / 4096 * 4096;  // page-aligned blob area
  std::vector<std::byte> padding(h.blobsOffset - tablesEnd);
  const std::string name = "face" + std::to_string(face) + ".pbdam";
  auto file = AtomicFileWriter::create(in_.options.outDir / name);
  if (!file) return std::move(file).error();
  // The blocks the face takes before its morph targets are made (the tables, the patches and
  // the tiles): a disk that cannot hold that much fails here, naming the size.
  std::uint64_t known = h.blobsOffset;
  for (std::uint64_t k = 0; k < h.nodeCount; ++k) known += located_[firstSlot + k].blob.size();
  for (std::uint64_t k = 0; k < h.textureNodeCount; ++k)
    known += tiles_.blobs[firstTile + k].size() + tiles_.normalBlobs[firstTile + k].size();
  if (auto r = file->reserve(known); !r) return std::move(r).error();
  // The header and tables are written last, in place: a record holds its blobs' offset, known
  // once the morph targets before it are made, and the header the tables' CRCs. The morph
  // targets are made and written a batch of nodes at a time, so that the assembly holds one
  // batch, never a face's worth (several GB at the paper's scale).
  if (auto r = file->leavePrefix(h.blobsOffset); !r) return std::move(r).error();
  std::uint64_t at = h.blobsOffset;
  auto nodeTableCrc = appendNodes(*file, h, firstSlot, at);
  if (!nodeTableCrc) return std::move(nodeTableCrc).error();
  std::vector<std::byte> textureTable(h.textureNodeCount * kTextureRecordBytes);
  for (std::uint64_t k = 0; k < h.textureNodeCount; ++k) {
    const std::size_t tile = firstTile + k;
    const std::uint64_t heap = tileKeys_.empty() ? k : tileKeys_[tile] - faceTiles;
    const auto& blob = tiles_.blobs[tile];
    const std::uint32_t level = textureLevelOfHeap(heap);
    // A tile with children has all four (ForestPlan::tiles); the first one tells.
    bool leaf = level + 1 == textureLevels_;
    if (!leaf && !tileKeys_.empty()) {
      const std::uint64_t inLevel = heap - textureHeapIndex(level, 0, 0);
      const auto qi = static_cast<std::uint32_t>(inLevel & ((std::uint64_t{1} << level) - 1));
      const auto qj = static_cast<std::uint32_t>(inLevel >> level);
      leaf = !std::binary_search(tileKeys_.begin(), tileKeys_.end(),
                                 faceTiles + textureHeapIndex(level + 1, 2 * qi, 2 * qj));
    }
    const auto& normal = tiles_.normalBlobs[tile];
    TextureRecord t{at,
                    static_cast<std::uint32_t>(blob.size()),
                    tiles_.errors[tile],
                    heap,
                    leaf ? kRecordLeaf : 0,
                    static_cast<std::uint32_t>(normal.size())};
    at += blob.size() + normal.size();
    if (auto w = file->append(blob); !w) return std::move(w).error();
    if (auto w = file->append(normal); !w) return std::move(w).error();
    encodeTextureRecord(t, std::span<std::byte, kTextureRecordBytes>(
                               textureTable.data() + k * kTextureRecordBytes, kTextureRecordBytes));
  }
  h.fileBytes = at;
  h.nodeTableCrc = *nodeTableCrc;
  h.textureTableCrc = crc32(textureTable);
  std::array<std::byte, kFaceHeaderBytes> header{};
  encodeFaceHeader(h, header);
  // The prefix in file order: header, node table (written above), texture table, padding.
  if (auto w = file->writePrefix(0, header); !w) return std::move(w).error();
  if (auto w = file->writePrefix(h.textureTableOffset, textureTable); !w) {
    return std::move(w).error();
  }
  if (auto w = file->writePrefix(tablesEnd, padding); !w) return std::move(w).error();
  std::uint32_t prefixCrc = crc32(header);
  prefixCrc = crc32Combine(prefixCrc, *nodeTableCrc, h.nodeCount * kNodeRecordBytes);
  prefixCrc = crc32(textureTable, prefixCrc);
  prefixCrc = crc32(padding, prefixCrc);
  file->prefixWritten(prefixCrc);
  const std::uint32_t crc = file->crc();
  if (auto w = file->finish(); !w) return std::move(w).error();
  return ManifestFace{name, h.fileBytes, crc};
}

Result<void> Assembly::run() {
  if (auto r = locateNodes(); !r) return r;
  summary_.textureLevels = textureLevels_;
  if (auto r = locateTiles(); !r) return r;
  summary_.textureTiles = tiles_.blobs.size();

  auto freeing = decideFreeing();
  if (!freeing) return std::move(freeing).error();
  freeing_ = *freeing;

  Manifest manifest = makeManifest();
  for (int face = 0; face < 6; ++face) {
    auto written = writeFace(face);
    if (!written) return std::move(written).error();
    // The face's nodes are never read again (morph targets come from the same face's trees).
    if (freeing_) {
      if (auto r = freeLevelPages(face); !r) return r;
    }
    manifest.faces[static_cast<std::size_t>(face)] = *written;
    summary_.datasetBytes += written->bytes;
    if (in_.progress) in_.progress(static_cast<double>(face + 1) / 6.0);
  }
  const std::filesystem::path& outDir = in_.options.outDir;
  if (!in_.voids.surfaces.empty()) {
    // Where the insets' voids were, for `pbdam height` (before the manifest, which names it).
    const std::vector<std::byte> bytes = encodeVoidMap(in_.voids);
    ManifestFace voids{kVoidMapFileName, bytes.size(), 0};
    if (auto w = writeFileAtomically(outDir / kVoidMapFileName, {bytes}, voids.crc32); !w) {
      return w;
    }
    manifest.voids = voids;
    summary_.datasetBytes += bytes.size();
  }
  syncDirectory(outDir);
  const std::string json = manifestToJson(manifest);
  std::uint32_t crc = 0;
  if (auto w = writeFileAtomically(outDir / kManifestFileName,
                                   {std::as_bytes(std::span<const char>(json.data(), json.size()))},
                                   crc);
      !w) {
    return w;
  }
  syncDirectory(outDir);
  summary_.datasetBytes += json.size();
  summary_.patches = located_.size();
  // The dataset is complete: its checkpoint has served.
  return in_.checkpoint.reset(false);
}

}  // namespace

Result<void> assembleDataset(const AssemblyInputs& inputs, BuildSummary& summary) {
  Assembly assembly(inputs, summary);
  return assembly.run();
}

}  // namespace pbdam::builder
