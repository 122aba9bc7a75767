// Camera-path CSV files (CameraPath.h).
#include "pbdam/formats/CameraPath.h"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

namespace pbdam::formats {
namespace {

constexpr std::array<std::string_view, 7> kColumns = {"t",       "lat",   "lon", "alt",
                                                      "heading", "pitch", "roll"};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::vector<std::string_view> splitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

bool parseFinite(std::string_view text, double& out) {
  if (text.empty()) return false;
  if (text.front() == '+') text.remove_prefix(1);
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc() && end == text.data() + text.size() && std::isfinite(out);
}

Error lineError(std::string_view name, std::size_t line, const std::string& what) {
  return makeError(ErrorCode::InvalidArgument,
                   std::string(name) + ":" + std::to_string(line) + ": " + what);
}

std::string shortest(double v) {
  std::array<char, 32> buf{};
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return ec == std::errc() ? std::string(buf.data(), end) : std::to_string(v);
}

}  // namespace

Result<std::vector<CameraPathPoint>> parseCameraPath(std::string_view text, std::string_view name) {
  std::vector<CameraPathPoint> points;
  std::size_t lineNumber = 0;
  std::size_t start = 0;
  bool header = false;
  while (start <= text.size()) {
    const std::size_t newline = text.find('\n', start);
    const std::string_view raw = text.substr(
        start, newline == std::string_view::npos ? std::string_view::npos : newline - start);
    start = newline == std::string_view::npos ? text.size() + 1 : newline + 1;
    ++lineNumber;
    const std::string_view line = trim(raw);
    if (!header) {
      const std::vector<std::string_view> names = splitFields(line);
      bool ok = names.size() == kColumns.size();
      for (std::size_t i = 0; ok && i < names.size(); ++i) ok = names[i] == kColumns[i];
      if (!ok) {
        return lineError(name, lineNumber,
                         "expected the header '" + std::string(kCameraPathHeader) + "', got '" +
                             std::string(line.substr(0, 80)) + "'");
      }
      header = true;
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string_view> fields = splitFields(line);
    if (fields.size() != kColumns.size()) {
      return lineError(name, lineNumber,
                       "expected 7 comma-separated numbers (t,lat,lon,alt,heading,pitch,roll), "
                       "got " +
                           std::to_string(fields.size()) + " fields");
    }
    std::array<double, 7> v{};
    for (std::size_t i = 0; i < fields.size(); ++i) {
      if (!parseFinite(fields[i], v[i])) {
        return lineError(name, lineNumber,
                         std::string(kColumns[i]) + " '" + std::string(fields[i].substr(0, 40)) +
                             "' is not a finite number");
      }
    }
    const CameraPathPoint point{v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
    if (!points.empty() && !(point.tSeconds > points.back().tSeconds)) {
      return lineError(
          name, lineNumber,
          "t = " + shortest(point.tSeconds) +
              " does not increase (previous row: t = " + shortest(points.back().tSeconds) + ")");
    }
    points.push_back(point);
  }
  if (!header) return lineError(name, 1, "empty file, expected a camera-path header");
  if (points.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     std::string(name) + ": no camera poses after the header");
  }
  return points;
}

Result<std::vector<CameraPathPoint>> readCameraPath(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return makeError(ErrorCode::NotFound, path.string() + ": camera path file not found");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(ErrorCode::IoError, path.string() + ": cannot open camera path");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return makeError(ErrorCode::IoError, path.string() + ": read failed");
  return parseCameraPath(text.str(), path.string());
}

std::string formatCameraPath(const std::vector<CameraPathPoint>& points) {
  std::string out(kCameraPathHeader);
  out += '\n';
  for (const CameraPathPoint& p : points) {
    for (const double v : {p.tSeconds, p.latDegrees, p.lonDegrees, p.altitudeMeters,
                           p.headingDegrees, p.pitchDegrees}) {
      out += shortest(v);
      out += ',';
    }
    out += shortest(p.rollDegrees);
    out += '\n';
  }
  return out;
}

Result<void> writeCameraPath(const std::filesystem::path& path,
                             const std::vector<CameraPathPoint>& points) {
  const std::string text = formatCameraPath(points);
  std::filesystem::path temporary = path;
  temporary += ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    return makeError(ErrorCode::IoError,
                     temporary.string() + ": cannot create (" + std::strerror(errno) + ")");
  }
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    written += static_cast<std::size_t>(n);
  }
  const bool ok = written == text.size() && ::fsync(fd) == 0;
  if (::close(fd) != 0 || !ok) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::IoError, temporary.string() + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::IoError, path.string() + ": rename failed (" + ec.message() + ")");
  }
  return {};
}

}  // namespace pbdam::formats
