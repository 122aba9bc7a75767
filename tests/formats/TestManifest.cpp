// The manifest reader (Manifest.h): a written manifest reads back, and numbers of the wrong kind
// behind a right checksum are rejected by name, never converted.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"

using namespace pbdam::formats;

namespace {

Manifest sampleManifest() {
  Manifest m;
  m.version = kDatasetFormatVersion;
  m.planetSpec = "mars";
  m.equatorialRadiusMeters = 3396190.0;
  m.latticeCells = 16;
  m.leafCells = 8;
  m.depth = 2;
  m.minPatchTriangles = 16;
  m.errorMargin = 0.25;
  m.heightStepMeters = 1.0 / 64.0;
  m.textureLevels = 1;
  m.textureTileTexels = 16;
  m.textureBorderTexels = 2;
  m.textureFormat = "bc1";
  m.textureNormalFormat = "bc5";
  m.textureSource = "shaded-relief";
  m.sourceDem = "megt90n000cb.lbl";
  m.sourceFormat = "PDS";
  m.sourceSamples = 1036800;
  for (std::size_t f = 0; f < 6; ++f) {
    m.faces[f] = ManifestFace{"face" + std::to_string(f) + ".pbdam", 12944, 7};
  }
  return m;
}

/// `text` with one field replaced by `value` (a JSON pointer) and its checksum made right.
std::string withField(const std::string& text, const std::string& pointer,
                      const std::string& value) {
  auto j = nlohmann::ordered_json::parse(text);
  j[nlohmann::ordered_json::json_pointer(pointer)] = nlohmann::ordered_json::parse(value);
  j.erase("checksum");
  const std::string body = j.dump(2);
  j["checksum"] = crc32(std::as_bytes(std::span<const char>(body.data(), body.size())));
  return j.dump(2);
}

}  // namespace

TEST(Manifest, AWrittenManifestReadsBack) {
  const std::string text = manifestToJson(sampleManifest());
  const auto m = parseManifest(text, "test");
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->latticeCells, 16u);
  EXPECT_EQ(m->sourceSamples, 1036800u);
  EXPECT_EQ(m->faces[5].file, "face5.pbdam");
}

TEST(Manifest, NumbersOfTheWrongKindAreRejectedByName) {
  const std::string text = manifestToJson(sampleManifest());
  const struct {
    const char* pointer;
    const char* value;
    const char* field;
  } cases[] = {
      {"/source/samples", "1.0366666666666667e22", "samples"},  // a float past uint64
      {"/source/samples", "-5", "samples"},
      {"/lattice_cells", "16.5", "lattice_cells"},
      {"/lattice_cells", "4294967312", "lattice_cells"},  // 2^32 + 16 would truncate to 16
      {"/faces/2/bytes", "-1", "bytes"},
      {"/texture/levels", "true", "levels"},
      {"/height_step_m", "\"0.5\"", "height_step_m"},
  };
  for (const auto& c : cases) {
    const auto m = parseManifest(withField(text, c.pointer, c.value), "test");
    ASSERT_FALSE(m) << c.pointer << " = " << c.value;
    EXPECT_NE(m.error().message.find(std::string("'") + c.field + "'"), std::string::npos)
        << m.error().message;
  }
}

// The normal-map tiles (dataset version 5) are half the colour tiles' size and have the format
// that goes with theirs: any other pairing, or a size that cannot be halved, is refused by name.
TEST(Manifest, NormalMapTilesMustMatchTheColourTiles) {
  const std::string text = manifestToJson(sampleManifest());
  const auto m = parseManifest(text, "test");
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->textureNormalFormat, "bc5");
  EXPECT_EQ(m->normalTileTexels(), 8u);
  EXPECT_EQ(m->normalBorderTexels(), 1u);
  const struct {
    const char* pointer;
    const char* value;
    const char* says;
  } cases[] = {
      {"/texture/normal_format", "\"rg8\"", "expected bc1 with bc5"},
      {"/texture/normal_format", "\"bc1\"", "expected bc1 with bc5"},
      {"/texture/format", "\"rgba8\"", "expected bc1 with bc5"},
      {"/texture/tile_texels", "20", "multiple of 8 for bc5"},
      {"/texture/border_texels", "3", "must be even"},
  };
  for (const auto& c : cases) {
    const auto bad = parseManifest(withField(text, c.pointer, c.value), "test");
    ASSERT_FALSE(bad) << c.pointer << " = " << c.value;
    EXPECT_NE(bad.error().message.find(c.says), std::string::npos) << bad.error().message;
  }
  auto j = nlohmann::ordered_json::parse(text);
  j["texture"].erase("normal_format");
  j.erase("checksum");
  const std::string body = j.dump(2);
  j["checksum"] = crc32(std::as_bytes(std::span<const char>(body.data(), body.size())));
  const auto missing = parseManifest(j.dump(2), "test");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("normal_format"), std::string::npos)
      << missing.error().message;
}

TEST(Manifest, InsetsAreWrittenOnlyWhenThereAreSomeAndReadBack) {
  Manifest m = sampleManifest();
  EXPECT_EQ(manifestToJson(m).find("insets"), std::string::npos);
  ManifestInset inset;
  inset.file = "terra_elev_luxembourg.tif";
  inset.format = "GTiff (GeoTIFF)";
  inset.samples = 4608;
  inset.southDegrees = 49.44;
  inset.westDegrees = 5.74;
  inset.northDegrees = 50.19;
  inset.eastDegrees = 6.53;
  inset.leafLevel = 20;
  inset.bandSamples = 16;
  inset.offsetMeters = -1.5;
  m.insets.push_back(inset);
  const std::string text = manifestToJson(m);
  const auto back = parseManifest(text, "test");
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_EQ(back->insets.size(), 1u);
  EXPECT_EQ(back->insets[0].file, inset.file);
  EXPECT_EQ(back->insets[0].samples, 4608u);
  EXPECT_EQ(back->insets[0].northDegrees, 50.19);
  EXPECT_EQ(back->insets[0].leafLevel, 20u);
  EXPECT_EQ(back->insets[0].offsetMeters, -1.5);
  EXPECT_EQ(manifestToJson(*back), text);
  // Malformed ones are refused by name.
  for (const auto& [pointer, value] :
       std::vector<std::pair<std::string, std::string>>{{"/insets/0/bounds", "[1, 2, 3]"},
                                                        {"/insets/0/bounds", "[50, 2, 49, 3]"},
                                                        {"/insets/0/file", "\"../etc/passwd\""},
                                                        {"/insets/0/leaf_level", "99"},
                                                        {"/insets/0/samples", "-1"},
                                                        {"/insets", "{}"}}) {
    const auto bad = parseManifest(withField(text, pointer, value), "test");
    EXPECT_FALSE(bad) << pointer << " = " << value;
  }
}
