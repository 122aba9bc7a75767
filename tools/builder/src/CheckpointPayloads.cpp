// The bytes of the build checkpoint's files (Checkpoint.h; docs/builder.md "Checkpoints"): the
// part-file trailer, the payloads of nodes, carry and texture parts, and the state file's text.
// Pure encoding and decoding, no file access, so that the decoders can be fuzzed alone
// (tests/fuzz/fuzz_checkpoint.cpp): every count and offset is checked against the bytes.
#include <algorithm>
#include <array>
#include <cstring>
#include <string>
#include <utility>

#include "pbdam/builder/Checkpoint.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

constexpr std::array<char, 8> kMagic = {'P', 'B', 'D', 'A', 'M', 'C', 'K', 'P'};
constexpr std::uint32_t kFileVersion = 5;

}  // namespace

std::vector<std::byte> encodePartTrailer(Checkpoint::Kind kind, int level, std::uint32_t part,
                                         std::uint32_t parts, std::uint64_t payloadBytes) {
  ByteWriter trailer;
  for (char c : kMagic) trailer.put(c);
  trailer.put(kFileVersion);
  trailer.put(static_cast<std::uint32_t>(kind));
  trailer.put(static_cast<std::int32_t>(level));
  trailer.put(part);
  trailer.put(parts);
  trailer.put(std::uint32_t{0});
  trailer.put(payloadBytes);
  return trailer.take();
}

Result<std::size_t> partPayloadBytes(std::span<const std::byte> tail, std::size_t fileBytes,
                                     Checkpoint::Kind kind, int level, std::uint32_t part,
                                     const std::string& where) {
  auto damaged = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData, where + ": " + what);
  };
  if (fileBytes < kPartTrailerBytes + 4 || tail.size() != kPartTrailerBytes + 4) {
    return damaged("truncated checkpoint file");
  }
  const std::size_t payloadEnd = fileBytes - kPartTrailerBytes - 4;
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
      (kind != Checkpoint::Kind::Texture && fileLevel != level) || filePart != part) {
    return damaged("holds another kind, level or part");
  }
  if (payloadBytes != payloadEnd) return damaged("size mismatch");
  return payloadEnd;
}

Result<std::span<const std::byte>> partPayload(std::span<const std::byte> bytes,
                                               Checkpoint::Kind kind, int level, std::uint32_t part,
                                               const std::string& where) {
  const std::size_t tailBytes = std::min(bytes.size(), kPartTrailerBytes + 4);
  auto payloadBytes =
      partPayloadBytes(bytes.last(tailBytes), bytes.size(), kind, level, part, where);
  if (!payloadBytes) return std::move(payloadBytes).error();
  return bytes.first(*payloadBytes);
}

Result<CheckpointState> parseCheckpointState(std::string_view text, const std::string& where) {
  auto damaged = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData,
                     where + ": " + what + " (remove the directory to build from scratch)");
  };
  std::size_t at = 0;
  auto getline = [&](std::string& line) {
    if (at >= text.size()) return false;
    const std::size_t end = std::min(text.find('\n', at), text.size());
    line.assign(text.substr(at, end - at));
    at = end + 1;
    return true;
  };
  std::string line;
  if (!getline(line) || line != kCheckpointStateHeader) {
    return damaged("not a pbdam build checkpoint of this version");
  }
  CheckpointState state;
  bool sawEnd = false;
  while (getline(line)) {
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
    } else if (key == "assembly-freed-levels") {
      state.assemblyFreedLevels = value == "yes";
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
  return state;
}

// ---- Part-file payloads.

std::vector<std::byte> encodeLevelPartFooter(const LevelPartFooter& footer) {
  ByteWriter w;
  w.put(footer.firstDiamond);
  w.put(footer.diamonds);
  w.put(footer.nodes);
  w.put(footer.insertedPoints);
  w.put(footer.halvesOverTarget);
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
  footer.nodes = r.get<std::uint64_t>();
  footer.insertedPoints = r.get<std::uint64_t>();
  footer.halvesOverTarget = r.get<std::uint64_t>();
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

void putTileEntry(ByteWriter& w, float textureErrorMeters, std::span<const std::byte> colour,
                  std::span<const std::byte> normal) {
  w.put(textureErrorMeters);
  w.put(static_cast<std::uint32_t>(colour.size()));
  w.put(static_cast<std::uint32_t>(normal.size()));
  w.putBytes(colour);
  w.putBytes(normal);
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
    // A carry keeps only hypotenuse points: no indices, and memcpy must not see null pointers.
    if (!run.empty()) std::memcpy(p.indices.data(), run.data(), run.size());
  } else {
    for (std::size_t k = 0; k < indices; ++k) {
      std::uint16_t v = 0;
      std::memcpy(&v, run.data() + 2 * k, 2);
      p.indices[k] = v;
    }
  }
  // Whole triangles of the record's own points: the simplifier indexes `points` with these.
  if (indices % 3 != 0) return false;
  return std::all_of(p.indices.begin(), p.indices.end(),
                     [&](std::uint32_t index) { return index < points; });
}

constexpr std::size_t kCarryIndexEntryBytes = 16;  // node id, record offset

}  // namespace

void putCarryRecord(ByteWriter& w, const CarrySaturation& saturation, const WorkPatch* patch) {
  w.put(saturation.errorMeters);
  w.put(saturation.sphereCenter.x);
  w.put(saturation.sphereCenter.y);
  w.put(saturation.sphereCenter.z);
  w.put(saturation.sphereRadiusMeters);
  w.put(saturation.floorMeters);
  w.put(static_cast<std::uint8_t>(patch != nullptr ? 1 : 0));
  if (patch == nullptr) return;
  putPatch(w, *patch);
  w.put(static_cast<std::uint32_t>(patch->sampleErrorMeters.size()));
  w.putBytes(std::as_bytes(std::span<const float>(patch->sampleErrorMeters)));
}

bool getCarryRecord(ByteReader& r, CarrySaturation& saturation, WorkPatch* patch) {
  saturation.errorMeters = r.get<float>();
  saturation.sphereCenter.x = r.get<double>();
  saturation.sphereCenter.y = r.get<double>();
  saturation.sphereCenter.z = r.get<double>();
  saturation.sphereRadiusMeters = r.get<float>();
  saturation.floorMeters = r.get<float>();
  const bool hasPatch = r.get<std::uint8_t>() != 0;
  if (patch != nullptr) {
    if (!hasPatch) return false;
    *patch = WorkPatch{};
    if (!getPatch(r, *patch)) return false;
    const auto errors = r.get<std::uint32_t>();
    // None, or one a triangle.
    if (r.failed() || (errors != 0 && errors != patch->indices.size() / 3)) return false;
    const auto run = r.take(std::size_t{errors} * sizeof(float));
    if (r.failed()) return false;
    patch->sampleErrorMeters.resize(errors);
    if (errors > 0) std::memcpy(patch->sampleErrorMeters.data(), run.data(), run.size());
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

}  // namespace pbdam::builder
