// End to end on lavapipe: a known triangle drawn offscreen and read back pixel-exact, checked
// against Vulkan's rasterization rule (pixel centres inside the edges, top-left tie rule),
// with the validation layer watching.
#include "GpuTestSupport.h"

#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/TrianglePipeline.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

constexpr uint32_t kSize = 64;
constexpr std::array<float, 4> kMagenta = {1.0f, 0.0f, 1.0f, 1.0f};
constexpr std::array<uint8_t, 4> kMagentaBytes = {255, 0, 255, 255};
constexpr std::array<float, 4> kGreen = {0.0f, 1.0f, 0.0f, 1.0f};
constexpr std::array<uint8_t, 4> kGreenBytes = {0, 255, 0, 255};
constexpr std::array<float, 4> kBlue = {0.0f, 0.0f, 1.0f, 1.0f};
constexpr std::array<uint8_t, 4> kBlueBytes = {0, 0, 255, 255};

// Vertices on a quarter-pixel grid (exact in floats and in lavapipe's 8 subpixel bits), chosen
// so that no pixel centre lies on an edge: coverage does not depend on the tie-breaking rule.
TriangleDraw knownTriangle(float depth, std::array<float, 4> color) {
  TriangleDraw draw;
  draw.verticesPixels = {{{8.25f, 6.25f, depth}, {55.75f, 19.75f, depth}, {18.5f, 57.75f, depth}}};
  draw.colorRgba = color;
  return draw;
}

struct Coverage {
  std::vector<bool> covered;  // kSize * kSize, row-major, y down
  uint32_t coveredCount = 0;
  uint32_t centresOnEdges = 0;
};

// Reference rasterizer: a pixel is covered when its centre (x + 0.5, y + 0.5) is strictly
// inside all three edges, or on an edge that is a top or left edge (the top-left rule). Exact
// integer arithmetic on coordinates scaled by 4.
Coverage referenceCoverage(const TriangleDraw& draw) {
  std::array<std::array<int64_t, 2>, 3> v{};
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t c = 0; c < 2; ++c) {
      const float scaled = draw.verticesPixels[i][c] * 4.0f;
      EXPECT_EQ(scaled, std::floor(scaled)) << "vertex not on the quarter-pixel grid";
      v[i][c] = static_cast<int64_t>(scaled);
    }
  }
  const auto cross = [](std::array<int64_t, 2> a, std::array<int64_t, 2> b,
                        std::array<int64_t, 2> p) {
    return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
  };
  if (cross(v[0], v[1], v[2]) < 0) std::swap(v[1], v[2]);  // clockwise on screen (y down)

  Coverage result;
  result.covered.assign(std::size_t{kSize} * kSize, false);
  for (uint32_t y = 0; y < kSize; ++y) {
    for (uint32_t x = 0; x < kSize; ++x) {
      const std::array<int64_t, 2> centre = {4 * int64_t{x} + 2, 4 * int64_t{y} + 2};
      bool inside = true;
      bool onEdge = false;
      for (std::size_t e = 0; e < 3; ++e) {
        const auto& a = v[e];
        const auto& b = v[(e + 1) % 3];
        const int64_t w = cross(a, b, centre);
        const int64_t dx = b[0] - a[0];
        const int64_t dy = b[1] - a[1];
        const bool topOrLeft = (dy == 0 && dx > 0) || dy < 0;
        if (w == 0) onEdge = true;
        if (w < 0 || (w == 0 && !topOrLeft)) inside = false;
      }
      if (onEdge) ++result.centresOnEdges;
      if (inside) {
        result.covered[std::size_t{y} * kSize + x] = true;
        ++result.coveredCount;
      }
    }
  }
  return result;
}

class OffscreenTriangle : public test::GpuTest {
 protected:
  void SetUp() override {
    test::GpuTest::SetUp();
    if (HasFatalFailure()) return;
    Result<OffscreenTarget> target = OffscreenTarget::create(context(), kSize, kSize);
    ASSERT_TRUE(target.ok()) << target.error().message;
    target_ = std::move(target).value();
    Result<TrianglePipeline> pipeline = TrianglePipeline::create(
        context(), OffscreenTarget::kColorFormat, OffscreenTarget::kDepthFormat);
    ASSERT_TRUE(pipeline.ok()) << pipeline.error().message;
    pipeline_.emplace(std::move(pipeline).value());
  }
  void TearDown() override {
    pipeline_.reset();
    target_ = OffscreenTarget();
    test::GpuTest::TearDown();
  }

  Result<RgbaImage> draw(const std::vector<TriangleDraw>& triangles) {
    return target_.render(context(), kMagenta, [&](VkCommandBuffer cmd) {
      for (const TriangleDraw& triangle : triangles) {
        pipeline_->record(cmd, triangle, target_.extent());
      }
    });
  }

  OffscreenTarget target_;
  std::optional<TrianglePipeline> pipeline_;
};

TEST(ReferenceRasterizer, KnownTriangleIsUnambiguous) {
  const Coverage reference = referenceCoverage(knownTriangle(0.5f, kGreen));
  EXPECT_EQ(reference.centresOnEdges, 0u);
  EXPECT_EQ(reference.coveredCount, 1157u);  // independently counted with exact fractions
}

TEST_F(OffscreenTriangle, DrawsExactlyThePixelsTheRasterizationRuleCovers) {
  const TriangleDraw triangle = knownTriangle(0.5f, kGreen);
  Result<RgbaImage> image = draw({triangle});
  ASSERT_TRUE(image.ok()) << image.error().message;
  ASSERT_EQ(image->widthPixels, kSize);
  ASSERT_EQ(image->heightPixels, kSize);
  ASSERT_EQ(image->rgba.size(), std::size_t{4} * kSize * kSize);

  // Exact values well inside and well outside.
  EXPECT_EQ(image->pixel(27, 27), kGreenBytes);  // near the centroid (27.5, 27.9)
  EXPECT_EQ(image->pixel(30, 15), kGreenBytes);
  EXPECT_EQ(image->pixel(0, 0), kMagentaBytes);
  EXPECT_EQ(image->pixel(63, 63), kMagentaBytes);
  EXPECT_EQ(image->pixel(60, 5), kMagentaBytes);
  EXPECT_EQ(image->pixel(5, 60), kMagentaBytes);

  const Coverage reference = referenceCoverage(triangle);
  uint32_t green = 0;
  uint32_t mismatches = 0;
  for (uint32_t y = 0; y < kSize; ++y) {
    for (uint32_t x = 0; x < kSize; ++x) {
      const std::array<uint8_t, 4> p = image->pixel(x, y);
      ASSERT_TRUE(p == kGreenBytes || p == kMagentaBytes)
          << "pixel (" << x << ", " << y << ") = " << int{p[0]} << "," << int{p[1]} << ","
          << int{p[2]} << "," << int{p[3]};
      const bool isGreen = p == kGreenBytes;
      green += isGreen ? 1u : 0u;
      if (isGreen != reference.covered[std::size_t{y} * kSize + x]) {
        ++mismatches;
        ADD_FAILURE() << "pixel (" << x << ", " << y << ") is "
                      << (isGreen ? "covered" : "not covered") << ", the rule says otherwise";
      }
    }
  }
  EXPECT_EQ(green, reference.coveredCount);
  EXPECT_EQ(green, 1157u);
  EXPECT_EQ(mismatches, 0u);
}

TEST_F(OffscreenTriangle, ReversedZKeepsTheNearerTriangle) {
  // The green triangle at depth 0.5 is drawn first; a blue full-screen triangle behind it
  // (depth 0.25: farther under reversed-Z) only fills the rest.
  TriangleDraw behind;
  behind.verticesPixels = {
      {{-64.0f, -64.0f, 0.25f}, {192.0f, -64.0f, 0.25f}, {-64.0f, 192.0f, 0.25f}}};
  behind.colorRgba = kBlue;
  Result<RgbaImage> image = draw({knownTriangle(0.5f, kGreen), behind});
  ASSERT_TRUE(image.ok()) << image.error().message;
  const Coverage reference = referenceCoverage(knownTriangle(0.5f, kGreen));
  uint32_t green = 0;
  uint32_t blue = 0;
  for (uint32_t y = 0; y < kSize; ++y) {
    for (uint32_t x = 0; x < kSize; ++x) {
      const std::array<uint8_t, 4> p = image->pixel(x, y);
      const bool covered = reference.covered[std::size_t{y} * kSize + x];
      EXPECT_EQ(p, covered ? kGreenBytes : kBlueBytes) << "pixel (" << x << ", " << y << ")";
      green += p == kGreenBytes ? 1u : 0u;
      blue += p == kBlueBytes ? 1u : 0u;
    }
  }
  EXPECT_EQ(green, 1157u);
  EXPECT_EQ(blue, kSize * kSize - 1157u);
}

TEST_F(OffscreenTriangle, RendersRepeatedlyIntoTheSameTarget) {
  // Second and third frames reuse the target: barriers between frames must satisfy
  // synchronization validation, and each frame starts from a fresh clear.
  Result<RgbaImage> first = draw({knownTriangle(0.5f, kGreen)});
  ASSERT_TRUE(first.ok()) << first.error().message;
  Result<RgbaImage> empty = draw({});
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  for (uint32_t y = 0; y < kSize; y += 7) {
    for (uint32_t x = 0; x < kSize; x += 7) EXPECT_EQ(empty->pixel(x, y), kMagentaBytes);
  }
  Result<RgbaImage> again = draw({knownTriangle(0.5f, kGreen)});
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->rgba, first->rgba);
}

TEST_F(OffscreenTriangle, RejectsAnEmptyTarget) {
  Result<OffscreenTarget> target = OffscreenTarget::create(context(), 0, 16);
  ASSERT_FALSE(target.ok());
  EXPECT_EQ(target.error().code, ErrorCode::InvalidArgument);
}

}  // namespace
}  // namespace pbdam::gpu
