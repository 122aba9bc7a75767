// Face-file header, node and texture records (DatasetFormat.h, FORMAT.md).
#include "pbdam/formats/DatasetFormat.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cstring>
#include <limits>
#include <mutex>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/formats/MemoryMapping.h"

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

/// Where the heap index and the flags lie in a record of each table.
constexpr std::size_t kNodeHeapField = 176;
constexpr std::size_t kNodeFlagsField = 172;
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
  w.put(t.normalBytes);
}

TextureRecord decodeTextureRecord(std::span<const std::byte, kTextureRecordBytes> bytes) noexcept {
  Reader r(bytes);
  TextureRecord t;
  t.blobOffset = r.get<std::uint64_t>();
  t.blobBytes = r.get<std::uint32_t>();
  t.errorMeters = r.get<float>();
  t.heapIndex = r.get<std::uint64_t>();
  t.flags = r.get<std::uint32_t>();
  t.normalBytes = r.get<std::uint32_t>();
  return t;
}

/// The cache of a paged node table: chunks of kNodeTableChunkRows records, each checked on
/// every read from the file against the CRC-32 it had at open, in shards (chunk % kShards) of
/// slots with a lock and a clock hand each, so that threads refining at once rarely wait on
/// each other.
struct FaceView::NodePages {
  static constexpr std::size_t kShards = 8;
  static constexpr std::size_t kChunkBytes = kNodeTableChunkRows * kNodeRecordBytes;
  static constexpr std::uint32_t kNoSlot = std::numeric_limits<std::uint32_t>::max();
  static constexpr std::uint64_t kNoChunk = std::numeric_limits<std::uint64_t>::max();

  struct Shard {
    std::mutex mutex;
    std::vector<std::byte> slots;      ///< slot s: bytes [s·kChunkBytes, (s+1)·kChunkBytes)
    std::vector<std::uint64_t> chunk;  ///< per slot: the chunk it holds (or kNoChunk)
    std::vector<std::uint8_t> used;    ///< per slot: read since the hand last passed (clock)
    std::size_t filled = 0;
    std::size_t hand = 0;
  };

  std::span<const std::byte> file;
  std::uint64_t tableOffset = 0;
  std::uint64_t rows = 0;
  std::string context;
  std::vector<std::uint32_t> crc;        ///< per chunk, at open
  std::vector<std::uint64_t> firstHeap;  ///< per chunk: its first record's heap index
  std::vector<std::uint32_t> slotOf;     ///< per chunk: its slot in shard chunk % kShards
  std::array<Shard, kShards> shards;
  std::atomic<std::uint64_t> reads{0};
  std::atomic<bool> damaged{false};
  mutable std::mutex damageMutex;
  std::optional<Error> damage;

  NodePages(std::span<const std::byte> f, std::uint64_t offset, std::uint64_t rowCount,
            std::string name, std::uint64_t cacheBytes)
      : file(f), tableOffset(offset), rows(rowCount), context(std::move(name)) {
    const std::uint64_t chunks = (rows + kNodeTableChunkRows - 1) / kNodeTableChunkRows;
    crc.resize(chunks);
    firstHeap.resize(chunks);
    slotOf.assign(chunks, kNoSlot);
    // One slot a shard at least (the trees' check at open then reads some chunks twice: it
    // walks a node and its children further on at once).
    const std::uint64_t perShard = std::max<std::uint64_t>(1, cacheBytes / kChunkBytes / kShards);
    for (Shard& shard : shards) {
      shard.slots.resize(perShard * kChunkBytes);
      shard.chunk.assign(perShard, kNoChunk);
      shard.used.assign(perShard, 0);
    }
  }

  std::uint64_t chunkRows(std::uint64_t c) const noexcept {
    return std::min(kNodeTableChunkRows, rows - c * kNodeTableChunkRows);
  }

  void recordDamage(Error error) {
    const std::lock_guard<std::mutex> lock(damageMutex);
    if (!damage) damage = std::move(error);
    damaged.store(true, std::memory_order_release);
  }

  /// Calls use(bytes of chunk c) with chunk c in its shard (read from the file if it is not),
  /// under the shard's lock. False, without calling it, when the chunk cannot be read back as
  /// it was at open (the damage is recorded).
  template <typename Use>
  bool with(std::uint64_t c, Use&& use) {
    Shard& shard = shards[c % kShards];
    const std::lock_guard<std::mutex> lock(shard.mutex);
    std::uint32_t slot = slotOf[c];
    if (slot == kNoSlot) {
      const std::size_t count = shard.chunk.size();
      if (shard.filled < count) {
        slot = static_cast<std::uint32_t>(shard.filled++);
      } else {
        while (shard.used[shard.hand] != 0) {
          shard.used[shard.hand] = 0;
          shard.hand = (shard.hand + 1) % count;
        }
        slot = static_cast<std::uint32_t>(shard.hand);
        shard.hand = (shard.hand + 1) % count;
        if (shard.chunk[slot] != kNoChunk) slotOf[shard.chunk[slot]] = kNoSlot;
        shard.chunk[slot] = kNoChunk;
      }
      const std::span<std::byte> bytes =
          std::span(shard.slots).subspan(slot * kChunkBytes).first(chunkRows(c) * kNodeRecordBytes);
      const std::uint64_t offset = tableOffset + c * kChunkBytes;
      reads.fetch_add(1, std::memory_order_relaxed);
      if (auto r = readMapped(file, offset, bytes, context); !r) {
        recordDamage(std::move(r).error());
        return false;
      }
      if (crc32(bytes) != crc[c]) {
        recordDamage(corrupt(context, offset,
                             "node table rows " + std::to_string(c * kNodeTableChunkRows) + ".." +
                                 std::to_string(c * kNodeTableChunkRows + chunkRows(c) - 1) +
                                 " changed after the file was opened (checksum mismatch)"));
        return false;
      }
      shard.chunk[slot] = c;
      slotOf[c] = slot;
    }
    shard.used[slot] = 1;
    use(std::span<const std::byte>(shard.slots)
            .subspan(slot * kChunkBytes)
            .first(chunkRows(c) * kNodeRecordBytes));
    return true;
  }
};

Result<FaceView> FaceView::open(std::span<const std::byte> file, std::string context,
                                const FaceViewOptions& options) {
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
  if (auto r = view.readNodeTable(options); !r) return std::move(r).error();
  view.textureTable_.resize(h.textureNodeCount * kTextureRecordBytes);
  if (auto r = readMapped(file, h.textureTableOffset, view.textureTable_, view.context_); !r) {
    return std::move(r).error();
  }
  if (crc32(view.textureTable_) != h.textureTableCrc) {
    return corrupt(view.context_, h.textureTableOffset, "texture table checksum mismatch");
  }
  if (auto r = view.checkNodes(); !r) return std::move(r).error();
  if (auto r = view.checkTextures(); !r) return std::move(r).error();
  // Checking the trees read a paged table back once more: nothing may have changed meanwhile.
  if (auto damage = view.damage()) return std::move(*damage);
  return view;
}

Result<void> FaceView::readNodeTable(const FaceViewOptions& options) {
  const FaceHeader& h = header_;
  const std::uint64_t tableBytes = h.nodeCount * kNodeRecordBytes;
  const std::uint64_t words = (h.nodeCount + 63) / 64;
  innerBits_.assign(words, 0);
  innerBefore_.assign(words + 1, 0);
  const auto noteRows = [&](std::uint64_t firstRow, std::span<const std::byte> records) {
    for (std::uint64_t i = 0; i < records.size() / kNodeRecordBytes; ++i) {
      std::uint32_t flags = 0;
      std::memcpy(&flags, records.data() + i * kNodeRecordBytes + kNodeFlagsField, sizeof(flags));
      const std::uint64_t row = firstRow + i;
      if ((flags & kRecordLeaf) == 0) innerBits_[row / 64] |= std::uint64_t{1} << (row % 64);
    }
  };
  const auto countInner = [&] {
    for (std::uint64_t w = 0; w < words; ++w) {
      innerBefore_[w + 1] =
          innerBefore_[w] + static_cast<std::uint64_t>(std::popcount(innerBits_[w]));
    }
  };
  if (options.nodeCacheBytes == 0 || tableBytes <= options.nodeCacheBytes) {
    nodeTable_.resize(tableBytes);
    if (auto r = readMapped(file_, h.nodeTableOffset, nodeTable_, context_); !r) {
      return std::move(r).error();
    }
    if (crc32(nodeTable_) != h.nodeTableCrc) {
      return corrupt(context_, h.nodeTableOffset, "node table checksum mismatch");
    }
    noteRows(0, nodeTable_);
    countInner();
    return {};
  }
  // Paged: one pass over the table for its CRC, each chunk's CRC, each chunk's first heap index
  // and the rows' leaf flags; the records are read again when they are used.
  pages_ = std::make_shared<NodePages>(file_, h.nodeTableOffset, h.nodeCount, context_,
                                       options.nodeCacheBytes);
  NodePages& pages = *pages_;
  std::vector<std::byte> chunk(NodePages::kChunkBytes);
  std::uint32_t tableCrc = 0;
  for (std::uint64_t c = 0; c < pages.crc.size(); ++c) {
    const std::span<std::byte> bytes =
        std::span(chunk).first(pages.chunkRows(c) * kNodeRecordBytes);
    const std::uint64_t offset = h.nodeTableOffset + c * NodePages::kChunkBytes;
    if (auto r = readMapped(file_, offset, bytes, context_); !r) return std::move(r).error();
    tableCrc = crc32(bytes, tableCrc);
    pages.crc[c] = crc32(bytes);
    std::memcpy(&pages.firstHeap[c], bytes.data() + kNodeHeapField, sizeof(std::uint64_t));
    noteRows(c * kNodeTableChunkRows, bytes);
  }
  if (tableCrc != h.nodeTableCrc) {
    return corrupt(context_, h.nodeTableOffset, "node table checksum mismatch");
  }
  countInner();
  return {};
}

NodeRecord FaceView::nodeAt(std::uint64_t tableIndex) const noexcept {
  if (!pages_) {
    return decodeNodeRecord(std::span<const std::byte>(nodeTable_)
                                .subspan(tableIndex * kNodeRecordBytes)
                                .first<kNodeRecordBytes>());
  }
  NodeRecord record;
  const std::uint64_t c = tableIndex / kNodeTableChunkRows;
  const std::uint64_t row = tableIndex % kNodeTableChunkRows;
  const bool read = pages_->with(c, [&](std::span<const std::byte> bytes) {
    record = decodeNodeRecord(bytes.subspan(row * kNodeRecordBytes).first<kNodeRecordBytes>());
  });
  // An unreadable chunk: an empty leaf (nothing drawn below it); damage() says why.
  if (!read) record.flags = kRecordLeaf;
  return record;
}

bool FaceView::nodeRecordResident(std::uint64_t tableIndex) const noexcept {
  if (!pages_) return true;
  const std::uint64_t c = tableIndex / kNodeTableChunkRows;
  {
    NodePages::Shard& shard = pages_->shards[c % NodePages::kShards];
    const std::lock_guard<std::mutex> lock(shard.mutex);
    if (pages_->slotOf[c] != NodePages::kNoSlot) return true;
  }
  return pagesResident(file_.subspan(header_.nodeTableOffset + c * NodePages::kChunkBytes,
                                     pages_->chunkRows(c) * kNodeRecordBytes));
}

std::uint64_t FaceView::nodeChunkReads() const noexcept {
  return pages_ ? pages_->reads.load(std::memory_order_relaxed) : 0;
}

std::optional<Error> FaceView::damage() const {
  if (!pages_ || !pages_->damaged.load(std::memory_order_acquire)) return std::nullopt;
  const std::lock_guard<std::mutex> lock(pages_->damageMutex);
  return pages_->damage;
}

Result<void> FaceView::checkNodes() {
  // Each tree's records in ascending heap order are breadth-first: the root, then the children
  // of every inner node in the order of their parents (2k+1 and 2k+2 grow with k). One walk
  // checks that shape and records where each inner node's children are.
  const FaceHeader& h = header_;
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
      assert(firstChildOf(k) == next);
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
    const std::uint64_t blobs = t.blobsBytes();
    if (blobs != 0 && (t.blobOffset < h.blobsOffset || t.blobOffset > h.fileBytes ||
                       blobs > h.fileBytes - t.blobOffset)) {
      return where("points outside the blob area");
    }
    if (t.normalBytes != 0 && t.blobBytes == 0) return where("a normal map without a tile");
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
  std::uint64_t lo = treeFirstNode(tree);
  std::uint64_t hi = tree == 0 ? header_.tree1FirstNode : header_.nodeCount;
  if (!pages_)
    return findHeapIndex({nodeTable_, kNodeRecordBytes, kNodeHeapField}, lo, hi, heapIndex);
  // Paged: the chunks' first heap indices (held) narrow the search to one chunk, searched in
  // the cache. Chunk c starts at row 64c; those starting inside [lo, hi) are ascending.
  const std::uint64_t rows = kNodeTableChunkRows;
  const std::uint64_t cLo = (lo + rows - 1) / rows;
  const std::uint64_t cHi = (hi + rows - 1) / rows;  // chunks starting before hi
  const auto begin = pages_->firstHeap.begin();
  const auto after = std::upper_bound(begin + static_cast<std::ptrdiff_t>(cLo),
                                      begin + static_cast<std::ptrdiff_t>(cHi), heapIndex);
  if (after != begin + static_cast<std::ptrdiff_t>(cLo)) {
    const auto c = static_cast<std::uint64_t>(after - begin) - 1;
    lo = std::max(lo, c * rows);
    hi = std::min(hi, (c + 1) * rows);
  } else {
    hi = std::min(hi, cLo * rows);
  }
  if (lo >= hi) return std::nullopt;
  const std::uint64_t c = lo / rows;
  std::optional<std::uint64_t> found;
  pages_->with(c, [&](std::span<const std::byte> bytes) {
    const HeapIndexedTable table{bytes, kNodeRecordBytes, kNodeHeapField};
    std::uint64_t a = lo - c * rows;
    std::uint64_t b = hi - c * rows;
    while (a < b) {
      const std::uint64_t mid = a + (b - a) / 2;
      const std::uint64_t at = table.heapAt(mid);
      if (at == heapIndex) {
        found = c * rows + mid;
        return;
      }
      if (at < heapIndex) {
        a = mid + 1;
      } else {
        b = mid;
      }
    }
  });
  return found;
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

Result<TextureBlobs> FaceView::readTextureBlobs(const TextureRecord& t,
                                                std::vector<std::byte>& buffer) const {
  auto both = readBlob(t.blobOffset, t.blobsBytes(), buffer);
  if (!both) return std::move(both).error();
  return TextureBlobs{both->first(t.blobBytes), both->subspan(t.blobBytes)};
}

}  // namespace pbdam::formats
