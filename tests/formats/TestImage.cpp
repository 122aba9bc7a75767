// Imagery ingest through OpenImageIO: the Debian-packaged Earth map and rejection of bad files.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <vector>

#include "TestData.h"
#include "Utm32GeoTiff.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/ImageCodec.h"
#include "pbdam/formats/Module.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

constexpr const char* kEarthImage = "/usr/share/xplanet/images/earth.jpg";

// OpenImageIO is a module loaded on first use (ImageCodec.h): it loads in a test executable too
// (found by name through the RUNPATH the build gives executables that link pbdam_formats), and a
// module that is nowhere is a NotFound naming every place looked at and why.
TEST(Image, TheCodecModuleLoadsAndAMissingModuleSaysWhereItLooked) {
  const Result<const ImageCodec*> codec = imageCodec();
  ASSERT_TRUE(codec.ok()) << codec.error().message;
  ASSERT_NE(*codec, nullptr);
  EXPECT_NE((*codec)->read, nullptr);

  const Result<void*> missing =
      openModule("libpbdam_nowhere.so", "/nonexistent/libpbdam_nowhere.so", RTLD_NOW);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
  const std::string& message = missing.error().message;
  EXPECT_NE(message.find("libpbdam_nowhere.so did not load"), std::string::npos) << message;
  EXPECT_NE(message.find("/nonexistent/libpbdam_nowhere.so: missing"), std::string::npos)
      << message;
  EXPECT_NE(message.find("libpbdam_nowhere.so by name: "), std::string::npos) << message;

  // A file that is not a shared object: dlopen's own reason.
  test::TempDir dir;
  const std::filesystem::path bogus = dir / "libpbdam_bogus.so";
  std::ofstream(bogus) << "not an ELF file";
  const Result<void*> refused = openModule("libpbdam_bogus.so", bogus, RTLD_NOW);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find(bogus.string() + ": "), std::string::npos)
      << refused.error().message;
  EXPECT_EQ(refused.error().message.find(bogus.string() + ": missing"), std::string::npos)
      << refused.error().message;
}

TEST(Image, ReadsTheEquirectangularEarth) {
  PBDAM_REQUIRE_DATA(path, kEarthImage);
  auto image = readImage(path);
  ASSERT_TRUE(image) << image.error().message;
  EXPECT_EQ(image->width(), 2048);
  EXPECT_EQ(image->height(), 1024);
  EXPECT_FALSE(image->georeferenced());
  EXPECT_DOUBLE_EQ(image->bounds().westDegrees, -180.0);
  // The Sahara is sand, the central Pacific is water.
  const auto sahara = *image->sampleBilinear(23.0, 10.0);
  const auto pacific = *image->sampleBilinear(0.0, -150.0);
  EXPECT_GT(sahara[0], sahara[2] + 30.0f);
  EXPECT_GT(pacific[2], pacific[0] + 20.0f);
  EXPECT_EQ(sahara[3], 255.0f);
  // The date line is continuous: samples just either side differ little.
  const auto east = *image->sampleBilinear(-20.0, 179.99);
  const auto west = *image->sampleBilinear(-20.0, -179.99);
  for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(east[c], west[c], 8.0f);
}

TEST(Image, RejectsTruncatedAndNonImageFiles) {
  PBDAM_REQUIRE_DATA(path, kEarthImage);
  test::TempDir dir;
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  bytes.resize(bytes.size() / 3);
  const auto cut = dir / "earth.jpg";
  std::ofstream(cut, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  auto r = readImage(cut);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("earth.jpg"), std::string::npos) << r.error().message;
  std::ofstream(dir / "x.png") << "not a png";
  auto notImage = readImage(dir / "x.png");
  ASSERT_FALSE(notImage);
  EXPECT_NE(notImage.error().message.find("x.png"), std::string::npos);
  EXPECT_FALSE(readImage(dir / "missing.jpg"));
}

TEST(Image, AProjectedGeoTiffIsWarpedToGeographicWithAlphaOutsideItsFootprint) {
  test::TempDir dir;
  const auto path = dir / "utm32.tif";
  // 100 km × 80 km on the rotated UTM 32N grid of Utm32GeoTiff.h: the western half red, the
  // eastern half blue.
  const int w = 100;
  const int h = 80;
  std::vector<std::vector<std::uint8_t>> bands(3, std::vector<std::uint8_t>(std::size_t{w} * h, 0));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto at = static_cast<std::size_t>(y) * w + static_cast<std::size_t>(x);
      (x < w / 2 ? bands[0] : bands[2])[at] = 255;
    }
  }
  ASSERT_TRUE(test::writeUtm32GeoTiff(path, w, h, GDT_Byte, bands));

  auto image = readImage(path);
  ASSERT_TRUE(image) << image.error().message;
  EXPECT_TRUE(image->georeferenced());
  // Points a quarter of the way in from the west and east edges, in latitude/longitude.
  const auto& gt = test::kUtm32Transform;
  double x[2] = {gt[0] + 0.25 * w * gt[1], gt[0] + 0.75 * w * gt[1]};
  double y[2] = {gt[3] + 0.5 * h * gt[5], gt[3] + 0.5 * h * gt[5]};
  ASSERT_TRUE(test::utm32ToLonLat(x, y, 2));
  const auto west = image->sampleBilinear(y[0], x[0]);
  const auto east = image->sampleBilinear(y[1], x[1]);
  ASSERT_TRUE(west && east);
  EXPECT_GT((*west)[0], 250.0f);
  EXPECT_LT((*west)[2], 5.0f);
  EXPECT_GT((*east)[2], 250.0f);
  EXPECT_LT((*east)[0], 5.0f);
  EXPECT_EQ((*west)[3], 255.0f);
  // The bounds are a box around the rotated footprint: its corners have no source pixel.
  EXPECT_EQ(image->pixel(0, 0)[3], 0);
  EXPECT_EQ(image->pixel(image->width() - 1, image->height() - 1)[3], 0);
}

/// Writes a 1° × 1° geographic (WGS 84) RGB GeoTIFF of `side` × `side` pixels of one colour.
bool writeGeographicTile(const std::filesystem::path& path, double west, double north, int side,
                         std::array<std::uint8_t, 3> rgb) {
  GDALAllRegister();
  GDALDriverH gtiff = GDALGetDriverByName("GTiff");
  GDALDatasetH ds = gtiff != nullptr
                        ? GDALCreate(gtiff, path.c_str(), side, side, 3, GDT_Byte, nullptr)
                        : nullptr;
  if (ds == nullptr) return false;
  double gt[6] = {west, 1.0 / side, 0.0, north, 0.0, -1.0 / side};
  GDALSetGeoTransform(ds, gt);
  OGRSpatialReferenceH wgs84 = OSRNewSpatialReference(nullptr);
  OSRImportFromEPSG(wgs84, 4326);
  GDALSetSpatialRef(ds, wgs84);
  OSRDestroySpatialReference(wgs84);
  bool ok = true;
  for (int b = 0; b < 3; ++b) {
    std::vector<std::uint8_t> values(static_cast<std::size_t>(side * side),
                                     rgb[static_cast<std::size_t>(b)]);
    ok = ok && GDALRasterIO(GDALGetRasterBand(ds, b + 1), GF_Write, 0, 0, side, side, values.data(),
                            side, side, GDT_Byte, 0, 0) == CE_None;
  }
  GDALClose(ds);
  return ok;
}

// Imagery tiles for a tile set's inset: a directory (or a glob) of georeferenced images read as
// one image, transparent where no tile lies; an ungeoreferenced tile among them is refused.
TEST(Image, ADirectoryOfGeoreferencedTilesIsOneImageTransparentWhereNoTileLies) {
  test::TempDir dir;
  std::filesystem::create_directories(dir / "tiles");
  ASSERT_TRUE(writeGeographicTile(dir / "tiles/a.tif", 10.0, 46.0, 32, {255, 0, 0}));
  ASSERT_TRUE(writeGeographicTile(dir / "tiles/b.tif", 11.0, 46.0, 32, {0, 0, 255}));
  ASSERT_TRUE(writeGeographicTile(dir / "tiles/c.tif", 13.0, 46.0, 32, {0, 255, 0}));
  std::ofstream(dir / "tiles/README.txt") << "side file\n";
  for (const auto& set : {dir / "tiles", dir / "tiles/*.tif"}) {
    auto image = readImage(set);
    ASSERT_TRUE(image) << image.error().message;
    EXPECT_TRUE(image->georeferenced());
    EXPECT_NEAR(image->bounds().westDegrees, 10.0, 1e-9);
    EXPECT_NEAR(image->bounds().eastDegrees, 14.0, 1e-9);
    EXPECT_NEAR(image->bounds().southDegrees, 45.0, 1e-9);
    const auto red = image->sampleBilinear(45.5, 10.5);
    const auto blue = image->sampleBilinear(45.5, 11.5);
    const auto gap = image->sampleBilinear(45.5, 12.5);
    const auto green = image->sampleBilinear(45.5, 13.5);
    ASSERT_TRUE(red && blue && gap && green);
    EXPECT_EQ((*red)[0], 255.0f);
    EXPECT_EQ((*red)[3], 255.0f);
    EXPECT_EQ((*blue)[2], 255.0f);
    EXPECT_EQ((*green)[1], 255.0f);
    EXPECT_EQ((*gap)[3], 0.0f) << "no tile there";
  }
  // A plain PNG (no georeference) among the tiles.
  std::filesystem::copy(kEarthImage, dir / "tiles/plain.jpg");
  auto mixed = readImage(dir / "tiles");
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.error().message.find("plain.jpg: an imagery tile of a set must be"),
            std::string::npos)
      << mixed.error().message;
}

}  // namespace
}  // namespace pbdam::formats
