// Golden frames: views rendered on lavapipe (with validation) and compared with checked-in PNGs —
// the whole of Mars, a low oblique over Valles Marineris, an Olympus Mons close-up and the
// Himalayas on Earth under the camera light; and Mars and Earth under the sun of an instant with
// their atmospheres, from orbit (the limb, the terminator), from 10 km (haze towards the horizon)
// and from the ground (the sky's colour by the sun's elevation). The atmosphere's tables are the
// small ones of the tests (quick under the sanitizers), the sun from the ephemeris. Tolerance:
// lavapipe is deterministic on one machine (the same camera gives the same bytes), but LLVM's code
// generation may round differently on another CPU, so a frame passes when at most 0.5% of its
// pixels differ by more than 8 in any channel and the mean absolute difference is at most 1.0. Each
// rendered frame is saved to build/test-artifacts; set PBDAM_UPDATE_GOLDEN=1 to rewrite the
// references (and look at them before committing).
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/Image.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/Atmosphere.h"
#include "pbdam/runtime/Sun.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::gpu {
namespace {

constexpr std::uint32_t kWidth = 384;
constexpr std::uint32_t kHeight = 216;

struct GoldenView {
  const char* name;
  const char* dataset;
  CameraPose pose;
  const char* utc = nullptr;  ///< with the atmosphere under the sun of this instant
};

/// The atmosphere's tables of the tests: small, made once per planet.
std::shared_ptr<const AtmosphereTables> smallAtmosphere(const Planet& planet) {
  static std::map<std::string, std::shared_ptr<const AtmosphereTables>> made;
  auto& tables = made[planet.name()];
  if (!tables) {
    AtmosphereTableSizes sizes;
    sizes.scatteringR = 8;
    sizes.scatteringMu = 32;
    sizes.scatteringMuS = 8;
    sizes.scatteringNu = 4;
    tables = std::make_shared<const AtmosphereTables>(
        AtmosphereTables::compute(*AtmosphereParameters::of(planet), sizes));
  }
  return tables;
}

void writePng(const std::filesystem::path& path, const RgbaImage& image) {
  std::filesystem::create_directories(path.parent_path());
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out) << path;
  OIIO::ImageSpec spec(static_cast<int>(image.widthPixels), static_cast<int>(image.heightPixels), 4,
                       OIIO::TypeDesc::UINT8);
  ASSERT_TRUE(out->open(path.string(), spec)) << out->geterror();
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, image.rgba.data())) << out->geterror();
  ASSERT_TRUE(out->close());
}

class GoldenFrames : public test::GpuTest, public ::testing::WithParamInterface<GoldenView> {};

TEST_P(GoldenFrames, MatchTheCheckedInReference) {
  const GoldenView& view = GetParam();
  PBDAM_REQUIRE_DATASET(dir, view.dataset);
  auto dataset = test::openDataset(dir);
  ASSERT_TRUE(dataset);
  const DatasetView& data = dataset->view();
  TerrainRendererOptions options;
  options.widthPixels = kWidth;
  options.heightPixels = kHeight;
  FrameSettings settings;
  if (view.utc) {
    options.atmosphere = smallAtmosphere(data.planet());
    auto t = parseUtcTime(view.utc);
    ASSERT_TRUE(t.ok());
    auto sun = subsolarPoint(data.planet(), *t);
    ASSERT_TRUE(sun.ok());
    settings.sunDirectionEcef = sunDirectionEcef(data.planet(), *sun);
    settings.sunAngularRadiusRadians = static_cast<float>(sunAngularRadiusRadians(sun->distanceAu));
    settings.ambient = 0.05f;
    settings.atmosphereExposure = solarBodyOf(data.planet()) == SolarBody::Mars ? 23.0f : 10.0f;
  }
  auto renderer = TerrainRenderer::create(context(), data, options);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Camera camera = test::cameraAt(data, view.pose, kWidth, kHeight);
  const Cut cut = refine(data, camera, RefinementOptions{});
  auto frame = renderer->render(cut, camera, settings);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const RgbaImage& image = frame->image;

  const std::filesystem::path artifacts =
      pbdam::test::testDatasetDir("mola").parent_path().parent_path() / "test-artifacts";
  writePng(artifacts / (std::string(view.name) + ".png"), image);
  const std::filesystem::path golden =
      std::filesystem::path(PBDAM_GOLDEN_DIR) / (std::string(view.name) + ".png");
  if (const char* update = std::getenv("PBDAM_UPDATE_GOLDEN"); update && *update == '1') {
    writePng(golden, image);
    GTEST_SKIP() << "wrote " << golden;
  }
  auto reference = readImage(golden);
  ASSERT_TRUE(reference.ok()) << reference.error().message;
  ASSERT_EQ(reference->width(), kWidth);
  ASSERT_EQ(reference->height(), kHeight);
  std::uint64_t differing = 0;
  double sum = 0.0;
  for (std::uint32_t y = 0; y < kHeight; ++y) {
    for (std::uint32_t x = 0; x < kWidth; ++x) {
      const auto a = image.pixel(x, y);
      const auto b = reference->pixel(x, y);
      int worst = 0;
      for (int c = 0; c < 3; ++c) {
        const int d =
            std::abs(int{a[static_cast<std::size_t>(c)]} - int{b[static_cast<std::size_t>(c)]});
        worst = std::max(worst, d);
        sum += d;
      }
      if (worst > 8) ++differing;
    }
  }
  const double pixels = double{kWidth} * kHeight;
  const double mean = sum / (3.0 * pixels);
  EXPECT_LE(static_cast<double>(differing), 0.005 * pixels)
      << differing << " pixels differ by more than 8; compare " << artifacts << " with " << golden;
  EXPECT_LE(mean, 1.0) << "mean absolute difference";
  // Sanity: the view shows terrain, not the background.
  EXPECT_GT(cut.patches.size(), 10u);
}

INSTANTIATE_TEST_SUITE_P(
    Views, GoldenFrames,
    ::testing::Values(
        GoldenView{"mars_whole", "mola", {0.0, -75.0, 5500e3, 0.0, -90.0, 0.0}},
        GoldenView{"valles_marineris", "mola", {-15.0, -68.0, 90e3, 15.0, -30.0, 0.0}},
        GoldenView{"olympus_mons", "mola", {12.5, -133.9, 40e3, 0.0, -14.0, 0.0}},
        GoldenView{"earth_himalayas", "earth", {22.0, 84.0, 700e3, 10.0, -35.0, 0.0}},
        // Mars24 example B (sun over 13.4°S 4.7°W): the terminator near 85°E and 95°W.
        GoldenView{"mars_orbit_atmosphere",
                   "mola",
                   {0.0, -75.0, 5500e3, 0.0, -90.0, 0.0},
                   "2004-01-03T13:46:31Z"},
        GoldenView{"mars_10km_atmosphere",
                   "mola",
                   {-10.0, -68.0, 10e3, 90.0, -8.0, 0.0},
                   "2004-01-03T20:00:00Z"},
        GoldenView{"mars_ground_atmosphere",
                   "mola",
                   {-10.0, -68.0, 6000.0, 270.0, 10.0, 0.0},
                   "2004-01-03T20:00:00Z"},
        // The June solstice of 2024, morning over India.
        GoldenView{"earth_orbit_atmosphere",
                   "earth",
                   {20.0, 80.0, 12000e3, 0.0, -90.0, 0.0},
                   "2024-06-20T06:00:00Z"},
        GoldenView{"earth_10km_atmosphere",
                   "earth",
                   {27.5, 86.0, 10e3, 200.0, -8.0, 0.0},
                   "2024-06-20T03:00:00Z"},
        GoldenView{"earth_ground_atmosphere",
                   "earth",
                   {26.0, 84.0, 400.0, 90.0, 10.0, 0.0},
                   "2024-06-20T01:00:00Z"}),
    [](const ::testing::TestParamInfo<GoldenView>& p) { return std::string(p.param.name); });

}  // namespace
}  // namespace pbdam::gpu
