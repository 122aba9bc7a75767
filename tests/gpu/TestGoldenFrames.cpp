// Golden frames: four views rendered on lavapipe (with validation) and compared with checked-in
// PNGs — the whole of Mars, a low oblique over Valles Marineris, an Olympus Mons close-up and the
// Himalayas on Earth. Tolerance: lavapipe is deterministic on one machine (the same camera gives
// the same bytes), but LLVM's code generation may round differently on another CPU, so a frame
// passes when at most 0.5% of its pixels differ by more than 8 in any channel and the mean
// absolute difference is at most 1.0. Each rendered frame is saved to build/test-artifacts; set
// PBDAM_UPDATE_GOLDEN=1 to rewrite the references (and look at them before committing).
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <filesystem>

#include "GpuTestSupport.h"
#include "TerrainTestSupport.h"
#include "TestData.h"
#include "pbdam/formats/Image.h"
#include "pbdam/gpu/TerrainRenderer.h"

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
};

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
  auto renderer = TerrainRenderer::create(context(), data, options);
  ASSERT_TRUE(renderer.ok()) << renderer.error().message;
  const Camera camera = test::cameraAt(data, view.pose, kWidth, kHeight);
  const Cut cut = refine(data, camera, RefinementOptions{});
  auto frame = renderer->render(cut, camera);
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
        GoldenView{"earth_himalayas", "earth", {22.0, 84.0, 700e3, 10.0, -35.0, 0.0}}),
    [](const ::testing::TestParamInfo<GoldenView>& p) { return std::string(p.param.name); });

}  // namespace
}  // namespace pbdam::gpu
