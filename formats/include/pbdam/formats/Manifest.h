// manifest.json of a dataset directory (formats/FORMAT.md): what the six face files are, how they
// were built, and their sizes and checksums. Written last by the builder, so a directory without
// a valid manifest is never taken for a complete dataset. Thread-safety: plain values.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// The manifest's file name inside a dataset directory.
inline constexpr std::string_view kManifestFileName = "manifest.json";
/// The manifest's "format" value, which marks a JSON file as a pbdam dataset's.
inline constexpr std::string_view kManifestFormatName = "pbdam-dataset";

/// One face file as the manifest records it.
struct ManifestFace final {
  std::string file;         ///< name inside the dataset directory, e.g. "face0.pbdam"
  std::uint64_t bytes = 0;  ///< the file's size
  std::uint32_t crc32 = 0;  ///< CRC-32 of the whole file
};

/// A local high-resolution DEM the dataset joins to its base (docs/builder.md "Insets").
struct ManifestInset final {
  std::string file;           ///< file name (no directories)
  std::string format;         ///< GDAL driver
  std::uint64_t samples = 0;  ///< its valid samples
  /// Its footprint: south, west, north and east edges in degrees.
  /// @{
  double southDegrees = 0.0, westDegrees = 0.0, northDegrees = 0.0, eastDegrees = 0.0;
  /// @}
  std::uint32_t leafLevel = 0;            ///< the level of the leaves over it
  std::uint32_t bandSamples = 0;          ///< the transition band's width inside its footprint
  double offsetMeters = 0.0;              ///< added to its heights
  std::string texture = "shaded-relief";  ///< its imagery's file name, or "shaded-relief"
};

/// A dataset's manifest.json: its planet, the lattice and trees the builder made, the texture
/// settings, the source DEM and its insets, and the six face files' sizes and CRCs.
struct Manifest final {
  std::uint32_t version = 0;            ///< the face files' format version (kDatasetFormatVersion)
  std::string planetSpec;               ///< Planet::fromSpec form, e.g. "mars", "earth"
  double equatorialRadiusMeters = 0.0;  ///< the planet's equatorial radius
  double flattening = 0.0;              ///< the planet's flattening (0 for a sphere)
  std::string cubeMap = "tangent";      ///< the cube-map kind (runtime/CubeMap.h)
  std::uint32_t latticeCells = 0;       ///< N: lattice cells per face side
  std::uint32_t leafCells = 0;          ///< L: leaf leg length in cells
  std::uint32_t depth = 0;              ///< D: deepest bintree level
  std::uint32_t minPatchTriangles = 0;  ///< the fewest triangles of a simplified patch
  double errorMargin = 0.0;             ///< r: a level's error ≥ (1 + r) × its children's
  double heightStepMeters = 0.0;        ///< metres per unit of a patch vertex's heightSteps
  std::uint32_t textureLevels = 0;      ///< texture quadtree levels
  std::uint32_t textureTileTexels = 0;  ///< texels on a tile's side, its border included
  std::uint32_t textureBorderTexels = 0;  ///< texels of border on each side of a tile
  std::string textureFormat;              ///< "rgba8" or "bc1"
  /// The normal-map tiles' texel format: "bc5" beside bc1 colour tiles, "rg8" beside rgba8.
  /// Their side and border are half the colour tiles' (normalTileTexels, normalBorderTexels).
  std::string textureNormalFormat;
  /// Texels on a normal-map tile's side, its border included: half the colour tile's, so that
  /// the same texture coordinates address both (formats/FORMAT.md "Texture table").
  std::uint32_t normalTileTexels() const noexcept { return textureTileTexels / 2; }
  /// Texels of border on each side of a normal-map tile.
  std::uint32_t normalBorderTexels() const noexcept { return textureBorderTexels / 2; }
  std::string textureSource;          ///< "shaded-relief" or "image:<file name>"
  std::string sourceDem;              ///< file name of the DEM (no directories: builds elsewhere
                                      ///< give the same bytes)
  std::string sourceFormat;           ///< GDAL driver of the DEM
  std::uint64_t sourceSamples = 0;    ///< the DEM's valid samples
  double minHeightMeters = 0.0;       ///< over the lattice
  double maxHeightMeters = 0.0;       ///< over the lattice
  std::array<ManifestFace, 6> faces;  ///< the face files, in face order (runtime/CubeMap.h)
  /// Insets joined to the source DEM; written (as "insets") only when there are some.
  std::vector<ManifestInset> insets;
  /// Where the insets' voids were and what they became (formats/VoidMap.h): written (as
  /// "voids") only when an inset had voids. Readers that predate it ignore it.
  std::optional<ManifestFace> voids;
};

/// The manifest as pretty-printed JSON (stable key order: byte-identical for equal manifests).
std::string manifestToJson(const Manifest& manifest);

/// The manifest's "insets" array as JSON text (what manifestToJson writes under that key; "[]"
/// when there are none), for commands that print it.
std::string manifestInsetsJson(const Manifest& manifest);

/// Parses and checks a manifest: format name, version, six faces, positive sizes. `context`
/// names the file in errors.
Result<Manifest> parseManifest(std::string_view json, std::string_view context);

/// Reads DIR/manifest.json; NotFound when the directory has none (an incomplete dataset).
Result<Manifest> readManifest(const std::filesystem::path& datasetDir);

}  // namespace pbdam::formats
