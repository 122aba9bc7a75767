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
#include <utility>
#include <vector>

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
/// temporary. Keeps the CRC-32 of everything appended.
class AtomicFileWriter final {
 public:
  static Result<AtomicFileWriter> create(const std::filesystem::path& path);
  AtomicFileWriter() = default;
  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter();

  Result<void> append(std::span<const std::byte> bytes);
  /// Bytes appended so far.
  std::uint64_t size() const noexcept { return size_; }
  std::uint32_t crc() const noexcept { return crc_; }
  /// Flushes, fsyncs, closes and renames the temporary to the path.
  Result<void> finish();

 private:
  Result<void> flush();
  void abandon() noexcept;
  std::filesystem::path path_;
  std::filesystem::path tmp_;
  int fd_ = -1;
  std::vector<std::byte> buffer_;
  std::uint64_t size_ = 0;
  std::uint32_t crc_ = 0;
};

/// Writes `chunks` to `path` through a temporary file in the same directory, fsync and rename
/// (docs/architecture.md "Formats"); `crc` receives the CRC-32 of the whole file.
Result<void> writeFileAtomically(const std::filesystem::path& path,
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
};

/// The checkpoint directory OUT/.build-checkpoint and its files.
class Checkpoint final {
 public:
  static constexpr const char* kDirectoryName = ".build-checkpoint";
  /// File kinds (the header says which, so a renamed file is caught).
  enum class Kind : std::uint32_t { Nodes = 1, Carry = 2, Texture = 3 };

  explicit Checkpoint(const std::filesystem::path& outDir) : dir_(outDir / kDirectoryName) {}
  const std::filesystem::path& directory() const noexcept { return dir_; }

  /// The state file, or nullopt when there is no checkpoint. Errors: unreadable or damaged.
  Result<std::optional<CheckpointState>> readState() const;
  /// Replaces the state file atomically.
  Result<void> writeState(const CheckpointState& state) const;
  /// Removes the directory and everything in it, then (with `recreate`) makes it empty.
  Result<void> reset(bool recreate) const;

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
    Result<void> append(std::span<const std::byte> bytes) { return file_.append(bytes); }
    /// Payload bytes so far (the offset of the next append).
    std::uint64_t size() const noexcept { return file_.size(); }
    Result<void> finish();

   private:
    friend class Checkpoint;
    AtomicFileWriter file_;
    Kind kind_ = Kind::Nodes;
    int level_ = 0;
    std::uint32_t part_ = 0;
    std::uint32_t parts_ = 1;
  };
  Result<PartWriter> startFile(Kind kind, int level, std::uint32_t part, std::uint32_t parts) const;
  /// Maps a part file and checks its trailer (and, with `verify`, its CRC: a read of the whole
  /// file, after which its pages are released from this process); `payload` is its payload
  /// inside the returned mapping.
  Result<MappedFile> openFile(Kind kind, int level, std::uint32_t part,
                              std::span<const std::byte>& payload, bool verify = true) const;
  /// Removes every part of one file (missing is fine).
  void removeFile(Kind kind, int level, std::uint32_t parts) const;

 private:
  std::filesystem::path dir_;
};

/// "name" of the first fingerprint entry that differs between `saved` and `now` with both
/// values, as a message; nullopt when they are equal.
std::optional<std::string> fingerprintMismatch(
    const std::vector<std::pair<std::string, std::string>>& saved,
    const std::vector<std::pair<std::string, std::string>>& now);

}  // namespace pbdam::builder
