// Checkpoint directory, its state file and its CRC-checked files (Checkpoint.h;
// docs/builder.md "Checkpoints").
#include "pbdam/builder/Checkpoint.h"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "pbdam/formats/Checksum.h"

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

constexpr std::array<char, 8> kMagic = {'P', 'B', 'D', 'A', 'M', 'C', 'K', 'P'};
constexpr std::uint32_t kFileVersion = 1;
constexpr std::size_t kHeaderBytes = 8 + 4 + 4 + 4 + 4 + 8;
constexpr const char* kStateName = "state";
constexpr const char* kStateFormat = "pbdam-build-checkpoint 1";

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

Result<void> writeFileAtomically(const fs::path& path,
                                 const std::vector<std::span<const std::byte>>& chunks,
                                 std::uint32_t& crc) {
  std::string tmpName = ".";
  tmpName += path.filename().string();
  tmpName += ".tmp";
  const fs::path tmp = path.parent_path() / tmpName;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    return makeError(ErrorCode::IoError,
                     tmp.string() + ": cannot create (" + std::strerror(errno) + ")");
  }
  crc = 0;
  for (const auto& chunk : chunks) {
    if (auto r = writeAll(fd, chunk, tmp, crc); !r) {
      ::close(fd);
      return r;
    }
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    return makeError(ErrorCode::IoError, tmp.string() + ": fsync/close failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec)
    return makeError(ErrorCode::IoError, path.string() + ": rename failed (" + ec.message() + ")");
  return {};
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
  out << "texture-complete " << (state.textureComplete ? "yes" : "no") << '\n';
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

fs::path Checkpoint::file(Kind kind, int level) const {
  char name[32];
  switch (kind) {
    case Kind::Nodes:
      std::snprintf(name, sizeof name, "level-%02d.nodes", level);
      break;
    case Kind::Carry:
      std::snprintf(name, sizeof name, "level-%02d.carry", level);
      break;
    case Kind::Texture:
      std::snprintf(name, sizeof name, "texture.tiles");
      break;
  }
  return dir_ / name;
}

Result<void> Checkpoint::writeFile(Kind kind, int level,
                                   const std::vector<std::span<const std::byte>>& payload) const {
  std::uint64_t payloadBytes = 0;
  for (const auto& piece : payload) payloadBytes += piece.size();
  ByteWriter header;
  for (char c : kMagic) header.put(c);
  header.put(kFileVersion);
  header.put(static_cast<std::uint32_t>(kind));
  header.put(static_cast<std::int32_t>(level));
  header.put(std::uint32_t{0});
  header.put(payloadBytes);
  std::uint32_t crc = crc32(header.bytes());
  for (const auto& piece : payload) crc = crc32(piece, crc);
  std::vector<std::span<const std::byte>> chunks;
  chunks.reserve(payload.size() + 2);
  chunks.emplace_back(header.bytes());
  chunks.insert(chunks.end(), payload.begin(), payload.end());
  const auto trailer = std::bit_cast<std::array<std::byte, 4>>(crc);
  chunks.emplace_back(trailer);
  std::uint32_t fileCrc = 0;
  return writeFileAtomically(file(kind, level), chunks, fileCrc);
}

Result<MappedFile> Checkpoint::openFile(Kind kind, int level,
                                        std::span<const std::byte>& payload) const {
  const fs::path path = file(kind, level);
  auto mapped = MappedFile::open(path);
  if (!mapped) return std::move(mapped).error();
  const auto bytes = mapped->bytes();
  auto damaged = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData, path.string() + ": " + what);
  };
  if (bytes.size() < kHeaderBytes + 4) return damaged("truncated checkpoint file");
  ByteReader r(bytes);
  std::array<char, 8> magic{};
  for (char& c : magic) c = r.get<char>();
  const auto version = r.get<std::uint32_t>();
  const auto fileKind = r.get<std::uint32_t>();
  const auto fileLevel = r.get<std::int32_t>();
  (void)r.get<std::uint32_t>();
  const auto payloadBytes = r.get<std::uint64_t>();
  if (magic != kMagic || version != kFileVersion) return damaged("not a checkpoint file");
  if (fileKind != static_cast<std::uint32_t>(kind) ||
      (kind != Kind::Texture && fileLevel != level)) {
    return damaged("holds another kind or level");
  }
  if (payloadBytes != bytes.size() - kHeaderBytes - 4) return damaged("size mismatch");
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (crc32(bytes.first(bytes.size() - 4)) != stored) return damaged("checksum mismatch");
  payload = bytes.subspan(kHeaderBytes, static_cast<std::size_t>(payloadBytes));
  return mapped;
}

void Checkpoint::removeFile(Kind kind, int level) const {
  std::error_code ec;
  fs::remove(file(kind, level), ec);
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
    if (*old != value) return "it has " + key + " " + *old + ", this build " + value;
  }
  if (saved.size() != now.size()) return "it records other options";
  return std::nullopt;
}

}  // namespace pbdam::builder
