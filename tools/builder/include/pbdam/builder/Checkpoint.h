// Build checkpoints (docs/builder.md "Checkpoints"): after each completed bintree level the build
// keeps that level's node records and patch blobs and the state the next level needs in
// OUT/.build-checkpoint/, so that `pbdam build --resume` restarts after the last completed level
// and still writes identical bytes. Also the exact byte serialisation used both for these files
// and for the MPI exchanges between levels. Thread-safety: plain values and functions; a
// Checkpoint is used by rank 0's build thread only.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
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

/// Writes `chunks` to `path` through a temporary file in the same directory, fsync and rename
/// (design.md §6); `crc` receives the CRC-32 of the whole file.
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

  /// Path of the file of `kind` for `level` (level is ignored for Texture).
  std::filesystem::path file(Kind kind, int level) const;
  /// Writes a checkpoint file atomically: header (magic, kind, level, payload size), the
  /// payload pieces, CRC-32 trailer.
  Result<void> writeFile(Kind kind, int level,
                         const std::vector<std::span<const std::byte>>& payload) const;
  /// Maps a checkpoint file and checks its header and CRC; `payload` is its payload inside
  /// the returned mapping.
  Result<MappedFile> openFile(Kind kind, int level, std::span<const std::byte>& payload) const;
  /// Removes one file (missing is fine).
  void removeFile(Kind kind, int level) const;

 private:
  std::filesystem::path dir_;
};

/// "name" of the first fingerprint entry that differs between `saved` and `now` with both
/// values, as a message; nullopt when they are equal.
std::optional<std::string> fingerprintMismatch(
    const std::vector<std::pair<std::string, std::string>>& saved,
    const std::vector<std::pair<std::string, std::string>>& now);

}  // namespace pbdam::builder
