// A whole dataset as the runtime reads it: the manifest, the planet it names, and a validated
// view of each of the six face files over bytes someone else owns (streaming/MappedDataset maps
// them; tests may hold them in memory). Also the per-level figures refinement needs that are
// properties of the whole dataset rather than of one node. Thread-safety: read-only after open;
// any number of threads may use one view.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Bintree.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// Identifies one bintree node of a dataset: face, tree (0/1) and heap index.
struct NodeKey final {
  std::uint8_t face = 0;
  std::uint8_t tree = 0;
  std::uint64_t heap = 0;
  friend bool operator==(const NodeKey&, const NodeKey&) = default;
};

/// Identifies one texture quadtree node: face and heap index (formats/DatasetFormat.h).
struct TileKey final {
  std::uint8_t face = 0;
  std::uint64_t heap = 0;
  friend bool operator==(const TileKey&, const TileKey&) = default;
};

class DatasetView final {
 public:
  /// Validates the six faces against the manifest (lattice, depth, texture levels and sizes,
  /// file sizes). `faceBytes[f]` are the bytes of manifest.faces[f]; `directory` names the
  /// dataset in errors.
  static formats::Result<DatasetView> open(
      const formats::Manifest& manifest, const std::array<std::span<const std::byte>, 6>& faceBytes,
      const std::string& directory);

  const formats::Manifest& manifest() const noexcept { return manifest_; }
  const Planet& planet() const noexcept { return planet_; }
  const formats::FaceView& face(int f) const noexcept {
    return faces_[static_cast<std::size_t>(f)];
  }
  std::uint32_t latticeCells() const noexcept { return manifest_.latticeCells; }
  int depth() const noexcept { return static_cast<int>(manifest_.depth); }
  std::uint32_t textureLevels() const noexcept { return manifest_.textureLevels; }

  formats::NodeRecord node(const NodeKey& key) const noexcept {
    return faces_[key.face].node(key.tree, key.heap);
  }
  BinTriangle triangle(const NodeKey& key) const noexcept {
    return bintreeTriangle(manifest_.latticeCells, key.face, key.tree, key.heap);
  }
  formats::TextureRecord textureNode(const TileKey& key) const noexcept {
    return faces_[key.face].textureNode(key.heap);
  }

  /// The texture level drawn with a patch of geometry level `level`: the finest tile level
  /// whose square contains every level-`level` triangle, min(level/2, textureLevels − 1).
  std::uint32_t textureLevelOf(int level) const noexcept;
  /// The tile that patch `key` is drawn with and the lattice origin and side of its square.
  TileKey tileOf(const NodeKey& key) const noexcept;

  /// The largest texture error of any tile of texture level `t` on any face (metres): the
  /// texture term of the refinement criterion, the same for both triangles of a diamond.
  double textureErrorOfLevel(std::uint32_t t) const noexcept { return textureErrorOfLevel_[t]; }

  /// The largest vertex and triangle counts of any patch (pool slot sizes).
  std::uint32_t maxPatchVertices() const noexcept { return maxPatchVertices_; }
  std::uint32_t maxPatchTriangles() const noexcept { return maxPatchTriangles_; }

 private:
  formats::Manifest manifest_;
  Planet planet_ = Planet::mars();
  std::array<formats::FaceView, 6> faces_;
  std::vector<double> textureErrorOfLevel_;
  std::uint32_t maxPatchVertices_ = 0;
  std::uint32_t maxPatchTriangles_ = 0;
};

}  // namespace pbdam::runtime
