// The on-disk layout of a P-BDAM face file (formats/FORMAT.md): a fixed header, the node table
// (fixed-size records of the nodes that exist of both bintrees of the face, each tree in
// ascending heap order — breadth-first, so top-down refinement reads it front to back; a node
// either has both children or is a leaf, flagged, so a forest may be deeper in one place than
// in another), the texture table (the quadtree's tiles that exist, in ascending heap order, each
// with none or all four children), then patch and texture blobs. Little-endian. Decoding is safe
// for untrusted bytes: every offset and size is checked against the file, the shape of both
// trees is checked when a file opens, and the header and tables carry CRC-32s.
// Thread-safety: pure functions and values; FaceView is read-only over caller-owned bytes.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The face-file version this build writes and reads (FaceHeader::version); others are refused.
inline constexpr std::uint32_t kDatasetFormatVersion = 5;
/// Bytes of a face file's header, at offset 0.
inline constexpr std::size_t kFaceHeaderBytes = 128;
/// Bytes of one node-table record (NodeRecord).
inline constexpr std::size_t kNodeRecordBytes = 192;
/// Bytes of one texture-table record (TextureRecord).
inline constexpr std::size_t kTextureRecordBytes = 32;
/// Deepest bintree level a face file may declare (heap indices below 2^(depth+1)).
inline constexpr std::uint32_t kMaxBintreeDepth = 40;
/// Most texture quadtree levels (heap indices below 4^levels).
inline constexpr std::uint32_t kMaxTextureLevels = 24;
/// Record flag: the node or tile has no children (refinement stops here).
inline constexpr std::uint32_t kRecordLeaf = 1;

/// The header of one face file.
struct FaceHeader final {
  std::uint32_t version = kDatasetFormatVersion;  ///< kDatasetFormatVersion
  std::uint32_t face = 0;                         ///< 0..5 (runtime/CubeMap.h)
  std::uint32_t latticeCells = 0;                 ///< N: lattice cells per face side
  std::uint32_t leafCells = 0;                    ///< L: leaf leg length in cells
  std::uint32_t depth = 0;                        ///< D: deepest bintree level (the deepest leaves)
  std::uint32_t textureLevels = 0;                ///< quadtree levels 0 .. textureLevels−1
  std::uint32_t textureTileTexels = 0;            ///< texels on a tile's side, its border included
  std::uint32_t textureBorderTexels = 0;          ///< texels of border on each side of a tile
  std::uint64_t nodeCount = 0;  ///< records of both trees (2 · (2^(D+1) − 1) when complete)
  std::uint64_t nodeTableOffset = 0;     ///< byte offset of the node table (128, after the header)
  std::uint64_t textureNodeCount = 0;    ///< tiles ((4^textureLevels − 1) / 3 when complete)
  std::uint64_t textureTableOffset = 0;  ///< byte offset of the texture table
  std::uint64_t blobsOffset = 0;         ///< byte offset of the first blob (page-aligned)
  std::uint64_t fileBytes = 0;           ///< the file's size; must equal it
  std::uint32_t nodeTableCrc = 0;        ///< CRC-32 of the node table
  std::uint32_t textureTableCrc = 0;     ///< CRC-32 of the texture table
  std::uint64_t tree1FirstNode = 0;      ///< table index of tree 1's root (tree 0's node count)
};

/// One bintree node: corners, bounding sphere, errors, and where its patch blob is.
struct NodeRecord final {
  std::array<double, 9> cornerPositions{};  ///< P0 (apex), P1 (left), P2 (right), planetocentric m
  std::array<float, 9> cornerNormals{};     ///< N0, N1, N2 (unit surface normals)
  std::array<double, 3> sphereCenter{};     ///< saturated: shared by diamond partners, nested
  float sphereRadiusMeters = 0.0f;          ///< the bounding sphere's radius, rounded up
  float errorMeters = 0.0f;                 ///< saturated object-space error
  float measuredErrorMeters = 0.0f;         ///< the patch's own measured error
  float minHeightMeters = 0.0f;             ///< of its vertices
  float maxHeightMeters = 0.0f;             ///< of its vertices
  std::uint64_t blobOffset = 0;             ///< from the start of the file
  std::uint32_t blobBytes = 0;              ///< bytes of the patch blob (PatchCodec.h)
  std::uint32_t vertexCount = 0;            ///< vertices of the patch
  std::uint32_t triangleCount = 0;          ///< triangles of the patch
  std::uint32_t flags = 0;                  ///< kRecordLeaf
  std::uint64_t heapIndex = 0;              ///< within its tree
  /// Of a leaf of a dataset with insets: the sources its stored error was measured against,
  /// bit 0 the base DEM, bit 1 + i the manifest's inset i; 0 otherwise.
  std::uint32_t sources = 0;
  /// Bytes of the patch's morph-target blob (PatchCodec.h), stored right after its patch blob;
  /// 0 for a root, whose targets are its own heights.
  std::uint32_t morphBytes = 0;
  /// The bytes of its patch blob and morph-target blob together (adjacent in the file).
  std::uint64_t blobsBytes() const noexcept { return std::uint64_t{blobBytes} + morphBytes; }
  /// Whether the node has no children (kRecordLeaf).
  bool leaf() const noexcept { return (flags & kRecordLeaf) != 0; }
};

/// One texture quadtree node: its colour tile blob, its normal-map tile blob (stored right after
/// the colour tile) and its texture error.
struct TextureRecord final {
  std::uint64_t blobOffset = 0;  ///< of the colour tile blob, from the start of the file
  std::uint32_t blobBytes = 0;   ///< bytes of the colour tile blob (TextureTile.h)
  float errorMeters = 0.0f;      ///< largest texel footprint on the ground
  std::uint64_t heapIndex = 0;   ///< textureHeapIndex(level, qi, qj)
  std::uint32_t flags = 0;       ///< kRecordLeaf
  /// Bytes of the normal-map tile blob, which starts at blobOffset + blobBytes (version 5).
  std::uint32_t normalBytes = 0;
  /// The bytes of both blobs together (adjacent in the file).
  std::uint64_t blobsBytes() const noexcept { return std::uint64_t{blobBytes} + normalBytes; }
  /// Whether the tile has no children (kRecordLeaf).
  bool leaf() const noexcept { return (flags & kRecordLeaf) != 0; }
};

/// Serialises into exactly k*Bytes bytes (the header's own CRC is computed here).
/// @{
void encodeFaceHeader(const FaceHeader& header,
                      std::span<std::byte, kFaceHeaderBytes> out) noexcept;
void encodeNodeRecord(const NodeRecord& record,
                      std::span<std::byte, kNodeRecordBytes> out) noexcept;
void encodeTextureRecord(const TextureRecord& record,
                         std::span<std::byte, kTextureRecordBytes> out) noexcept;
/// @}

/// Decodes a header: magic, version, CRC, and internal consistency (counts within what the depth
/// and texture levels allow, tables and blobs lie in order inside `fileBytes`). `context` names
/// the file.
Result<FaceHeader> decodeFaceHeader(std::span<const std::byte> bytes, std::string_view context);
/// The same for a header's bytes held apart from its file (`bytes` its first 128 bytes or
/// fewer, `fileBytes` the file's size).
Result<FaceHeader> decodeFaceHeader(std::span<const std::byte> bytes, std::uint64_t fileBytes,
                                    std::string_view context);
/// Decodes a table record as it is, without checks: the table's CRC and the trees' shape are
/// checked as a whole when a file opens (FaceView::open).
/// @{
NodeRecord decodeNodeRecord(std::span<const std::byte, kNodeRecordBytes> bytes) noexcept;
TextureRecord decodeTextureRecord(std::span<const std::byte, kTextureRecordBytes> bytes) noexcept;
/// @}

/// A node's patch blob and its morph-target blob, read together (they are adjacent in the file).
struct PatchBlobs final {
  std::span<const std::byte> patch;  ///< the patch blob (PatchCodec.h)
  std::span<const std::byte> morph;  ///< empty when the node has none
};

/// A tile's two blobs, read together (FaceView::readTextureBlobs).
struct TextureBlobs final {
  std::span<const std::byte> colour;  ///< the colour tile blob (TextureTile.h)
  std::span<const std::byte> normal;  ///< the normal-map tile blob; empty when the tile has none
};

/// How a FaceView holds its node table.
struct FaceViewOptions final {
  /// 0 (the default): the whole node table is copied out at open. Otherwise the most bytes of
  /// node-table copies the view may hold: a larger table is paged — read back from the file a
  /// chunk of kNodeTableChunkRows records at a time into a cache of this many bytes (at least
  /// one chunk per shard), each chunk checked against the CRC-32 it had when the file opened.
  std::uint64_t nodeCacheBytes = 0;
};

/// Records per chunk of a paged node table.
inline constexpr std::uint64_t kNodeTableChunkRows = 64;

/// A validated, read-only view of a whole face file held in memory or mapped. The header and
/// both tables are read out of the file when it opens (through guarded copies, GuardedCopy.h)
/// and checked against their CRC-32s; records are decoded from those copies, never from the
/// file again. A node table larger than FaceViewOptions::nodeCacheBytes is the exception: it is
/// read whole once at open (its CRC, each chunk's CRC and the trees' shape checked), and
/// later read back chunk by chunk into a bounded cache, each chunk checked against its CRC
/// from open. Should a chunk no longer read back as it was (the file truncated or rewritten
/// under the mapping, a disk error), nodeAt() returns an empty leaf (no patch) and damage()
/// names the file, offset and cause from then on: frame loops check it and stop with that
/// error. Blobs are copied out on each read (guarded too): a truncated or unreadable file is an
/// error naming it and the offset, never a SIGBUS. Thread-safety: const members from any
/// thread; the file's bytes must outlive the view.
class FaceView final {
 public:
  /// Copies and validates the header, both tables (CRCs), the shape of both bintrees and of the
  /// texture quadtree (each tree's records in ascending heap order from its root, every node a
  /// leaf or followed in order by all its children, no level deeper than the header's), and that
  /// every node's and tile's blob lies inside the blob area. Errors are CorruptData naming
  /// `context` and the offset.
  static Result<FaceView> open(std::span<const std::byte> file, std::string context,
                               const FaceViewOptions& options = {});

  /// The file's header, as checked at open.
  const FaceHeader& header() const noexcept { return header_; }
  /// The name of the file in error messages (open's `context`).
  const std::string& context() const noexcept { return context_; }
  /// Whether both bintrees are complete to the header's depth (every leaf at depth D).
  bool completeForest() const noexcept;
  /// Table index of tree `tree`'s root (0 or header().tree1FirstNode).
  std::uint64_t treeFirstNode(std::uint32_t tree) const noexcept {
    return tree == 0 ? 0 : header_.tree1FirstNode;
  }
  /// Table index of node `heapIndex` of tree `tree`, if the tree has it.
  std::optional<std::uint64_t> findNode(std::uint32_t tree, std::uint64_t heapIndex) const noexcept;
  /// Node `heapIndex` of tree `tree` (0 or 1); the node must exist (findNode).
  NodeRecord node(std::uint32_t tree, std::uint64_t heapIndex) const noexcept;
  /// The node at row `tableIndex` of the node table (below header().nodeCount); an empty leaf
  /// once a paged table has failed to read back (damage()).
  NodeRecord nodeAt(std::uint64_t tableIndex) const noexcept;
  /// Table index of the first child of the node at `tableIndex` (the second follows it); the
  /// node must not be a leaf.
  std::uint64_t firstChildOf(std::uint64_t tableIndex) const noexcept {
    // Children follow in the order of their parents (checked at open): the first child of the
    // k-th inner node of a tree is the tree's row 1 + 2k.
    const std::uint64_t first = tableIndex < header_.tree1FirstNode ? 0 : header_.tree1FirstNode;
    return first + 1 + 2 * (innerRowsBefore(tableIndex) - innerRowsBefore(first));
  }
  /// Whether nodeAt(tableIndex) can be answered without reading the disk: always for a table
  /// held whole; for a paged one, when its chunk is cached or its pages are in the page cache
  /// (mincore).
  bool nodeRecordResident(std::uint64_t tableIndex) const noexcept;
  /// Whether the node table is paged (FaceViewOptions::nodeCacheBytes) rather than held whole.
  bool nodeTablePaged() const noexcept { return pages_ != nullptr; }
  /// Chunks of a paged node table read from the file since open (0 when held whole).
  std::uint64_t nodeChunkReads() const noexcept;
  /// The first failure to read a chunk of a paged node table back as it was at open (the file
  /// changed or became unreadable under the view); nullopt while there is none.
  std::optional<Error> damage() const;
  /// Copies the patch blob of a node into `buffer` (resized to fit) and returns it (empty when
  /// the node has none). CorruptData naming the file and offset when the blob's bytes cannot be
  /// read (the file was truncated under its mapping, or its disk failed). The blob's own CRC is
  /// for its decoder to check.
  Result<std::span<const std::byte>> readPatchBlob(const NodeRecord& node,
                                                   std::vector<std::byte>& buffer) const;
  /// Table index of tile `heapIndex`, if the quadtree has it.
  std::optional<std::uint64_t> findTexture(std::uint64_t heapIndex) const noexcept;
  /// Copies a node's patch blob and morph-target blob into `buffer` in one read; errors as for
  /// readPatchBlob.
  Result<PatchBlobs> readPatchBlobs(const NodeRecord& node, std::vector<std::byte>& buffer) const;
  /// Tile `heapIndex`; the tile must exist (findTexture).
  TextureRecord textureNode(std::uint64_t heapIndex) const noexcept;
  /// The tile at row `tableIndex` of the texture table (below header().textureNodeCount).
  TextureRecord textureAt(std::uint64_t tableIndex) const noexcept;
  /// Copies a tile's colour and normal-map blobs into `buffer` in one read; errors as for
  /// readPatchBlob.
  Result<TextureBlobs> readTextureBlobs(const TextureRecord& record,
                                        std::vector<std::byte>& buffer) const;
  /// Byte offset of a table entry in the file (for error messages and prefetch).
  std::uint64_t nodeRecordOffset(std::uint64_t tableIndex) const noexcept {
    return header_.nodeTableOffset + tableIndex * kNodeRecordBytes;
  }

 private:
  Result<std::span<const std::byte>> readBlob(std::uint64_t offset, std::uint64_t bytes,
                                              std::vector<std::byte>& buffer) const;
  struct NodePages;
  Result<void> readNodeTable(const FaceViewOptions& options);
  Result<void> checkNodes();
  Result<void> checkTextures();
  /// Rows with children among rows [0, row).
  std::uint64_t innerRowsBefore(std::uint64_t row) const noexcept {
    const std::uint64_t word = row / 64;
    const std::uint64_t below = (std::uint64_t{1} << (row % 64)) - 1;
    return word < innerBits_.size()
               ? innerBefore_[word] +
                     static_cast<std::uint64_t>(std::popcount(innerBits_[word] & below))
               : innerBefore_.back();
  }
  FaceHeader header_;
  std::span<const std::byte> file_;
  std::string context_;
  std::vector<std::byte> nodeTable_;     ///< copied and CRC-checked at open (unless paged)
  std::shared_ptr<NodePages> pages_;     ///< the paged node table's cache, shared by copies
  std::vector<std::byte> textureTable_;  ///< copied and CRC-checked at open
  /// Bit r % 64 of word r / 64: row r has children (from the records' leaf flags at open).
  std::vector<std::uint64_t> innerBits_;
  /// Rows with children before row 64·w, for w up to innerBits_.size() (one more entry).
  std::vector<std::uint64_t> innerBefore_;
};

/// The level of texture heap index `heapIndex` (0 for the root, 1 for 1..4, …).
inline std::uint32_t textureLevelOfHeap(std::uint64_t heapIndex) noexcept {
  return static_cast<std::uint32_t>((std::bit_width(3 * heapIndex + 1) - 1) / 2);
}

/// Heap index of texture quadtree node (level, qi, qj): (4^level − 1)/3 + qj·2^level + qi.
inline std::uint64_t textureHeapIndex(std::uint32_t level, std::uint32_t qi,
                                      std::uint32_t qj) noexcept {
  return ((std::uint64_t{1} << (2 * level)) - 1) / 3 + (static_cast<std::uint64_t>(qj) << level) +
         qi;
}

}  // namespace pbdam::formats
