// Imagery ingest through OpenImageIO: the Debian-packaged Earth map and rejection of bad files.
#include <gtest/gtest.h>

#include <fstream>

#include "TestData.h"
#include "pbdam/formats/Image.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

constexpr const char* kEarthImage = "/usr/share/xplanet/images/earth.jpg";

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

}  // namespace
}  // namespace pbdam::formats
