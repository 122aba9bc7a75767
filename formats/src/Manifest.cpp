// manifest.json reading and writing (Manifest.h) with nlohmann::json.
#include "pbdam/formats/Manifest.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"

namespace pbdam::formats {

namespace {

nlohmann::ordered_json insetsJson(const Manifest& m) {
  nlohmann::ordered_json insets = nlohmann::ordered_json::array();
  for (const ManifestInset& i : m.insets) {
    insets.push_back({{"file", i.file},
                      {"format", i.format},
                      {"samples", i.samples},
                      {"bounds", {i.southDegrees, i.westDegrees, i.northDegrees, i.eastDegrees}},
                      {"leaf_level", i.leafLevel},
                      {"band_samples", i.bandSamples},
                      {"offset_m", i.offsetMeters},
                      {"texture", i.texture}});
  }
  return insets;
}

}  // namespace

std::string manifestInsetsJson(const Manifest& manifest) { return insetsJson(manifest).dump(); }

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
                  {"normal_format", m.textureNormalFormat},
                  {"source", m.textureSource}};
  j["source"] = {{"dem", m.sourceDem},
                 {"format", m.sourceFormat},
                 {"samples", m.sourceSamples},
                 {"min_height_m", m.minHeightMeters},
                 {"max_height_m", m.maxHeightMeters}};
  if (!m.insets.empty()) j["insets"] = insetsJson(m);
  if (m.voids) {
    j["voids"] = {{"file", m.voids->file}, {"bytes", m.voids->bytes}, {"crc32", m.voids->crc32}};
  }
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

namespace {

/// A field of the wrong kind of number, by its name.
struct BadNumber final {
  std::string field;
};

/// An unsigned integer field: a JSON integer from 0 to T's maximum. nlohmann's get<T>() would
/// convert a float, a negative or a larger number silently (or, for a float out of T's range,
/// with undefined behaviour).
template <class T>
T unsignedField(const nlohmann::ordered_json& parent, const char* key) {
  const auto& v = parent.at(key);
  if (!v.is_number_unsigned() || v.get<std::uint64_t>() > std::numeric_limits<T>::max()) {
    throw BadNumber{key};
  }
  return static_cast<T>(v.get<std::uint64_t>());
}

/// A finite number field.
double finiteField(const nlohmann::ordered_json& parent, const char* key) {
  const auto& v = parent.at(key);
  if (!v.is_number() || !std::isfinite(v.get<double>())) throw BadNumber{key};
  return v.get<double>();
}

/// Reads the `texture` object into `m`; returns what is wrong with it (empty when nothing is):
/// the normal maps' format must go with the colour tiles' and their sizes halve.
std::string readTexture(const nlohmann::ordered_json& t, Manifest& m) {
  m.textureLevels = unsignedField<std::uint32_t>(t, "levels");
  m.textureTileTexels = unsignedField<std::uint32_t>(t, "tile_texels");
  m.textureBorderTexels = unsignedField<std::uint32_t>(t, "border_texels");
  m.textureFormat = t.at("format").get<std::string>();
  m.textureNormalFormat = t.at("normal_format").get<std::string>();
  m.textureSource = t.at("source").get<std::string>();
  if ((m.textureFormat != "bc1" || m.textureNormalFormat != "bc5") &&
      (m.textureFormat != "rgba8" || m.textureNormalFormat != "rg8")) {
    return "texture format '" + m.textureFormat + "' with normal format '" + m.textureNormalFormat +
           "' (expected bc1 with bc5, or rgba8 with rg8)";
  }
  if (m.textureTileTexels % 2 != 0 || m.textureBorderTexels % 2 != 0 ||
      (m.textureNormalFormat == "bc5" && m.textureTileTexels % 8 != 0)) {
    return "texture tiles of " + std::to_string(m.textureTileTexels) + " texels, border " +
           std::to_string(m.textureBorderTexels) +
           ": normal-map tiles are half as large, so both must be even (the side a multiple of 8 "
           "for bc5)";
  }
  return {};
}

}  // namespace

Result<Manifest> parseManifest(std::string_view text, std::string_view context) {
  const auto fail = [&](const std::string& what) {
    return makeError(ErrorCode::CorruptData, std::string(context) + ": " + what);
  };
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return fail("not valid JSON");
  try {
    if (!j.contains("checksum")) return fail("no checksum field");
    const auto stored = unsignedField<std::uint32_t>(j, "checksum");
    j.erase("checksum");
    const std::string body = j.dump(2);
    if (crc32(std::as_bytes(std::span<const char>(body.data(), body.size()))) != stored) {
      return fail("checksum mismatch (the manifest was modified or damaged)");
    }
    if (j.value("format", "") != kManifestFormatName) return fail("not a pbdam dataset manifest");
    Manifest m;
    m.version = unsignedField<std::uint32_t>(j, "version");
    if (m.version != kDatasetFormatVersion) {
      return fail("format version " + std::to_string(m.version) + " (this pbdam reads version " +
                  std::to_string(kDatasetFormatVersion) +
                  "); rebuild the dataset with this pbdam (pbdam build)");
    }
    m.planetSpec = j.at("planet").at("spec").get<std::string>();
    m.equatorialRadiusMeters = finiteField(j.at("planet"), "equatorial_radius_m");
    m.flattening = finiteField(j.at("planet"), "flattening");
    m.cubeMap = j.at("cube_map").get<std::string>();
    m.latticeCells = unsignedField<std::uint32_t>(j, "lattice_cells");
    m.leafCells = unsignedField<std::uint32_t>(j, "leaf_cells");
    m.depth = unsignedField<std::uint32_t>(j, "depth");
    m.minPatchTriangles = unsignedField<std::uint32_t>(j, "min_patch_triangles");
    m.errorMargin = finiteField(j, "error_margin");
    m.heightStepMeters = finiteField(j, "height_step_m");
    if (const std::string wrong = readTexture(j.at("texture"), m); !wrong.empty()) {
      return fail(wrong);
    }
    const auto& s = j.at("source");
    m.sourceDem = s.at("dem").get<std::string>();
    m.sourceFormat = s.at("format").get<std::string>();
    m.sourceSamples = unsignedField<std::uint64_t>(s, "samples");
    m.minHeightMeters = finiteField(s, "min_height_m");
    m.maxHeightMeters = finiteField(s, "max_height_m");
    if (j.contains("insets")) {
      const auto& insets = j.at("insets");
      if (!insets.is_array() || insets.size() > 64) return fail("'insets' must list up to 64");
      for (const auto& e : insets) {
        ManifestInset i;
        i.file = e.at("file").get<std::string>();
        i.format = e.at("format").get<std::string>();
        i.samples = unsignedField<std::uint64_t>(e, "samples");
        const auto& b = e.at("bounds");
        if (!b.is_array() || b.size() != 4) return fail("an inset's 'bounds' must be S, W, N, E");
        for (std::size_t k = 0; k < 4; ++k) {
          if (!b[k].is_number() || !std::isfinite(b[k].get<double>())) {
            return fail("an inset's 'bounds' must be finite numbers");
          }
        }
        i.southDegrees = b[0].get<double>();
        i.westDegrees = b[1].get<double>();
        i.northDegrees = b[2].get<double>();
        i.eastDegrees = b[3].get<double>();
        i.leafLevel = unsignedField<std::uint32_t>(e, "leaf_level");
        i.bandSamples = unsignedField<std::uint32_t>(e, "band_samples");
        i.offsetMeters = finiteField(e, "offset_m");
        if (e.contains("texture")) {
          if (!e.at("texture").is_string()) return fail("an inset's 'texture' must be a string");
          i.texture = e.at("texture").get<std::string>();
        }
        if (i.file.empty() || i.file.find('/') != std::string::npos ||
            !(i.southDegrees <= i.northDegrees) || i.leafLevel > kMaxBintreeDepth ||
            i.texture.empty() || i.texture.find('/') != std::string::npos) {
          return fail("inset '" + i.file + "' is malformed");
        }
        m.insets.push_back(std::move(i));
      }
    }
    if (j.contains("voids")) {
      const auto& v = j.at("voids");
      ManifestFace file;
      file.file = v.at("file").get<std::string>();
      file.bytes = unsignedField<std::uint64_t>(v, "bytes");
      file.crc32 = unsignedField<std::uint32_t>(v, "crc32");
      if (file.file.empty() || file.file.find('/') != std::string::npos ||
          file.file.find("..") != std::string::npos || m.insets.empty()) {
        return fail("'voids' must name a plain file of a dataset with insets");
      }
      m.voids = std::move(file);
    }
    const auto& faces = j.at("faces");
    if (!faces.is_array() || faces.size() != 6) return fail("'faces' must list 6 files");
    for (std::size_t f = 0; f < 6; ++f) {
      m.faces[f].file = faces[f].at("file").get<std::string>();
      m.faces[f].bytes = unsignedField<std::uint64_t>(faces[f], "bytes");
      m.faces[f].crc32 = unsignedField<std::uint32_t>(faces[f], "crc32");
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
  } catch (const BadNumber& e) {
    return fail("field '" + e.field + "' is not a number in range");
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
