// Checkpoint directory, its state file and its CRC-checked files (Checkpoint.h;
// docs/builder.md "Checkpoints").
#include "pbdam/builder/Checkpoint.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <utility>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/FileWrite.h"
#include "pbdam/formats/GuardedCopy.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kWriteBufferBytes = std::size_t{1} << 20;
constexpr const char* kStateName = "state";

}  // namespace

Result<AtomicFileWriter> AtomicFileWriter::create(const fs::path& path) {
  AtomicFileWriter w;
  w.path_ = path;
  std::string tmpName = ".";
  tmpName += path.filename().string();
  tmpName += ".tmp";
  w.tmp_ = path.parent_path() / tmpName;
  w.fd_ = ::open(w.tmp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (w.fd_ < 0) {
    return makeError(ErrorCode::IoError,
                     w.tmp_.string() + ": cannot create (" + std::strerror(errno) + ")");
  }
  w.buffer_.reserve(kWriteBufferBytes);
  return w;
}

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& other) noexcept
    : path_(std::move(other.path_)),
      tmp_(std::move(other.tmp_)),
      fd_(std::exchange(other.fd_, -1)),
      buffer_(std::move(other.buffer_)),
      size_(other.size_),
      reserved_(other.reserved_),
      prefix_(other.prefix_),
      prefixPending_(other.prefixPending_),
      crc_(other.crc_) {}

AtomicFileWriter& AtomicFileWriter::operator=(AtomicFileWriter&& other) noexcept {
  if (this != &other) {
    abandon();
    path_ = std::move(other.path_);
    tmp_ = std::move(other.tmp_);
    fd_ = std::exchange(other.fd_, -1);
    buffer_ = std::move(other.buffer_);
    size_ = other.size_;
    reserved_ = other.reserved_;
    prefix_ = other.prefix_;
    prefixPending_ = other.prefixPending_;
    crc_ = other.crc_;
  }
  return *this;
}

AtomicFileWriter::~AtomicFileWriter() { abandon(); }

void AtomicFileWriter::abandon() noexcept {
  if (fd_ < 0) return;
  ::close(fd_);
  fd_ = -1;
  std::error_code ec;
  fs::remove(tmp_, ec);
}

Result<void> AtomicFileWriter::append(std::span<const std::byte> bytes) {
  crc_ = crc32(bytes, crc_);
  size_ += bytes.size();
  if (buffer_.size() + bytes.size() > kWriteBufferBytes) {
    if (auto r = flush(); !r) return r;
  }
  if (bytes.size() >= kWriteBufferBytes) {
    return writeFully(fd_, bytes, path_);
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  return {};
}

Result<void> AtomicFileWriter::leavePrefix(std::uint64_t bytes) {
  if (size_ != 0 || prefixPending_) {
    return makeError(ErrorCode::Internal, path_.string() + ": a prefix left after appending");
  }
  if (::lseek(fd_, static_cast<off_t>(bytes), SEEK_SET) < 0) {
    return makeError(ErrorCode::IoError,
                     tmp_.string() + ": lseek failed (" + std::strerror(errno) + ")");
  }
  prefix_ = bytes;
  prefixPending_ = bytes != 0;
  size_ = bytes;
  return {};
}

Result<void> AtomicFileWriter::writePrefix(std::uint64_t offset, std::span<const std::byte> bytes) {
  if (!prefixPending_ || offset > prefix_ || bytes.size() > prefix_ - offset) {
    return makeError(ErrorCode::Internal, path_.string() + ": a write outside the prefix left");
  }
  return pwriteFully(fd_, bytes, offset, path_);
}

void AtomicFileWriter::prefixWritten(std::uint32_t prefixCrc) noexcept {
  if (!prefixPending_) return;
  crc_ = crc32Combine(prefixCrc, crc_, size_ - prefix_);
  prefixPending_ = false;
}

Result<void> AtomicFileWriter::flush() {
  auto r = writeFully(fd_, buffer_, path_);
  buffer_.clear();
  return r;
}

Result<void> AtomicFileWriter::reserve(std::uint64_t bytes) {
  if (auto r = reserveFileSpace(fd_, 0, bytes, path_); !r) return r;
  reserved_ = std::max(reserved_, bytes);
  return {};
}

Result<void> AtomicFileWriter::finish() {
  if (prefixPending_) {
    return makeError(ErrorCode::Internal, path_.string() + ": its prefix was never written");
  }
  if (auto r = flush(); !r) return r;
  // posix_fallocate extends the file: a reservation beyond what was written is cut off.
  if (reserved_ > size_ && ::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
    return makeError(ErrorCode::IoError,
                     tmp_.string() + ": ftruncate failed (" + std::strerror(errno) + ")");
  }
  if (auto r = syncFile(fd_, size_, path_); !r) return r;
  if (::close(std::exchange(fd_, -1)) != 0) {
    return makeError(ErrorCode::IoError,
                     tmp_.string() + ": close failed (" + std::strerror(errno) + ")");
  }
  std::error_code ec;
  fs::rename(tmp_, path_, ec);
  if (ec) {
    return makeError(ErrorCode::IoError, path_.string() + ": rename failed (" + ec.message() + ")");
  }
  return {};
}

Result<void> writeFileAtomically(const fs::path& path,
                                 const std::vector<std::span<const std::byte>>& chunks,
                                 std::uint32_t& crc) {
  auto w = AtomicFileWriter::create(path);
  if (!w) return std::move(w).error();
  for (const auto& chunk : chunks) {
    if (auto r = w->append(chunk); !r) return r;
  }
  crc = w->crc();
  return w->finish();
}

void syncDirectory(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
}

Result<std::optional<CheckpointState>> Checkpoint::readState() const {
  const fs::path path = dir_ / kStateName;
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::optional<CheckpointState>{};
  std::ifstream in(path);
  if (!in) return makeError(ErrorCode::IoError, path.string() + ": cannot read");
  std::ostringstream text;
  text << in.rdbuf();
  auto state = parseCheckpointState(text.str(), path.string());
  if (!state) return std::move(state).error();
  return std::optional<CheckpointState>{std::move(state).value()};
}

Result<void> Checkpoint::writeState(const CheckpointState& state) const {
  std::ostringstream out;
  out << kCheckpointStateHeader << '\n';
  for (const auto& [key, value] : state.fingerprint)
    out << "option " << key << '=' << value << '\n';
  if (state.completeLevel) out << "complete-level " << *state.completeLevel << '\n';
  for (const auto& [level, parts] : state.levelParts)
    out << "level-parts " << level << ' ' << parts << '\n';
  out << "texture-complete " << (state.textureComplete ? "yes" : "no") << '\n';
  if (state.textureComplete) out << "texture-parts " << state.textureParts << '\n';
  if (state.assemblyFreedLevels) out << "assembly-freed-levels yes\n";
  out << "end\n";
  const std::string text = out.str();
  std::uint32_t crc = 0;
  auto r = writeFileAtomically(
      dir_ / kStateName, {std::as_bytes(std::span<const char>(text.data(), text.size()))}, crc);
  if (r) syncDirectory(dir_);
  return r;
}

Result<void> Checkpoint::reset(bool recreate) const {
  std::error_code ec;
  fs::remove_all(dir_, ec);
  if (ec)
    return makeError(ErrorCode::IoError, dir_.string() + ": cannot remove (" + ec.message() + ")");
  if (recreate) {
    fs::create_directories(dir_, ec);
    if (ec) {
      return makeError(ErrorCode::IoError,
                       dir_.string() + ": cannot create (" + ec.message() + ")");
    }
  }
  return {};
}

fs::path Checkpoint::file(Kind kind, int level, std::uint32_t part) const {
  char name[48];
  switch (kind) {
    case Kind::Nodes:
      std::snprintf(name, sizeof name, "level-%02d.part-%u.nodes", level, part);
      break;
    case Kind::Carry:
      std::snprintf(name, sizeof name, "level-%02d.part-%u.carry", level, part);
      break;
    case Kind::Texture:
      std::snprintf(name, sizeof name, "texture.part-%u.tiles", part);
      break;
  }
  return dir_ / name;
}

fs::path Checkpoint::samplesFile(std::uint32_t part) const {
  char name[48];
  std::snprintf(name, sizeof name, "samples.part-%u.bin", part);
  return dir_ / name;
}

Result<Checkpoint::PartWriter> Checkpoint::startFile(Kind kind, int level, std::uint32_t part,
                                                     std::uint32_t parts) const {
  auto file = AtomicFileWriter::create(this->file(kind, level, part));
  if (!file) return std::move(file).error();
  PartWriter w;
  w.file_ = std::move(file).value();
  w.kind_ = kind;
  w.level_ = level;
  w.part_ = part;
  w.parts_ = parts;
  return w;
}

Result<void> Checkpoint::PartWriter::finish() {
  if (auto r = file_.append(encodePartTrailer(kind_, level_, part_, parts_, file_.size())); !r) {
    return r;
  }
  const auto crc = std::bit_cast<std::array<std::byte, 4>>(file_.crc());
  if (auto r = file_.append(crc); !r) return r;
  return file_.finish();
}

Result<MappedFile> Checkpoint::openFile(Kind kind, int level, std::uint32_t part,
                                        std::span<const std::byte>& payload, bool verify) const {
  const fs::path path = file(kind, level, part);
  auto mapped = MappedFile::open(path);
  if (!mapped) return std::move(mapped).error();
  const auto bytes = mapped->bytes();
  // The trailer and CRC are copied out guarded: a file cut short under the mapping is an error.
  std::array<std::byte, kPartTrailerBytes + 4> tail{};
  if (bytes.size() < tail.size()) {
    return makeError(ErrorCode::CorruptData, path.string() + ": truncated checkpoint file");
  }
  if (auto read = mapped->read(bytes.size() - tail.size(), tail); !read) {
    return std::move(read).error();
  }
  auto payloadBytes = partPayloadBytes(tail, bytes.size(), kind, level, part, path.string());
  if (!payloadBytes) return std::move(payloadBytes).error();
  if (verify) {
    std::uint32_t stored = 0;
    std::memcpy(&stored, tail.data() + kPartTrailerBytes, 4);
    // RSS bound: the check reads every page; release them every 64 MB (chunk starts stay
    // page-aligned), not only at the end, or a leaf level's file would be resident whole. Read
    // through guarded copies: a part truncated or unreadable on disk is an error naming it.
    constexpr std::size_t kChunk = std::size_t{64} << 20;
    const std::size_t checked = bytes.size() - 4;
    std::uint32_t crc = 0;
    for (std::size_t at = 0; at < checked; at += kChunk) {
      const std::size_t n = std::min(kChunk, checked - at);
      auto piece = crc32Mapped(bytes, at, n, path.string(), crc);
      (void)mapped->releaseResident(at, n);
      if (!piece) return std::move(piece).error();
      crc = *piece;
    }
    if (crc != stored) {
      return makeError(ErrorCode::CorruptData, path.string() + ": checksum mismatch");
    }
  }
  payload = bytes.first(*payloadBytes);
  return mapped;
}

void Checkpoint::removeFile(Kind kind, int level, std::uint32_t parts) const {
  std::error_code ec;
  for (std::uint32_t part = 0; part < parts; ++part) fs::remove(file(kind, level, part), ec);
}

Result<void> CarryReader::open(const Checkpoint& checkpoint, int level, std::uint32_t parts,
                               bool verify) {
  parts_.clear();
  for (std::uint32_t part = 0; part < parts; ++part) {
    std::span<const std::byte> payload;
    auto mapped = checkpoint.openFile(Checkpoint::Kind::Carry, level, part, payload, verify);
    if (!mapped) return std::move(mapped).error();
    const auto path = checkpoint.file(Checkpoint::Kind::Carry, level, part).string();
    auto view = CarryPartView::parse(payload, path);
    if (!view) return std::move(view).error();
    parts_.push_back(Part{std::move(mapped).value(), *view});
  }
  return {};
}

void CarryReader::releaseResident() const noexcept {
  for (const Part& p : parts_) (void)p.file.releaseResident();
}

bool CarryReader::find(std::uint64_t id, CarrySaturation& saturation, WorkPatch* patch) const {
  for (const Part& p : parts_) {
    if (const auto offset = p.view.offsetOf(id)) return p.view.read(*offset, saturation, patch);
  }
  return false;
}

std::optional<std::string> fingerprintMismatch(
    const std::vector<std::pair<std::string, std::string>>& saved,
    const std::vector<std::pair<std::string, std::string>>& now) {
  for (const auto& [key, value] : now) {
    std::optional<std::string> old;
    for (const auto& [k, v] : saved) {
      if (k == key) old = v;
    }
    if (key == "builder-levels" && old != value) {
      // The builder that wrote it made (or carried) its levels another way: its part files
      // cannot be continued by this one.
      return "it was written by an older builder (levels version " + old.value_or("1") +
             ", this builder's " + value + "), whose level files this one cannot continue";
    }
    if (!old) return key + " is not recorded in it";
    if (*old != value) {
      return std::string("it has ")
          .append(key)
          .append(" ")
          .append(*old)
          .append(", this build ")
          .append(value);
    }
  }
  if (saved.size() != now.size()) return "it records other options";
  return std::nullopt;
}

}  // namespace pbdam::builder
