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
#include "pbdam/formats/GuardedCopy.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

constexpr std::array<char, 8> kMagic = {'P', 'B', 'D', 'A', 'M', 'C', 'K', 'P'};
constexpr std::uint32_t kFileVersion = 2;
// Trailer: magic, version, kind, level, part, parts, 0, payload bytes; then the CRC-32 of the
// payload and the trailer.
constexpr std::size_t kTrailerBytes = 8 + 4 + 4 + 4 + 4 + 4 + 4 + 8;
constexpr std::size_t kWriteBufferBytes = std::size_t{1} << 20;
constexpr const char* kStateName = "state";
constexpr const char* kStateFormat = "pbdam-build-checkpoint 2";

Result<void> writeAll(int fd, std::span<const std::byte> bytes, const fs::path& path,
                      std::uint32_t& crc) {
  crc = crc32(bytes, crc);
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return makeError(ErrorCode::IoError,
                       path.string() + ": write failed (" + std::strerror(errno) + ")");
    }
    done += static_cast<std::size_t>(n);
  }
  return {};
}

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
      crc_(other.crc_) {}

AtomicFileWriter& AtomicFileWriter::operator=(AtomicFileWriter&& other) noexcept {
  if (this != &other) {
    abandon();
    path_ = std::move(other.path_);
    tmp_ = std::move(other.tmp_);
    fd_ = std::exchange(other.fd_, -1);
    buffer_ = std::move(other.buffer_);
    size_ = other.size_;
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
    std::uint32_t ignored = 0;
    return writeAll(fd_, bytes, tmp_, ignored);
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  return {};
}

Result<void> AtomicFileWriter::flush() {
  std::uint32_t ignored = 0;
  auto r = writeAll(fd_, buffer_, tmp_, ignored);
  buffer_.clear();
  return r;
}

Result<void> AtomicFileWriter::finish() {
  if (auto r = flush(); !r) return r;
  const int fd = std::exchange(fd_, -1);
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    return makeError(ErrorCode::IoError, tmp_.string() + ": fsync/close failed");
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
  auto damaged = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData,
                     path.string() + ": " + what + " (remove the directory to build from scratch)");
  };
  std::string line;
  if (!std::getline(in, line) || line != kStateFormat) {
    return damaged("not a pbdam build checkpoint of this version");
  }
  CheckpointState state;
  bool sawEnd = false;
  while (std::getline(in, line)) {
    if (line == "end") {
      sawEnd = true;
      break;
    }
    const auto space = line.find(' ');
    if (space == std::string::npos) return damaged("bad line '" + line + "'");
    const std::string key = line.substr(0, space);
    const std::string value = line.substr(space + 1);
    if (key == "complete-level") {
      try {
        state.completeLevel = std::stoi(value);
      } catch (const std::exception&) {
        return damaged("bad complete-level '" + value + "'");
      }
    } else if (key == "texture-complete") {
      state.textureComplete = value == "yes";
    } else if (key == "level-parts" || key == "texture-parts") {
      try {
        std::size_t used = 0;
        const int first = std::stoi(value, &used);
        if (key == "texture-parts") {
          state.textureParts = static_cast<std::uint32_t>(first);
        } else {
          state.levelParts[first] = static_cast<std::uint32_t>(std::stoul(value.substr(used)));
        }
      } catch (const std::exception&) {
        return damaged(std::string("bad ").append(key).append(" '").append(value).append("'"));
      }
    } else if (key == "option") {
      const auto eq = value.find('=');
      if (eq == std::string::npos) return damaged("bad option line '" + line + "'");
      state.fingerprint.emplace_back(value.substr(0, eq), value.substr(eq + 1));
    } else {
      return damaged("unknown key '" + key + "'");
    }
  }
  if (!sawEnd) return damaged("truncated");
  return std::optional<CheckpointState>{std::move(state)};
}

Result<void> Checkpoint::writeState(const CheckpointState& state) const {
  std::ostringstream out;
  out << kStateFormat << '\n';
  for (const auto& [key, value] : state.fingerprint)
    out << "option " << key << '=' << value << '\n';
  if (state.completeLevel) out << "complete-level " << *state.completeLevel << '\n';
  for (const auto& [level, parts] : state.levelParts)
    out << "level-parts " << level << ' ' << parts << '\n';
  out << "texture-complete " << (state.textureComplete ? "yes" : "no") << '\n';
  if (state.textureComplete) out << "texture-parts " << state.textureParts << '\n';
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
  ByteWriter trailer;
  const std::uint64_t payloadBytes = file_.size();
  for (char c : kMagic) trailer.put(c);
  trailer.put(kFileVersion);
  trailer.put(static_cast<std::uint32_t>(kind_));
  trailer.put(static_cast<std::int32_t>(level_));
  trailer.put(part_);
  trailer.put(parts_);
  trailer.put(std::uint32_t{0});
  trailer.put(payloadBytes);
  if (auto r = file_.append(trailer.bytes()); !r) return r;
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
  auto damaged = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData, path.string() + ": " + what);
  };
  if (bytes.size() < kTrailerBytes + 4) return damaged("truncated checkpoint file");
  const std::size_t payloadEnd = bytes.size() - kTrailerBytes - 4;
  // The trailer and CRC are copied out guarded: a file cut short under the mapping is an error.
  std::array<std::byte, kTrailerBytes + 4> tail{};
  if (auto read = mapped->read(payloadEnd, tail); !read) return std::move(read).error();
  ByteReader r(tail);
  std::array<char, 8> magic{};
  for (char& c : magic) c = r.get<char>();
  const auto version = r.get<std::uint32_t>();
  const auto fileKind = r.get<std::uint32_t>();
  const auto fileLevel = r.get<std::int32_t>();
  const auto filePart = r.get<std::uint32_t>();
  (void)r.get<std::uint32_t>();
  (void)r.get<std::uint32_t>();
  const auto payloadBytes = r.get<std::uint64_t>();
  if (magic != kMagic || version != kFileVersion) return damaged("not a checkpoint file");
  if (fileKind != static_cast<std::uint32_t>(kind) ||
      (kind != Kind::Texture && fileLevel != level) || filePart != part) {
    return damaged("holds another kind, level or part");
  }
  if (payloadBytes != payloadEnd) return damaged("size mismatch");
  if (verify) {
    std::uint32_t stored = 0;
    std::memcpy(&stored, tail.data() + kTrailerBytes, 4);
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
    if (crc != stored) return damaged("checksum mismatch");
  }
  payload = bytes.first(payloadEnd);
  return mapped;
}

void Checkpoint::removeFile(Kind kind, int level, std::uint32_t parts) const {
  std::error_code ec;
  for (std::uint32_t part = 0; part < parts; ++part) fs::remove(file(kind, level, part), ec);
}

// ---- Part-file payloads.

std::vector<std::byte> encodeLevelPartFooter(const LevelPartFooter& footer) {
  ByteWriter w;
  w.put(footer.firstDiamond);
  w.put(footer.diamonds);
  w.put(footer.simplifyRetries);
  w.put(footer.halvesKeptUnsimplified);
  w.put(footer.patchBytesRaw);
  w.put(footer.seconds);
  return w.take();
}

Result<LevelPartFooter> decodeLevelPartFooter(std::span<const std::byte> bytes,
                                              const std::string& where) {
  if (bytes.size() != LevelPartFooter::kBytes) {
    return makeError(ErrorCode::CorruptData, where + ": truncated");
  }
  ByteReader r(bytes);
  LevelPartFooter footer;
  footer.firstDiamond = r.get<std::uint64_t>();
  footer.diamonds = r.get<std::uint64_t>();
  footer.simplifyRetries = r.get<std::uint64_t>();
  footer.halvesKeptUnsimplified = r.get<std::uint64_t>();
  footer.patchBytesRaw = r.get<std::uint64_t>();
  footer.seconds = r.get<double>();
  return footer;
}

void putNodeEntry(ByteWriter& w, std::uint64_t id,
                  std::span<const std::byte, kNodeRecordBytes> record,
                  std::span<const std::byte> blob) {
  w.put(id);
  w.putBytes(record);
  w.put(static_cast<std::uint32_t>(blob.size()));
  w.putBytes(blob);
}

Result<LevelPartView> LevelPartView::parse(std::span<const std::byte> payload, std::string where) {
  if (payload.size() < LevelPartFooter::kBytes) {
    return makeError(ErrorCode::CorruptData, where + ": truncated");
  }
  auto footer = decodeLevelPartFooter(payload.last(LevelPartFooter::kBytes), where);
  if (!footer) return std::move(footer).error();
  LevelPartView view;
  view.entries_ = payload.first(payload.size() - LevelPartFooter::kBytes);
  view.footer_ = *footer;
  view.where_ = std::move(where);
  return view;
}

std::optional<NodeEntry> LevelPartView::nextEntry(ByteReader& r) noexcept {
  const auto id = r.get<std::uint64_t>();
  const auto record = r.take(kNodeRecordBytes);
  const auto bytes = r.get<std::uint32_t>();
  const auto blob = r.take(bytes);
  if (r.failed()) return std::nullopt;
  return NodeEntry{
      id, std::span<const std::byte, kNodeRecordBytes>(record.data(), kNodeRecordBytes), blob};
}

Error LevelPartView::truncated() const {
  return makeError(ErrorCode::CorruptData, where_ + ": truncated");
}

std::vector<std::byte> encodeTexturePartFooter(const TexturePartFooter& footer) {
  ByteWriter w;
  w.put(footer.firstTile);
  w.put(footer.tiles);
  w.put(footer.seconds);
  return w.take();
}

Result<TexturePartFooter> decodeTexturePartFooter(std::span<const std::byte> bytes,
                                                  const std::string& where) {
  if (bytes.size() != TexturePartFooter::kBytes) {
    return makeError(ErrorCode::CorruptData, where + ": incomplete");
  }
  ByteReader r(bytes);
  TexturePartFooter footer;
  footer.firstTile = r.get<std::uint64_t>();
  footer.tiles = r.get<std::uint64_t>();
  footer.seconds = r.get<double>();
  return footer;
}

void putTileEntry(ByteWriter& w, float textureErrorMeters, std::span<const std::byte> blob) {
  w.put(textureErrorMeters);
  w.put(static_cast<std::uint32_t>(blob.size()));
  w.putBytes(blob);
}

Result<TexturePartView> TexturePartView::parse(std::span<const std::byte> payload,
                                               std::string where) {
  if (payload.size() < TexturePartFooter::kBytes) {
    return makeError(ErrorCode::CorruptData, where + ": incomplete");
  }
  auto footer = decodeTexturePartFooter(payload.last(TexturePartFooter::kBytes), where);
  if (!footer) return std::move(footer).error();
  TexturePartView view;
  view.entries_ = payload.first(payload.size() - TexturePartFooter::kBytes);
  view.footer_ = *footer;
  view.where_ = std::move(where);
  return view;
}

Error TexturePartView::incomplete() const {
  return makeError(ErrorCode::CorruptData, where_ + ": incomplete");
}

namespace {

void putPatch(ByteWriter& w, const WorkPatch& p) {
  bool narrow = p.points.size() <= 65536;
  for (const LatticeXY& q : p.points) {
    narrow = narrow && q.x >= 0 && q.x <= 65535 && q.y >= 0 && q.y <= 65535;
  }
  w.put(static_cast<std::uint32_t>(p.points.size()));
  w.put(static_cast<std::uint8_t>(narrow ? 2 : 4));
  if (narrow) {
    std::vector<std::uint16_t> values;
    values.reserve(2 * p.points.size());
    for (const LatticeXY& q : p.points) {
      values.push_back(static_cast<std::uint16_t>(q.x));
      values.push_back(static_cast<std::uint16_t>(q.y));
    }
    w.putBytes(std::as_bytes(std::span<const std::uint16_t>(values)));
    values.assign(p.indices.begin(), p.indices.end());  // < 65536: indices of the points
    w.put(static_cast<std::uint32_t>(values.size()));
    w.putBytes(std::as_bytes(std::span<const std::uint16_t>(values)));
    return;
  }
  for (const LatticeXY& q : p.points) {
    w.put(q.x);
    w.put(q.y);
  }
  w.put(static_cast<std::uint32_t>(p.indices.size()));
  w.putBytes(std::as_bytes(std::span<const std::uint32_t>(p.indices)));
}

/// Reads what putPatch wrote; false when the width is neither 2 nor 4 or a run is cut short.
bool getPatch(ByteReader& r, WorkPatch& p) {
  const auto points = r.get<std::uint32_t>();
  const auto width = r.get<std::uint8_t>();
  if (r.failed() || (width != 2 && width != 4)) return false;
  const auto coordinates = r.take(std::size_t{points} * 2 * width);
  if (r.failed()) return false;
  p.points.resize(points);
  for (std::size_t k = 0; k < points; ++k) {
    if (width == 2) {
      std::array<std::uint16_t, 2> xy{};
      std::memcpy(xy.data(), coordinates.data() + 4 * k, 4);
      p.points[k] = LatticeXY(static_cast<std::int32_t>(xy[0]), static_cast<std::int32_t>(xy[1]));
    } else {
      std::memcpy(&p.points[k].x, coordinates.data() + 8 * k, 4);
      std::memcpy(&p.points[k].y, coordinates.data() + 8 * k + 4, 4);
    }
  }
  const auto indices = r.get<std::uint32_t>();
  const auto run = r.take(std::size_t{indices} * width);
  if (r.failed()) return false;
  p.indices.resize(indices);
  if (width == 4) {
    std::memcpy(p.indices.data(), run.data(), run.size());
  } else {
    for (std::size_t k = 0; k < indices; ++k) {
      std::uint16_t v = 0;
      std::memcpy(&v, run.data() + 2 * k, 2);
      p.indices[k] = v;
    }
  }
  return true;
}

constexpr std::size_t kCarryIndexEntryBytes = 16;  // node id, record offset

}  // namespace

void putCarryRecord(ByteWriter& w, const CarrySaturation& saturation, const WorkPatch* patch) {
  w.put(saturation.errorMeters);
  w.put(saturation.sphereCenter.x);
  w.put(saturation.sphereCenter.y);
  w.put(saturation.sphereCenter.z);
  w.put(saturation.sphereRadiusMeters);
  w.put(static_cast<std::uint8_t>(patch != nullptr ? 1 : 0));
  if (patch != nullptr) putPatch(w, *patch);
}

bool getCarryRecord(ByteReader& r, CarrySaturation& saturation, WorkPatch* patch) {
  saturation.errorMeters = r.get<float>();
  saturation.sphereCenter.x = r.get<double>();
  saturation.sphereCenter.y = r.get<double>();
  saturation.sphereCenter.z = r.get<double>();
  saturation.sphereRadiusMeters = r.get<float>();
  const bool hasPatch = r.get<std::uint8_t>() != 0;
  if (patch != nullptr) {
    if (!hasPatch) return false;
    *patch = WorkPatch{};
    if (!getPatch(r, *patch)) return false;
  }
  return !r.failed();
}

std::vector<std::byte> encodeCarryIndex(
    std::vector<std::pair<std::uint64_t, std::uint64_t>> entries) {
  std::sort(entries.begin(), entries.end());
  ByteWriter index;
  for (const auto& [id, offset] : entries) {
    index.put(id);
    index.put(offset);
  }
  index.put(static_cast<std::uint64_t>(entries.size()));
  return index.take();
}

Result<CarryPartView> CarryPartView::parse(std::span<const std::byte> payload,
                                           const std::string& where) {
  if (payload.size() < 8) return makeError(ErrorCode::CorruptData, where + ": no index");
  CarryPartView view;
  std::memcpy(&view.count_, payload.data() + payload.size() - 8, 8);
  if (view.count_ > (payload.size() - 8) / kCarryIndexEntryBytes) {
    return makeError(ErrorCode::CorruptData, where + ": bad index");
  }
  view.payload_ = payload;
  view.index_ = payload.data() + payload.size() - 8 - kCarryIndexEntryBytes * view.count_;
  return view;
}

std::optional<std::uint64_t> CarryPartView::offsetOf(std::uint64_t id) const noexcept {
  std::uint64_t lo = 0;
  std::uint64_t hi = count_;
  while (lo < hi) {
    const std::uint64_t mid = lo + (hi - lo) / 2;
    std::uint64_t key = 0;
    std::memcpy(&key, index_ + kCarryIndexEntryBytes * mid, 8);
    if (key < id) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo == count_) return std::nullopt;
  std::uint64_t key = 0;
  std::uint64_t offset = 0;
  std::memcpy(&key, index_ + kCarryIndexEntryBytes * lo, 8);
  std::memcpy(&offset, index_ + kCarryIndexEntryBytes * lo + 8, 8);
  if (key != id || offset >= payload_.size()) return std::nullopt;
  return offset;
}

bool CarryPartView::read(std::uint64_t offset, CarrySaturation& saturation,
                         WorkPatch* patch) const {
  if (offset >= payload_.size()) return false;
  ByteReader r(payload_.subspan(static_cast<std::size_t>(offset)));
  return getCarryRecord(r, saturation, patch);
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
