// The void map's bytes (VoidMap.h; layout in formats/VoidMap.md).
#include "pbdam/formats/VoidMap.h"

#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <type_traits>

#include "pbdam/formats/Checksum.h"

namespace pbdam::formats {
namespace {

constexpr char kMagic[8] = {'P', 'B', 'D', 'V', 'O', 'I', 'D', 'S'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kSurfaceBytes = 4 * 8 + 3 * 4;  // spacing/origin, width, height, runs
constexpr std::size_t kRunBytes = 16;

template <typename T>
void put(std::vector<std::byte>& out, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::byte b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));  // little-endian hosts only (the dataset format's rule)
  out.insert(out.end(), b, b + sizeof(T));
}

class Reader final {
 public:
  explicit Reader(std::span<const std::byte> bytes) : bytes_(bytes) {}
  std::size_t offset() const noexcept { return at_; }
  std::size_t left() const noexcept { return bytes_.size() - at_; }
  template <typename T>
  T get() noexcept {
    T value;
    std::memcpy(&value, bytes_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }

 private:
  std::span<const std::byte> bytes_;
  std::size_t at_ = 0;
};

}  // namespace

std::optional<VoidKind> VoidGrid::at(double lat, double lon) const noexcept {
  if (width == 0 || height == 0 || !std::isfinite(lat) || !std::isfinite(lon)) return std::nullopt;
  const double row = std::round((firstLatDegrees - lat) / latSpacingDegrees);
  double dl = std::fmod(lon - firstLonDegrees + 0.5 * lonSpacingDegrees, 360.0);
  if (dl < 0.0) dl += 360.0;
  const double col = std::floor(dl / lonSpacingDegrees);
  if (!(row >= 0.0 && row < height && col >= 0.0 && col < width)) return std::nullopt;
  const auto r = static_cast<std::uint32_t>(row), c = static_cast<std::uint32_t>(col);
  // The last run that starts at or before (r, c).
  std::size_t lo = 0, hi = runs.size();
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    const VoidRun& m = runs[mid];
    if (m.row < r || (m.row == r && m.column <= c)) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo == 0) return std::nullopt;
  const VoidRun& run = runs[lo - 1];
  if (run.row == r && c < run.column + run.length) return run.kind;
  return std::nullopt;
}

std::vector<std::byte> encodeVoidMap(const VoidMap& map) {
  std::vector<std::byte> out;
  for (const char c : kMagic) out.push_back(static_cast<std::byte>(c));
  put(out, kVersion);
  put(out, static_cast<std::uint32_t>(map.surfaces.size()));
  for (const VoidGrid& g : map.surfaces) {
    put(out, g.firstLatDegrees);
    put(out, g.firstLonDegrees);
    put(out, g.latSpacingDegrees);
    put(out, g.lonSpacingDegrees);
    put(out, g.width);
    put(out, g.height);
    put(out, static_cast<std::uint32_t>(g.runs.size()));
    for (const VoidRun& r : g.runs) {
      put(out, r.row);
      put(out, r.column);
      put(out, r.length);
      put(out, static_cast<std::uint32_t>(r.kind));
    }
  }
  put(out, crc32(out));
  return out;
}

Result<VoidMap> decodeVoidMap(std::span<const std::byte> bytes, std::string_view context) {
  const auto fail = [&](std::size_t offset, const std::string& what) {
    return makeError(ErrorCode::CorruptData,
                     std::string(context) + " at byte " + std::to_string(offset) + ": " + what);
  };
  if (bytes.size() < sizeof kMagic + 12 || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
    return fail(0, "not a pbdam void map");
  }
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (crc32(bytes.first(bytes.size() - 4)) != stored) {
    return fail(bytes.size() - 4, "checksum mismatch (the file was modified or damaged)");
  }
  Reader in(bytes.first(bytes.size() - 4));
  (void)in.get<std::array<char, 8>>();
  if (const auto version = in.get<std::uint32_t>(); version != kVersion) {
    return fail(8, "version " + std::to_string(version) + " (this pbdam reads version " +
                       std::to_string(kVersion) + ")");
  }
  const auto surfaces = in.get<std::uint32_t>();
  if (surfaces > 64) return fail(12, "more surfaces than a manifest's insets");
  VoidMap map;
  for (std::uint32_t s = 0; s < surfaces; ++s) {
    const std::size_t at = in.offset();
    if (in.left() < kSurfaceBytes) return fail(at, "truncated");
    VoidGrid g;
    g.firstLatDegrees = in.get<double>();
    g.firstLonDegrees = in.get<double>();
    g.latSpacingDegrees = in.get<double>();
    g.lonSpacingDegrees = in.get<double>();
    g.width = in.get<std::uint32_t>();
    g.height = in.get<std::uint32_t>();
    const auto count = in.get<std::uint32_t>();
    if (!std::isfinite(g.firstLatDegrees) || !std::isfinite(g.firstLonDegrees) ||
        !(g.latSpacingDegrees > 0.0 && g.latSpacingDegrees <= 180.0) ||
        !(g.lonSpacingDegrees > 0.0 && g.lonSpacingDegrees <= 360.0)) {
      return fail(at, "a surface's georeference is not finite and positive");
    }
    if (count > in.left() / kRunBytes) return fail(at, "more runs than the file holds");
    g.runs.reserve(count);
    for (std::uint32_t k = 0; k < count; ++k) {
      const std::size_t runAt = in.offset();
      VoidRun r;
      r.row = in.get<std::uint32_t>();
      r.column = in.get<std::uint32_t>();
      r.length = in.get<std::uint32_t>();
      const auto kind = in.get<std::uint32_t>();
      if (kind != 1 && kind != 2) return fail(runAt, "unknown void kind " + std::to_string(kind));
      r.kind = static_cast<VoidKind>(kind);
      if (r.length == 0 || r.row >= g.height || r.column >= g.width ||
          r.length > g.width - r.column) {
        return fail(runAt, "a run lies outside its grid");
      }
      if (!g.runs.empty()) {
        const VoidRun& last = g.runs.back();
        if (r.row < last.row || (r.row == last.row && r.column < last.column + last.length)) {
          return fail(runAt, "runs out of order or overlapping");
        }
      }
      g.runs.push_back(r);
    }
    map.surfaces.push_back(std::move(g));
  }
  if (in.left() != 0) return fail(in.offset(), "bytes after the last surface");
  return map;
}

}  // namespace pbdam::formats
