// Face-file header, node and texture records (DatasetFormat.h, FORMAT.md).
#include "pbdam/formats/DatasetFormat.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstring>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/GuardedCopy.h"

namespace pbdam::formats {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the dataset format is little-endian; a big-endian port must swap here");

constexpr std::array<char, 8> kMagic = {'P', 'B', 'D', 'A', 'M', 'F', 'C', '1'};

class Writer {
 public:
  explicit Writer(std::span<std::byte> out) : out_(out) {}
  template <typename T>
  void put(const T& value) noexcept {
    std::memcpy(out_.data() + at_, &value, sizeof(T));
    at_ += sizeof(T);
  }
  std::size_t at() const noexcept { return at_; }

 private:
  std::span<std::byte> out_;
  std::size_t at_ = 0;
};

class Reader {
 public:
  explicit Reader(std::span<const std::byte> in) : in_(in) {}
  template <typename T>
  T get() noexcept {
    T value{};
    std::memcpy(&value, in_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }

 private:
  std::span<const std::byte> in_;
  std::size_t at_ = 0;
};

/// Where the heap index lies in a record of each table.
constexpr std::size_t kNodeHeapField = 176;
constexpr std::size_t kTextureHeapField = 16;

/// A table copied out of a face file, as far as finding a record by heap index goes.
struct HeapIndexedTable {
  std::span<const std::byte> bytes;
  std::size_t recordBytes;
  std::size_t heapField;
  std::uint64_t heapAt(std::uint64_t row) const noexcept {
    std::uint64_t value = 0;
    std::memcpy(&value, bytes.data() + row * recordBytes + heapField, sizeof(value));
    return value;
  }
};

/// The row in [lo, hi) holding `heapIndex`, the rows' heap indices ascending.
std::optional<std::uint64_t> findHeapIndex(const HeapIndexedTable& table, std::uint64_t lo,
                                           std::uint64_t hi, std::uint64_t heapIndex) noexcept {
  // A tree complete down to this index's level holds it at its own position.
  if (heapIndex < hi - lo && table.heapAt(lo + heapIndex) == heapIndex) return lo + heapIndex;
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    const std::uint64_t at = table.heapAt(mid);
    if (at == heapIndex) return mid;
    if (at < heapIndex) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return std::nullopt;
}

Error corrupt(std::string_view context, std::uint64_t offset, const std::string& what) {
  return makeError(ErrorCode::CorruptData,
                   std::string(context) + " offset " + std::to_string(offset) + ": " + what);
}

}  // namespace

void encodeFaceHeader(const FaceHeader& h, std::span<std::byte, kFaceHeaderBytes> out) noexcept {
  std::memset(out.data(), 0, out.size());
  Writer w(out);
  for (char c : kMagic) w.put(c);
  w.put(h.version);
  w.put(h.face);
  w.put(h.latticeCells);
  w.put(h.leafCells);
  w.put(h.depth);
  w.put(h.textureLevels);
  w.put(h.textureTileTexels);
  w.put(h.textureBorderTexels);
  w.put(h.nodeCount);
  w.put(h.nodeTableOffset);
  w.put(h.textureNodeCount);
  w.put(h.textureTableOffset);
  w.put(h.blobsOffset);
  w.put(h.fileBytes);
  w.put(h.nodeTableCrc);
  w.put(h.textureTableCrc);
  w.put(h.tree1FirstNode);
  // The CRC of the first 124 bytes sits in the last 4.
  const std::uint32_t crc = crc32(std::span<const std::byte>(out.data(), kFaceHeaderBytes - 4));
  std::memcpy(out.data() + kFaceHeaderBytes - 4, &crc, 4);
}

Result<FaceHeader> decodeFaceHeader(std::span<const std::byte> bytes, std::string_view context) {
  return decodeFaceHeader(bytes.first(std::min(bytes.size(), kFaceHeaderBytes)), bytes.size(),
                          context);
}

Result<FaceHeader> decodeFaceHeader(std::span<const std::byte> bytes, std::uint64_t fileBytes,
                                    std::string_view context) {
  if (fileBytes < kFaceHeaderBytes || bytes.size() < kFaceHeaderBytes) {
    return corrupt(context, 0,
                   "file of " + std::to_string(fileBytes) + " bytes is shorter than the " +
                       std::to_string(kFaceHeaderBytes) + "-byte header");
  }
  if (std::memcmp(bytes.data(), kMagic.data(), kMagic.size()) != 0) {
    return corrupt(context, 0, "not a pbdam face file (bad magic)");
  }
  std::uint32_t storedCrc = 0;
  std::memcpy(&storedCrc, bytes.data() + kFaceHeaderBytes - 4, 4);
  if (crc32(bytes.first(kFaceHeaderBytes - 4)) != storedCrc) {
    return corrupt(context, 0, "header checksum mismatch");
  }
  Reader r(bytes.subspan(kMagic.size()));
  FaceHeader h;
  h.version = r.get<std::uint32_t>();
  h.face = r.get<std::uint32_t>();
  h.latticeCells = r.get<std::uint32_t>();
  h.leafCells = r.get<std::uint32_t>();
  h.depth = r.get<std::uint32_t>();
  h.textureLevels = r.get<std::uint32_t>();
  h.textureTileTexels = r.get<std::uint32_t>();
  h.textureBorderTexels = r.get<std::uint32_t>();
  h.nodeCount = r.get<std::uint64_t>();
  h.nodeTableOffset = r.get<std::uint64_t>();
  h.textureNodeCount = r.get<std::uint64_t>();
  h.textureTableOffset = r.get<std::uint64_t>();
  h.blobsOffset = r.get<std::uint64_t>();
  h.fileBytes = r.get<std::uint64_t>();
  h.nodeTableCrc = r.get<std::uint32_t>();
  h.textureTableCrc = r.get<std::uint32_t>();
  h.tree1FirstNode = r.get<std::uint64_t>();
  if (h.version != kDatasetFormatVersion) {
    return corrupt(context, 8,
                   "format version " + std::to_string(h.version) + " (this pbdam reads version " +
                       std::to_string(kDatasetFormatVersion) +
                       "); rebuild the dataset with this pbdam (pbdam build)");
  }
  if (h.face > 5) return corrupt(context, 12, "face index " + std::to_string(h.face));
  if (h.depth > kMaxBintreeDepth || h.textureLevels > kMaxTextureLevels) {
    return corrupt(context, 24, "bintree depth or texture levels out of range");
  }
  if (h.latticeCells == 0 || !std::has_single_bit(h.latticeCells) || h.leafCells == 0 ||
      !std::has_single_bit(h.leafCells) || h.leafCells > h.latticeCells) {
    return corrupt(context, 16, "lattice or leaf size is not a power of two");
  }
  // Each tree has between 1 node and a complete tree's; at least the root tile.
  const std::uint64_t completeTree = (std::uint64_t{1} << (h.depth + 1)) - 1;
  const std::uint64_t completeTextures = ((std::uint64_t{1} << (2 * h.textureLevels)) - 1) / 3;
  if (h.tree1FirstNode < 1 || h.tree1FirstNode > completeTree || h.nodeCount <= h.tree1FirstNode ||
      h.nodeCount - h.tree1FirstNode > completeTree || h.textureNodeCount < 1 ||
      h.textureNodeCount > completeTextures) {
    return corrupt(context, 40, "node counts do not fit the depth and texture levels");
  }
  if (h.fileBytes != fileBytes) {
    return corrupt(context, 80,
                   "header says " + std::to_string(h.fileBytes) + " bytes, the file has " +
                       std::to_string(fileBytes) + " (truncated or padded)");
  }
  // Counts are bounded above (depth and levels), so only the offsets can overflow a sum.
  if (h.nodeTableOffset > h.fileBytes || h.textureTableOffset > h.fileBytes) {
    return corrupt(context, 48, "tables overlap or lie outside the file");
  }
  const std::uint64_t nodeEnd = h.nodeTableOffset + h.nodeCount * kNodeRecordBytes;
  const std::uint64_t textureEnd = h.textureTableOffset + h.textureNodeCount * kTextureRecordBytes;
  if (h.nodeTableOffset < kFaceHeaderBytes || nodeEnd > h.textureTableOffset ||
      textureEnd > h.blobsOffset || h.blobsOffset > h.fileBytes) {
    return corrupt(context, 48, "tables overlap or lie outside the file");
  }
  return h;
}

void encodeNodeRecord(const NodeRecord& n, std::span<std::byte, kNodeRecordBytes> out) noexcept {
  std::memset(out.data(), 0, out.size());
  Writer w(out);
  for (double v : n.cornerPositions) w.put(v);
  for (float v : n.cornerNormals) w.put(v);
  for (double v : n.sphereCenter) w.put(v);
  w.put(n.sphereRadiusMeters);
  w.put(n.errorMeters);
  w.put(n.measuredErrorMeters);
  w.put(n.minHeightMeters);
  w.put(n.maxHeightMeters);
  w.put(n.blobOffset);
  w.put(n.blobBytes);
  w.put(n.vertexCount);
  w.put(n.triangleCount);
  w.put(n.flags);
  w.put(n.heapIndex);
  w.put(n.sources);
  w.put(n.morphBytes);
}

NodeRecord decodeNodeRecord(std::span<const std::byte, kNodeRecordBytes> bytes) noexcept {
  Reader r(bytes);
  NodeRecord n;
  for (double& v : n.cornerPositions) v = r.get<double>();
  for (float& v : n.cornerNormals) v = r.get<float>();
  for (double& v : n.sphereCenter) v = r.get<double>();
  n.sphereRadiusMeters = r.get<float>();
  n.errorMeters = r.get<float>();
  n.measuredErrorMeters = r.get<float>();
  n.minHeightMeters = r.get<float>();
  n.maxHeightMeters = r.get<float>();
  n.blobOffset = r.get<std::uint64_t>();
  n.blobBytes = r.get<std::uint32_t>();
  n.vertexCount = r.get<std::uint32_t>();
  n.triangleCount = r.get<std::uint32_t>();
  n.flags = r.get<std::uint32_t>();
  n.heapIndex = r.get<std::uint64_t>();
  n.sources = r.get<std::uint32_t>();
  n.morphBytes = r.get<std::uint32_t>();
  return n;
}

void encodeTextureRecord(const TextureRecord& t,
                         std::span<std::byte, kTextureRecordBytes> out) noexcept {
  std::memset(out.data(), 0, out.size());
  Writer w(out);
  w.put(t.blobOffset);
  w.put(t.blobBytes);
  w.put(t.errorMeters);
  w.put(t.heapIndex);
  w.put(t.flags);
}

TextureRecord decodeTextureRecord(std::span<const std::byte, kTextureRecordBytes> bytes) noexcept {
  Reader r(bytes);
  TextureRecord t;
  t.blobOffset = r.get<std::uint64_t>();
  t.blobBytes = r.get<std::uint32_t>();
  t.errorMeters = r.get<float>();
  t.heapIndex = r.get<std::uint64_t>();
  t.flags = r.get<std::uint32_t>();
  return t;
}

Result<FaceView> FaceView::open(std::span<const std::byte> file, std::string context) {
  // The header and both tables are copied out (guarded: a truncated or unreadable file is an
  // error here, not a SIGBUS) and checked against their CRCs once; records are decoded from
  // these copies from then on, so bytes rewritten in the file later are never drawn.
  std::array<std::byte, kFaceHeaderBytes> headerBytes{};
  const std::size_t headerRead = std::min(file.size(), kFaceHeaderBytes);
  if (auto r = readMapped(file, 0, std::span(headerBytes).first(headerRead), context); !r) {
    return std::move(r).error();
  }
  auto header = decodeFaceHeader(std::span(headerBytes).first(headerRead), file.size(), context);
  if (!header) return std::move(header).error();
  FaceView view;
  view.header_ = *header;
  view.file_ = file;
  view.context_ = std::move(context);
  const FaceHeader& h = view.header_;
  view.nodeTable_.resize(h.nodeCount * kNodeRecordBytes);
  if (auto r = readMapped(file, h.nodeTableOffset, view.nodeTable_, view.context_); !r) {
    return std::move(r).error();
  }
  if (crc32(view.nodeTable_) != h.nodeTableCrc) {
    return corrupt(view.context_, h.nodeTableOffset, "node table checksum mismatch");
  }
  view.textureTable_.resize(h.textureNodeCount * kTextureRecordBytes);
  if (auto r = readMapped(file, h.textureTableOffset, view.textureTable_, view.context_); !r) {
    return std::move(r).error();
  }
  if (crc32(view.textureTable_) != h.textureTableCrc) {
    return corrupt(view.context_, h.textureTableOffset, "texture table checksum mismatch");
  }
  if (auto r = view.checkNodes(); !r) return std::move(r).error();
  if (auto r = view.checkTextures(); !r) return std::move(r).error();
  return view;
}

NodeRecord FaceView::nodeAt(std::uint64_t tableIndex) const noexcept {
  return decodeNodeRecord(std::span<const std::byte>(nodeTable_)
                              .subspan(tableIndex * kNodeRecordBytes)
                              .first<kNodeRecordBytes>());
}

Result<void> FaceView::checkNodes() {
  // Each tree's records in ascending heap order are breadth-first: the root, then the children
  // of every inner node in the order of their parents (2k+1 and 2k+2 grow with k). One walk
  // checks that shape and records where each inner node's children are.
  const FaceHeader& h = header_;
  firstChild_.assign(h.nodeCount, 0);
  for (std::uint32_t tree = 0; tree < 2; ++tree) {
    const std::uint64_t first = treeFirstNode(tree);
    const std::uint64_t end = tree == 0 ? h.tree1FirstNode : h.nodeCount;
    std::uint64_t next = first + 1;  // the next record that must be a child
    for (std::uint64_t k = first; k < end; ++k) {
      const NodeRecord n = nodeAt(k);
      const auto where = [&](const std::string& what) {
        return corrupt(context_, nodeRecordOffset(k),
                       "node " + std::to_string(k) + " (tree " + std::to_string(tree) +
                           ", heap index " + std::to_string(n.heapIndex) + "): " + what);
      };
      if (k == first && n.heapIndex != 0) return where("a tree does not start at its root");
      if ((n.flags & ~kRecordLeaf) != 0) return where("unknown flags");
      if (n.sources != 0 && !n.leaf()) return where("sources on a node that is not a leaf");
      const std::uint64_t blobs = n.blobsBytes();
      if (blobs != 0 && (n.blobOffset < h.blobsOffset || n.blobOffset > h.fileBytes ||
                         blobs > h.fileBytes - n.blobOffset)) {
        return where("points outside the blob area");
      }
      if (n.morphBytes != 0 && n.blobBytes == 0) return where("morph targets without a patch");
      if (n.leaf()) continue;
      if (n.heapIndex >= (std::uint64_t{1} << h.depth) - 1) {
        return where("has children below the face's depth " + std::to_string(h.depth));
      }
      if (next + 2 > end || nodeAt(next).heapIndex != 2 * n.heapIndex + 1 ||
          nodeAt(next + 1).heapIndex != 2 * n.heapIndex + 2) {
        return where("its children are missing or out of order");
      }
      firstChild_[k] = next;
      next += 2;
    }
    if (next != end) {
      return corrupt(context_, nodeRecordOffset(next),
                     "node " + std::to_string(next) + " is not the child of a node before it");
    }
  }
  return {};
}

Result<void> FaceView::checkTextures() {
  // Ascending heap order, every tile but the root has an inner parent, and an inner tile has all
  // four children (row-major heap order puts them on two rows, so each is looked up).
  const FaceHeader& h = header_;
  for (std::uint64_t k = 0; k < h.textureNodeCount; ++k) {
    const TextureRecord t = textureAt(k);
    const auto where = [&](const std::string& what) {
      return corrupt(context_, h.textureTableOffset + k * kTextureRecordBytes,
                     "texture node " + std::to_string(k) + " (heap index " +
                         std::to_string(t.heapIndex) + "): " + what);
    };
    if ((k == 0) != (t.heapIndex == 0) || (k > 0 && textureAt(k - 1).heapIndex >= t.heapIndex)) {
      return where("tiles are not in ascending heap order from the root");
    }
    if ((t.flags & ~kRecordLeaf) != 0) return where("unknown flags");
    if (t.blobBytes != 0 && (t.blobOffset < h.blobsOffset || t.blobOffset > h.fileBytes ||
                             t.blobBytes > h.fileBytes - t.blobOffset)) {
      return where("points outside the blob area");
    }
    const std::uint32_t level = textureLevelOfHeap(t.heapIndex);
    if (level >= h.textureLevels) return where("deeper than the face's texture levels");
    const std::uint64_t inLevel = t.heapIndex - textureHeapIndex(level, 0, 0);
    const auto qi = static_cast<std::uint32_t>(inLevel & ((std::uint64_t{1} << level) - 1));
    const auto qj = static_cast<std::uint32_t>(inLevel >> level);
    if (level > 0) {
      const auto parent = findTexture(textureHeapIndex(level - 1, qi / 2, qj / 2));
      if (!parent || textureAt(*parent).leaf()) return where("its parent is missing or a leaf");
    }
    if (t.leaf()) continue;
    if (level + 1 >= h.textureLevels) return where("has children below the last texture level");
    for (std::uint32_t c = 0; c < 4; ++c) {
      if (!findTexture(textureHeapIndex(level + 1, 2 * qi + (c & 1), 2 * qj + (c >> 1)))) {
        return where("one of its four children is missing");
      }
    }
  }
  return {};
}

bool FaceView::completeForest() const noexcept {
  const std::uint64_t completeTree = (std::uint64_t{1} << (header_.depth + 1)) - 1;
  return header_.tree1FirstNode == completeTree && header_.nodeCount == 2 * completeTree;
}

std::optional<std::uint64_t> FaceView::findNode(std::uint32_t tree,
                                                std::uint64_t heapIndex) const noexcept {
  return findHeapIndex({nodeTable_, kNodeRecordBytes, kNodeHeapField}, treeFirstNode(tree),
                       tree == 0 ? header_.tree1FirstNode : header_.nodeCount, heapIndex);
}

NodeRecord FaceView::node(std::uint32_t tree, std::uint64_t heapIndex) const noexcept {
  const auto row = findNode(tree, heapIndex);
  assert(row);
  return row ? nodeAt(*row) : NodeRecord{};
}

std::optional<std::uint64_t> FaceView::findTexture(std::uint64_t heapIndex) const noexcept {
  return findHeapIndex({textureTable_, kTextureRecordBytes, kTextureHeapField}, 0,
                       header_.textureNodeCount, heapIndex);
}

Result<std::span<const std::byte>> FaceView::readBlob(std::uint64_t offset, std::uint64_t bytes,
                                                      std::vector<std::byte>& buffer) const {
  buffer.resize(bytes);
  if (auto r = readMapped(file_, offset, buffer, context_); !r) return std::move(r).error();
  return std::span<const std::byte>(buffer);
}

Result<std::span<const std::byte>> FaceView::readPatchBlob(const NodeRecord& n,
                                                           std::vector<std::byte>& buffer) const {
  return readBlob(n.blobOffset, n.blobBytes, buffer);
}

Result<PatchBlobs> FaceView::readPatchBlobs(const NodeRecord& n,
                                            std::vector<std::byte>& buffer) const {
  auto both = readBlob(n.blobOffset, n.blobsBytes(), buffer);
  if (!both) return std::move(both).error();
  return PatchBlobs{both->first(n.blobBytes), both->subspan(n.blobBytes)};
}

TextureRecord FaceView::textureAt(std::uint64_t tableIndex) const noexcept {
  return decodeTextureRecord(std::span<const std::byte>(textureTable_)
                                 .subspan(tableIndex * kTextureRecordBytes)
                                 .first<kTextureRecordBytes>());
}

TextureRecord FaceView::textureNode(std::uint64_t heapIndex) const noexcept {
  const auto row = findTexture(heapIndex);
  assert(row);
  return row ? textureAt(*row) : TextureRecord{};
}

Result<std::span<const std::byte>> FaceView::readTextureBlob(const TextureRecord& t,
                                                             std::vector<std::byte>& buffer) const {
  return readBlob(t.blobOffset, t.blobBytes, buffer);
}

}  // namespace pbdam::formats
