// manifest.json reading and writing (Manifest.h) with nlohmann::json.
#include "pbdam/formats/Manifest.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <sstream>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"

namespace pbdam::formats {

std::string manifestToJson(const Manifest& m) {
  nlohmann::ordered_json j;
  j["format"] = kManifestFormatName;
  j["version"] = m.version;
  j["planet"] = {{"spec", m.planetSpec},
                 {"equatorial_radius_m", m.equatorialRadiusMeters},
                 {"flattening", m.flattening}};
  j["cube_map"] = m.cubeMap;
  j["lattice_cells"] = m.latticeCells;
  j["leaf_cells"] = m.leafCells;
  j["depth"] = m.depth;
  j["min_patch_triangles"] = m.minPatchTriangles;
  j["error_margin"] = m.errorMargin;
  j["height_step_m"] = m.heightStepMeters;
  j["texture"] = {{"levels", m.textureLevels},
                  {"tile_texels", m.textureTileTexels},
                  {"border_texels", m.textureBorderTexels},
                  {"format", m.textureFormat},
                  {"source", m.textureSource}};
  j["source"] = {{"dem", m.sourceDem},
                 {"format", m.sourceFormat},
                 {"samples", m.sourceSamples},
                 {"min_height_m", m.minHeightMeters},
                 {"max_height_m", m.maxHeightMeters}};
  nlohmann::ordered_json faces = nlohmann::ordered_json::array();
  for (const ManifestFace& f : m.faces) {
    faces.push_back({{"file", f.file}, {"bytes", f.bytes}, {"crc32", f.crc32}});
  }
  j["faces"] = faces;
  // A checksum of the manifest itself: CRC-32 of this same dump without the checksum field.
  const std::string body = j.dump(2);
  j["checksum"] = crc32(std::as_bytes(std::span<const char>(body.data(), body.size())));
  return j.dump(2) + "\n";
}

Result<Manifest> parseManifest(std::string_view text, std::string_view context) {
  const auto fail = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData, std::string(context) + ": " + what);
  };
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return fail("not valid JSON");
  try {
    if (!j.contains("checksum")) return fail("no checksum field");
    const auto stored = j.at("checksum").get<std::uint32_t>();
    j.erase("checksum");
    const std::string body = j.dump(2);
    if (crc32(std::as_bytes(std::span<const char>(body.data(), body.size()))) != stored) {
      return fail("checksum mismatch (the manifest was modified or damaged)");
    }
    if (j.value("format", "") != kManifestFormatName) return fail("not a pbdam dataset manifest");
    Manifest m;
    m.version = j.at("version").get<std::uint32_t>();
    if (m.version != kDatasetFormatVersion) {
      return fail("format version " + std::to_string(m.version) + " (this pbdam reads version " +
                  std::to_string(kDatasetFormatVersion) +
                  "); rebuild the dataset with this pbdam (pbdam build)");
    }
    m.planetSpec = j.at("planet").at("spec").get<std::string>();
    m.equatorialRadiusMeters = j.at("planet").at("equatorial_radius_m").get<double>();
    m.flattening = j.at("planet").at("flattening").get<double>();
    m.cubeMap = j.at("cube_map").get<std::string>();
    m.latticeCells = j.at("lattice_cells").get<std::uint32_t>();
    m.leafCells = j.at("leaf_cells").get<std::uint32_t>();
    m.depth = j.at("depth").get<std::uint32_t>();
    m.minPatchTriangles = j.at("min_patch_triangles").get<std::uint32_t>();
    m.errorMargin = j.at("error_margin").get<double>();
    m.heightStepMeters = j.at("height_step_m").get<double>();
    const auto& t = j.at("texture");
    m.textureLevels = t.at("levels").get<std::uint32_t>();
    m.textureTileTexels = t.at("tile_texels").get<std::uint32_t>();
    m.textureBorderTexels = t.at("border_texels").get<std::uint32_t>();
    m.textureFormat = t.at("format").get<std::string>();
    m.textureSource = t.at("source").get<std::string>();
    const auto& s = j.at("source");
    m.sourceDem = s.at("dem").get<std::string>();
    m.sourceFormat = s.at("format").get<std::string>();
    m.sourceSamples = s.at("samples").get<std::uint64_t>();
    m.minHeightMeters = s.at("min_height_m").get<double>();
    m.maxHeightMeters = s.at("max_height_m").get<double>();
    const auto& faces = j.at("faces");
    if (!faces.is_array() || faces.size() != 6) return fail("'faces' must list 6 files");
    for (std::size_t f = 0; f < 6; ++f) {
      m.faces[f].file = faces[f].at("file").get<std::string>();
      m.faces[f].bytes = faces[f].at("bytes").get<std::uint64_t>();
      m.faces[f].crc32 = faces[f].at("crc32").get<std::uint32_t>();
      if (m.faces[f].file.empty() || m.faces[f].file.find('/') != std::string::npos ||
          m.faces[f].file.find("..") != std::string::npos) {
        return fail("face file name '" + m.faces[f].file + "' is not a plain file name");
      }
    }
    if (m.cubeMap != "tangent") return fail("unknown cube map '" + m.cubeMap + "'");
    if (m.equatorialRadiusMeters <= 0.0 || m.heightStepMeters <= 0.0 || m.latticeCells == 0 ||
        m.leafCells == 0 || m.depth > kMaxBintreeDepth || m.textureLevels > kMaxTextureLevels) {
      return fail("out-of-range numbers");
    }
    return m;
  } catch (const nlohmann::json::exception& e) {
    return fail(std::string("missing or mistyped field (") + e.what() + ")");
  }
}

Result<Manifest> readManifest(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / kManifestFileName;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return makeError(ErrorCode::NotFound,
                     path.string() + ": no manifest (not a dataset, or an incomplete build)");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return parseManifest(text.str(), path.string());
}

}  // namespace pbdam::formats
