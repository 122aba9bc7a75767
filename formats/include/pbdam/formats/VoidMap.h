// Where an inset's voids were and what the build put there: the dataset file `voids.bin`
// (formats/VoidMap.md), one record per inset surface in the manifest's order, each its grid's
// georeference and the runs of void samples along its rows, filled from the void's rim or left to
// the surface below (builder/VoidFill.h). `pbdam height` reads it to say whether a point lies
// in a filled void. Decoding is safe for untrusted input: bounds-checked, checksummed, errors
// name the file and the offset. Thread-safety: plain values; free functions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The file's name inside a dataset directory.
inline constexpr const char* kVoidMapFileName = "voids.bin";

/// What a void's samples became.
enum class VoidKind : std::uint32_t {
  FilledFromRim = 1,  ///< interpolated from the inset's own samples around it
  SurfaceBelow = 2,   ///< too large: the base (or a coarser inset) shows through
};

/// Consecutive void samples along one row of a surface's grid.
struct VoidRun final {
  std::uint32_t row = 0;                    ///< row 0 north
  std::uint32_t column = 0;                 ///< the first
  std::uint32_t length = 0;                 ///< ≥ 1
  VoidKind kind = VoidKind::FilledFromRim;  ///< what its samples became
  /// Field by field.
  bool operator==(const VoidRun&) const = default;
};

/// One inset surface's voids on its grid (GridGeometry's conventions: row 0 north, sample
/// centres at firstLat − row·latSpacing, firstLon + col·lonSpacing).
struct VoidGrid final {
  double firstLatDegrees = 0.0;    ///< latitude of the centre of row 0
  double firstLonDegrees = 0.0;    ///< longitude of the centre of column 0
  double latSpacingDegrees = 0.0;  ///< between rows, > 0
  double lonSpacingDegrees = 0.0;  ///< between columns, > 0
  std::uint32_t width = 0;         ///< columns
  std::uint32_t height = 0;        ///< rows
  std::vector<VoidRun> runs;       ///< sorted by (row, column), not overlapping
  /// Field by field, the runs included.
  bool operator==(const VoidGrid&) const = default;

  /// What the sample nearest (lat, lon) was, if it was a void's; nullopt outside the grid or
  /// on a valid sample. Longitude is taken modulo 360.
  std::optional<VoidKind> at(double latDegrees, double lonDegrees) const noexcept;
};

/// The contents of a dataset's voids.bin: for each inset surface, where its voids were and what
/// they became (docs/builder.md "Insets").
struct VoidMap final {
  std::vector<VoidGrid> surfaces;  ///< the manifest's insets, in its order
  /// Surface by surface.
  bool operator==(const VoidMap&) const = default;
};

/// The file's bytes: magic, version, the surfaces, a CRC-32 of everything before it.
std::vector<std::byte> encodeVoidMap(const VoidMap& map);

/// Parses and checks a void map: CorruptData naming `context` and the offset for bad magic,
/// another version, truncation, a checksum mismatch, runs out of their grid, unsorted or
/// overlapping, an unknown kind, non-finite or non-positive spacing.
Result<VoidMap> decodeVoidMap(std::span<const std::byte> bytes, std::string_view context);

}  // namespace pbdam::formats
