// Build checkpoints (docs/builder.md "Checkpoints"): after each completed bintree level the build
// keeps that level's node records and patch blobs and the state the next level needs in
// OUT/.build-checkpoint/ — one part file per rank, streamed while the rank works — so that
// `pbdam build --resume` restarts after the last completed level and still writes identical
// bytes. The same files are how the ranks hand a level's patches to the next level and how the
// build keeps them out of memory. Also the exact byte serialisation used in these files and in
// the MPI exchanges. Thread-safety: plain values and functions; a writer belongs to one thread.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Result.h"
#include "pbdam/streaming/MappedFile.h"

namespace pbdam::builder {

static_assert(std::endian::native == std::endian::little, "checkpoints are little-endian");

/// Appends plain values and byte runs to a buffer (host = little-endian, checked above).
class ByteWriter final {
 public:
  template <typename T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void putBytes(std::span<const std::byte> run) {
    bytes_.insert(bytes_.end(), run.begin(), run.end());
  }
  std::vector<std::byte>& bytes() noexcept { return bytes_; }
  std::vector<std::byte> take() noexcept { return std::move(bytes_); }

 private:
  std::vector<std::byte> bytes_;
};

/// Reads what ByteWriter wrote. Reading past the end sets failed() and returns zeros/empty
/// runs, so a damaged buffer is detected once at the end instead of at every read.
class ByteReader final {
 public:
  explicit ByteReader(std::span<const std::byte> bytes) noexcept : bytes_(bytes) {}
  template <typename T>
  T get() noexcept {
    static_assert(std::is_trivially_copyable_v<T>);
    T value{};
    if (bytes_.size() - at_ < sizeof(T)) {
      failed_ = true;
      at_ = bytes_.size();
      return value;
    }
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  std::span<const std::byte> take(std::size_t n) noexcept {
    if (bytes_.size() - at_ < n) {
      failed_ = true;
      at_ = bytes_.size();
      return {};
    }
    auto run = bytes_.subspan(at_, n);
    at_ += n;
    return run;
  }
  bool failed() const noexcept { return failed_; }
  bool atEnd() const noexcept { return at_ == bytes_.size(); }
  std::size_t offset() const noexcept { return at_; }

 private:
  std::span<const std::byte> bytes_;
  std::size_t at_ = 0;
  bool failed_ = false;
};

/// Writes one file through a temporary name in the same directory (docs/architecture.md "Formats"):
/// bytes are appended (buffered), finish() fsyncs and renames. Destroyed unfinished, it removes the
/// temporary. Keeps the CRC-32 of everything appended. A file whose head depends on what follows
/// it (a face file's header and node table) leaves that head as a prefix, appends the rest, then
/// writes the prefix in place: nothing of the file need be held in memory whole.
class AtomicFileWriter final {
 public:
  static formats::Result<AtomicFileWriter> create(const std::filesystem::path& path);
  AtomicFileWriter() = default;
  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  /// Appends `bytes`. Errors name the file: ErrorCode::NoSpace when the disk is full or the
  /// file-size limit is reached (formats/FileWrite.h), IoError otherwise.
  formats::Result<void> append(std::span<const std::byte> bytes);
  /// Reserves the file's blocks for `bytes` bytes up front (posix_fallocate), so that a file of
  /// known size fails at once, naming the size it needs, when it cannot fit.
  formats::Result<void> reserve(std::uint64_t bytes);
  /// Leaves the file's first `bytes` to be written later (writePrefix), before anything is
  /// appended; appends then go after them.
  formats::Result<void> leavePrefix(std::uint64_t bytes);
  /// Writes `bytes` at `offset` inside the prefix (pwrite; any order, each byte once).
  formats::Result<void> writePrefix(std::uint64_t offset, std::span<const std::byte> bytes);
  /// Says the prefix is written and gives its CRC-32 (of all its bytes in file order), which
  /// crc() then includes.
  void prefixWritten(std::uint32_t prefixCrc) noexcept;
  /// Bytes of the file so far (the prefix and what was appended).
  std::uint64_t size() const noexcept { return size_; }
  /// CRC-32 of the file: of what was appended, and of the prefix before it once prefixWritten.
  std::uint32_t crc() const noexcept { return crc_; }
  /// Flushes, fsyncs, closes and renames the temporary to the path. Internal error when a
  /// prefix was left and never said written.
  formats::Result<void> finish();

 private:
  formats::Result<void> flush();
  void abandon() noexcept;
  std::filesystem::path path_;
  std::filesystem::path tmp_;
  int fd_ = -1;
  std::vector<std::byte> buffer_;
  std::uint64_t size_ = 0;
  std::uint64_t reserved_ = 0;
  std::uint64_t prefix_ = 0;  ///< the prefix's bytes
  bool prefixPending_ = false;
  std::uint32_t crc_ = 0;
};

/// Writes `chunks` to `path` through a temporary file in the same directory, fsync and rename
/// (docs/architecture.md "Formats"); `crc` receives the CRC-32 of the whole file.
formats::Result<void> writeFileAtomically(const std::filesystem::path& path,
                                          const std::vector<std::span<const std::byte>>& chunks,
                                          std::uint32_t& crc);
/// fsync of a directory (makes renames inside it durable).
void syncDirectory(const std::filesystem::path& dir);

/// What the checkpoint directory says about the build it belongs to.
struct CheckpointState final {
  /// The options and inputs that determine the output bytes, as (name, value) in a fixed order.
  std::vector<std::pair<std::string, std::string>> fingerprint;
  /// The lowest (coarsest) bintree level whose nodes are all checkpointed, if any; levels
  /// complete from the leaves (depth) towards the roots (0).
  std::optional<int> completeLevel;
  bool textureComplete = false;
  /// The number of part files (the rank count that wrote them) of each complete level and of
  /// the textures.
  std::map<int, std::uint32_t> levelParts;
  std::uint32_t textureParts = 0;
  /// The assembly has begun freeing the level files' pages: they can no longer be resumed from.
  bool assemblyFreedLevels = false;
};

/// The first line of the state file.
inline constexpr std::string_view kCheckpointStateHeader = "pbdam-build-checkpoint 4";
/// Parses the text of a state file; CorruptData naming `where` and the bad line otherwise.
formats::Result<CheckpointState> parseCheckpointState(std::string_view text,
                                                      const std::string& where);

/// The checkpoint directory OUT/.build-checkpoint and its files.
class Checkpoint final {
 public:
  static constexpr const char* kDirectoryName = ".build-checkpoint";
  /// File kinds (the header says which, so a renamed file is caught).
  enum class Kind : std::uint32_t { Nodes = 1, Carry = 2, Texture = 3 };

  explicit Checkpoint(const std::filesystem::path& outDir) : dir_(outDir / kDirectoryName) {}
  const std::filesystem::path& directory() const noexcept { return dir_; }

  /// The state file, or nullopt when there is no checkpoint. Errors: unreadable or damaged.
  formats::Result<std::optional<CheckpointState>> readState() const;
  /// Replaces the state file atomically.
  formats::Result<void> writeState(const CheckpointState& state) const;
  /// Removes the directory and everything in it, then (with `recreate`) makes it empty.
  formats::Result<void> reset(bool recreate) const;

  /// Path of part `part` of the file of `kind` for `level` (level is ignored for Texture),
  /// e.g. level-03.part-1.nodes.
  std::filesystem::path file(Kind kind, int level, std::uint32_t part = 0) const;
  /// The resampled lattice heights (SampleGrid::writeHeightRows) and the bucketed source samples
  /// of DEM row range `part` (SampleGrid::writeSourceBuckets).
  std::filesystem::path heightsFile() const { return dir_ / "heights.f32"; }
  std::filesystem::path samplesFile(std::uint32_t part) const;

  /// Streams part `part` of `parts` of a checkpoint file: payload appended in pieces, then a
  /// trailer (magic, kind, level, part, parts, payload size) and the CRC-32 of all of it.
  class PartWriter final {
   public:
    PartWriter() = default;
    formats::Result<void> append(std::span<const std::byte> bytes) { return file_.append(bytes); }
    /// Payload bytes so far (the offset of the next append).
    std::uint64_t size() const noexcept { return file_.size(); }
    formats::Result<void> finish();

   private:
    friend class Checkpoint;
    AtomicFileWriter file_;
    Kind kind_ = Kind::Nodes;
    int level_ = 0;
    std::uint32_t part_ = 0;
    std::uint32_t parts_ = 1;
  };
  formats::Result<PartWriter> startFile(Kind kind, int level, std::uint32_t part,
                                        std::uint32_t parts) const;
  /// Maps a part file and checks its trailer (and, with `verify`, its CRC: a read of the whole
  /// file, after which its pages are released from this process); `payload` is its payload
  /// inside the returned mapping.
  formats::Result<streaming::MappedFile> openFile(Kind kind, int level, std::uint32_t part,
                                                  std::span<const std::byte>& payload,
                                                  bool verify = true) const;
  /// Removes every part of one file (missing is fine).
  void removeFile(Kind kind, int level, std::uint32_t parts) const;

 private:
  std::filesystem::path dir_;
};

// ---- The trailer of the part files: magic PBDAMCKP, u32 version 5, u32 kind, i32 level, u32
// part, u32 parts, u32 0, u64 payload bytes; then the CRC-32 of payload and trailer.
inline constexpr std::size_t kPartTrailerBytes = 8 + 4 + 4 + 4 + 4 + 4 + 4 + 8;
/// The trailer of a part file whose payload has `payloadBytes` bytes (the CRC follows it).
std::vector<std::byte> encodePartTrailer(Checkpoint::Kind kind, int level, std::uint32_t part,
                                         std::uint32_t parts, std::uint64_t payloadBytes);
/// The payload size of a part file of `fileBytes` bytes whose last kPartTrailerBytes + 4 bytes
/// are `tail` (trailer and CRC, copied out of the file), checked as partPayload checks them.
formats::Result<std::size_t> partPayloadBytes(std::span<const std::byte> tail,
                                              std::size_t fileBytes, Checkpoint::Kind kind,
                                              int level, std::uint32_t part,
                                              const std::string& where);
/// The payload of the whole part file `bytes` after checking its trailer against `kind`,
/// `level` (not for Texture) and `part` (not the CRC); CorruptData naming `where` otherwise.
formats::Result<std::span<const std::byte>> partPayload(std::span<const std::byte> bytes,
                                                        Checkpoint::Kind kind, int level,
                                                        std::uint32_t part,
                                                        const std::string& where);

// ---- The payloads of the part files (docs/builder.md "Checkpoints"). Every byte of them is
// written and read here and nowhere else; a reader never trusts a count or offset it has not
// checked against the payload.

/// The footer of a level's nodes part file: what the rank's share of the level did. The same
/// bytes are what the ranks all-gather after the level for the log.
struct LevelPartFooter final {
  static constexpr std::size_t kBytes = std::size_t{7} * 8;  ///< seven 8-byte fields
  std::uint64_t firstDiamond = 0;  ///< the rank's first diamond of the level
  std::uint64_t diamonds = 0;      ///< how many it built
  std::uint64_t nodes = 0;         ///< their nodes (two a diamond, one a leaf without partner)
  std::uint64_t insertedPoints = 0;
  std::uint64_t halvesOverTarget = 0;
  std::uint64_t patchBytesRaw = 0;  ///< 8 bytes a vertex and 6 a triangle, uncompressed
  double seconds = 0.0;
};
/// Exactly LevelPartFooter::kBytes bytes.
std::vector<std::byte> encodeLevelPartFooter(const LevelPartFooter& footer);
/// Decodes what encodeLevelPartFooter wrote; `bytes` must be exactly kBytes long, else the
/// error names `where` and "truncated".
formats::Result<LevelPartFooter> decodeLevelPartFooter(std::span<const std::byte> bytes,
                                                       const std::string& where);

/// One node as a nodes part file holds it: id, the saturated record (without blob offset) and
/// the encoded patch.
struct NodeEntry final {
  std::uint64_t id = 0;
  std::span<const std::byte, formats::kNodeRecordBytes> record;
  std::span<const std::byte> blob;
};
/// Appends one node entry: u64 id, the record, u32 blob size, the blob.
void putNodeEntry(ByteWriter& w, std::uint64_t id,
                  std::span<const std::byte, formats::kNodeRecordBytes> record,
                  std::span<const std::byte> blob);

/// A nodes part file's payload: node entries, then the footer.
class LevelPartView final {
 public:
  /// Splits `payload` (from Checkpoint::openFile); `where` names the file in errors.
  static formats::Result<LevelPartView> parse(std::span<const std::byte> payload,
                                              std::string where);
  const LevelPartFooter& footer() const noexcept { return footer_; }
  /// Calls `visit(entry, bytesReadSoFar)` for each of the footer's `nodes` entries, in
  /// file order, stopping early when `visit` returns false. Errors: the entries do not fill
  /// the payload exactly ("truncated").
  template <typename Visit>
  formats::Result<void> forEachNode(Visit&& visit) const {
    ByteReader r(entries_);
    for (std::uint64_t k = 0; k < footer_.nodes; ++k) {
      const std::optional<NodeEntry> entry = nextEntry(r);
      if (!entry) break;
      if (!visit(*entry, r.offset())) break;
    }
    if (r.failed() || !r.atEnd()) return truncated();
    return {};
  }

 private:
  static std::optional<NodeEntry> nextEntry(ByteReader& r) noexcept;
  formats::Error truncated() const;
  std::span<const std::byte> entries_;
  LevelPartFooter footer_;
  std::string where_;
};

/// The footer of a texture part file (and what the ranks all-gather after the textures).
struct TexturePartFooter final {
  static constexpr std::size_t kBytes = std::size_t{3} * 8;  ///< three 8-byte fields
  std::uint64_t firstTile = 0;
  std::uint64_t tiles = 0;
  double seconds = 0.0;
};
std::vector<std::byte> encodeTexturePartFooter(const TexturePartFooter& footer);
/// Decodes exactly TexturePartFooter::kBytes bytes; the error names `where` and "incomplete".
formats::Result<TexturePartFooter> decodeTexturePartFooter(std::span<const std::byte> bytes,
                                                           const std::string& where);
/// Appends one tile entry: f32 texture error, u32 colour blob size, u32 normal-map blob size,
/// the colour blob, the normal-map blob.
void putTileEntry(ByteWriter& w, float textureErrorMeters, std::span<const std::byte> colour,
                  std::span<const std::byte> normal);
/// A texture part file's payload: tile entries, then the footer.
class TexturePartView final {
 public:
  static formats::Result<TexturePartView> parse(std::span<const std::byte> payload,
                                                std::string where);
  const TexturePartFooter& footer() const noexcept { return footer_; }
  /// Calls `visit(tileIndex, textureErrorMeters, colourBlob, normalBlob)` for the footer's tiles
  /// in order,
  /// stopping early when `visit` returns false. Errors: the entries do not fill the payload
  /// exactly ("incomplete").
  template <typename Visit>
  formats::Result<void> forEachTile(Visit&& visit) const {
    ByteReader r(entries_);
    for (std::uint64_t k = footer_.firstTile; k < footer_.firstTile + footer_.tiles; ++k) {
      const auto error = r.get<float>();
      const auto colourBytes = r.get<std::uint32_t>();
      const auto normalBytes = r.get<std::uint32_t>();
      const auto colour = r.take(colourBytes);
      const auto normal = r.take(normalBytes);
      if (r.failed() || !visit(k, error, colour, normal)) break;
    }
    if (r.failed() || !r.atEnd()) return incomplete();
    return {};
  }

 private:
  formats::Error incomplete() const;
  std::span<const std::byte> entries_;
  TexturePartFooter footer_;
  std::string where_;
};

/// What a level hands the next one for each of its nodes: the diamond's saturated error and
/// bounding sphere as stored (floats where the record stores floats).
struct CarrySaturation final {
  float errorMeters = 0.0f;
  glm::dvec3 sphereCenter{0.0};
  float sphereRadiusMeters = 0.0f;
  /// The largest leaf error under the diamond: what the lattice cannot do better than (its
  /// deviation from the source samples), which the parent's height target leaves room for.
  float floorMeters = 0.0f;
};
/// Appends one carry record: the saturation, a u8 flag, and with `patch` the working patch —
/// u32 point count, u8 width (2 when every coordinate and index fits 16 bits — always for
/// lattices up to 16384 cells and patches up to 65536 points — else 4), the points' (x, y), u32
/// index count, the indices; each value in `width` bytes (half the bytes of plain 32-bit
/// values: the carry of the first block level is most of the build's I/O and disk); then u32
/// count (0 or one a triangle) and the triangles' sample errors (float), which the parent's
/// errors are bounded through.
void putCarryRecord(ByteWriter& w, const CarrySaturation& saturation, const WorkPatch* patch);
/// Reads one carry record; with `patch` the record must hold a patch. False when it is damaged
/// (or has no patch that was asked for).
bool getCarryRecord(ByteReader& r, CarrySaturation& saturation, WorkPatch* patch);
/// The index that ends a carry part file: (node id, record offset) sorted by node id, then
/// their u64 count. `entries` is sorted here.
std::vector<std::byte> encodeCarryIndex(
    std::vector<std::pair<std::uint64_t, std::uint64_t>> entries);

/// One carry part file's payload: records, then the index. Thread-safe lookups.
class CarryPartView final {
 public:
  /// Checks the index against `payload`; `where` names the file in errors.
  static formats::Result<CarryPartView> parse(std::span<const std::byte> payload,
                                              const std::string& where);
  /// The offset of node `id`'s record, or nullopt when the part does not hold it.
  std::optional<std::uint64_t> offsetOf(std::uint64_t id) const noexcept;
  /// The record at `offset` (from offsetOf), as getCarryRecord.
  bool read(std::uint64_t offset, CarrySaturation& saturation, WorkPatch* patch) const;

 private:
  std::span<const std::byte> payload_;
  const std::byte* index_ = nullptr;
  std::uint64_t count_ = 0;
};

/// The carry of a finished level as the next level reads it: the level's part files mapped
/// read-only, so a rank finds the children of its own diamonds without holding the level.
/// Thread-safe lookups; open/close by one thread while no lookup runs.
class CarryReader final {
 public:
  /// Maps the `parts` carry part files of `level` (checking CRCs with `verify`).
  formats::Result<void> open(const Checkpoint& checkpoint, int level, std::uint32_t parts,
                             bool verify);
  void close() { parts_.clear(); }
  /// Drops the mappings' pages from this process.
  void releaseResident() const noexcept;
  /// Node `id`'s saturation and, with `patch`, its working patch, from the first part that
  /// holds the node. Returns false when no part holds it, and when its record is damaged.
  bool find(std::uint64_t id, CarrySaturation& saturation, WorkPatch* patch) const;

 private:
  struct Part {
    streaming::MappedFile file;
    CarryPartView view;
  };
  std::vector<Part> parts_;
};

/// "name" of the first fingerprint entry that differs between `saved` and `now` with both
/// values, as a message; nullopt when they are equal.
std::optional<std::string> fingerprintMismatch(
    const std::vector<std::pair<std::string, std::string>>& saved,
    const std::vector<std::pair<std::string, std::string>>& now);

}  // namespace pbdam::builder
