// Camera-path files (docs/architecture.md "Formats"): CSV with the header
// `t,lat,lon,alt,heading,pitch,roll` and one pose per row — seconds, degrees, metres above the
// reference surface, degrees — as `pbdam render --path` and the benchmarks replay them. Reading is
// strict and safe for untrusted files; the poses' ranges are checked where they are used
// (runtime/Camera.h validateCameraPose). Thread-safety: pure functions.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// One row of a camera path.
struct CameraPathPoint final {
  double tSeconds = 0.0;        ///< t: time of the pose from the path's start
  double latDegrees = 0.0;      ///< lat
  double lonDegrees = 0.0;      ///< lon
  double altitudeMeters = 0.0;  ///< alt: above the reference surface
  double headingDegrees = 0.0;  ///< heading: clockwise from north
  double pitchDegrees = -90.0;  ///< pitch: up from the horizon (−90 looks straight down)
  double rollDegrees = 0.0;     ///< roll: clockwise about the view direction

  /// Field by field.
  friend bool operator==(const CameraPathPoint&, const CameraPathPoint&) = default;
};

/// The header line every camera-path file starts with.
inline constexpr std::string_view kCameraPathHeader = "t,lat,lon,alt,heading,pitch,roll";

/// Parses camera-path CSV text. The first line must be the header (kCameraPathHeader; spaces
/// around names allowed); then each non-blank line holds exactly 7 finite decimal numbers
/// separated by commas (spaces around them allowed), with t strictly increasing; at least one
/// row. Line endings may be LF or CRLF. Errors are InvalidArgument "<name>:<line>: <what>".
Result<std::vector<CameraPathPoint>> parseCameraPath(std::string_view text, std::string_view name);

/// Reads and parses a camera-path file: NotFound when it does not exist, IoError when it cannot
/// be read, else as parseCameraPath with the file's path as name.
Result<std::vector<CameraPathPoint>> readCameraPath(const std::filesystem::path& path);

/// The CSV text of `points` (header first, numbers in shortest round-trip form, LF endings):
/// parseCameraPath gives the same points back.
std::string formatCameraPath(const std::vector<CameraPathPoint>& points);

/// Writes formatCameraPath(points) to `path` atomically (a temporary name, fsync, rename).
/// IoError naming the file on failure.
Result<void> writeCameraPath(const std::filesystem::path& path,
                             const std::vector<CameraPathPoint>& points);

}  // namespace pbdam::formats
