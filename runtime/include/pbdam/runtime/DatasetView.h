// A whole dataset as the runtime reads it: the manifest, the planet it names, and a validated
// view of each of the six face files over bytes someone else owns (streaming/MappedDataset maps
// them; tests may hold them in memory). Also the per-level figures refinement needs that are
// properties of the whole dataset rather than of one node. Thread-safety: read-only after open;
// any number of threads may use one view.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/Planet.h"

/// The runtime layer: the planet and its cube map, the camera, a dataset's view over bytes held
/// elsewhere, and the CPU side of each frame — refinement into a cut, the cut's mesh and draw
/// records, height, sightline and viewshed queries. No I/O and no GPU.
namespace pbdam::runtime {

/// Heap indices of node and tile keys stay below 2^kMaxKeyHeapBits, faces below 8 and trees
/// below 2: the bounds under which packKey() is injective (a bintree of depth ≤ 57 and a texture
/// quadtree of ≤ 29 levels have smaller heap indices).
inline constexpr int kMaxKeyHeapBits = 59;

/// Identifies one bintree node of a dataset: face, tree (0/1) and heap index.
struct NodeKey final {
  std::uint8_t face = 0;   ///< 0..5
  std::uint8_t tree = 0;   ///< 0 or 1
  std::uint64_t heap = 0;  ///< heap index within the tree (root 0)
  /// Field by field.
  friend bool operator==(const NodeKey&, const NodeKey&) = default;
};

/// Identifies one texture quadtree node: face and heap index (formats/DatasetFormat.h).
struct TileKey final {
  std::uint8_t face = 0;   ///< 0..5
  std::uint64_t heap = 0;  ///< heap index in the face's quadtree (textureHeapIndex)
  /// Field by field.
  friend bool operator==(const TileKey&, const TileKey&) = default;
};

/// The one integer packing of node keys: face in bits 60-62, tree in bit 59, heap index in
/// bits 0-58; bit 63 is 0. Injective for face < 8, tree < 2, heap < 2^kMaxKeyHeapBits.
constexpr std::uint64_t packKey(const NodeKey& key) noexcept {
  return (std::uint64_t{key.face} << 60) | (std::uint64_t{key.tree} << kMaxKeyHeapBits) | key.heap;
}

/// The one integer packing of tile keys: bit 63 set (so that a tile never packs like a node),
/// face in bits 60-62, heap index in bits 0-58. Injective for face < 8, heap <
/// 2^kMaxKeyHeapBits, and disjoint from every packed NodeKey.
constexpr std::uint64_t packKey(const TileKey& key) noexcept {
  return (std::uint64_t{1} << 63) | (std::uint64_t{key.face} << 60) | key.heap;
}

/// A whole dataset as the runtime reads it: its manifest, its planet and a validated FaceView
/// of each face file, over bytes someone else owns (streaming::MappedDataset maps them), with
/// the per-level figures refinement needs. Read-only after open; any number of threads may use
/// one view.
class DatasetView final {
 public:
  /// Validates the six faces against the manifest (lattice, depth, texture levels and sizes,
  /// file sizes). `faceBytes[f]` are the bytes of manifest.faces[f]; `directory` names the
  /// dataset in errors.
  /// `faceOptions` say how each face holds its node table (FaceViewOptions: whole, or paged
  /// through a cache of at most that many bytes per face).
  static formats::Result<DatasetView> open(
      const formats::Manifest& manifest, const std::array<std::span<const std::byte>, 6>& faceBytes,
      const std::string& directory, const formats::FaceViewOptions& faceOptions = {});
  /// The first face's damage() (a paged node table that no longer reads back as it did at
  /// open): frame loops check it after each frame and stop with it. nullopt while all is well.
  std::optional<formats::Error> damage() const;
  /// Node-table chunks read back from the files since open (paged tables only).
  std::uint64_t nodeChunkReads() const noexcept;

  /// The dataset's manifest.
  const formats::Manifest& manifest() const noexcept { return manifest_; }
  /// The planet the manifest names.
  const Planet& planet() const noexcept { return planet_; }
  /// Face file `f` (0..5).
  const formats::FaceView& face(int f) const noexcept {
    return faces_[static_cast<std::size_t>(f)];
  }
  /// N: lattice cells per face side.
  std::uint32_t latticeCells() const noexcept { return manifest_.latticeCells; }
  /// The lattice's spacing along the surface: a face's quarter meridian (on the equatorial
  /// radius) over its cells. The cube map stretches cells towards the face corners; this is
  /// the nominal figure, for defaults and margins.
  double latticeSpacingMeters() const noexcept;
  /// The deepest level of any leaf (leaves may be shallower elsewhere: NodeRecord::leaf()).
  int depth() const noexcept { return static_cast<int>(manifest_.depth); }
  /// Levels of the texture quadtree.
  std::uint32_t textureLevels() const noexcept { return manifest_.textureLevels; }

  /// Whether the dataset has node `key`.
  bool hasNode(const NodeKey& key) const noexcept {
    return faces_[key.face].findNode(key.tree, key.heap).has_value();
  }
  /// Node `key`, which must exist (every key of a cut does).
  formats::NodeRecord node(const NodeKey& key) const noexcept {
    return faces_[key.face].node(key.tree, key.heap);
  }
  /// Node `key`'s lattice triangle (it follows from the key; the node need not exist).
  BinTriangle triangle(const NodeKey& key) const noexcept {
    return bintreeTriangle(manifest_.latticeCells, key.face, key.tree, key.heap);
  }
  /// Tile `key`, which must exist (every tile of a cut does).
  formats::TextureRecord textureNode(const TileKey& key) const noexcept {
    return faces_[key.face].textureNode(key.heap);
  }

  /// The texture level of the refinement's texture term for geometry level `level`: the finest
  /// tile level whose square contains every level-`level` triangle, min(level/2,
  /// textureLevels − 1).
  std::uint32_t textureLevelOf(int level) const noexcept;
  /// The tile that patch `key` is drawn with: the finest tile that exists among those of levels
  /// up to textureLevelOf(its level) whose square contains it.
  TileKey tileOf(const NodeKey& key) const noexcept;

  /// The largest texture error of any tile of texture level `t` on any face (metres): the
  /// texture term of the refinement criterion, the same for both triangles of a diamond.
  double textureErrorOfLevel(std::uint32_t t) const noexcept { return textureErrorOfLevel_[t]; }
  /// The texture term of the refinement criterion for bintree level `level` (≤ depth()): while
  /// a finer tile level exists, the texture error of the level's tiles, saturated upward with
  /// the dataset's error margin r from the deepest level, term(L) = max(T(L), (1 + r)·term(L + 1)),
  /// so that, like the geometry errors, it shrinks by at least 1 + r per level (the two bintree
  /// levels that share a tile level would otherwise share a term, and the morph windows of
  /// docs/architecture.md "Geomorphing" would touch there).
  double textureTermOfLevel(int level) const noexcept {
    return textureTerm_[static_cast<std::size_t>(level)];
  }

  /// The largest vertex and triangle counts of any patch (pool slot sizes).
  /// @{
  std::uint32_t maxPatchVertices() const noexcept { return maxPatchVertices_; }
  std::uint32_t maxPatchTriangles() const noexcept { return maxPatchTriangles_; }
  /// @}

 private:
  formats::Manifest manifest_;
  Planet planet_ = Planet::mars();
  std::array<formats::FaceView, 6> faces_;
  std::vector<double> textureErrorOfLevel_;
  std::vector<double> textureTerm_;  ///< per bintree level 0..depth
  std::uint32_t maxPatchVertices_ = 0;
  std::uint32_t maxPatchTriangles_ = 0;
};

}  // namespace pbdam::runtime
