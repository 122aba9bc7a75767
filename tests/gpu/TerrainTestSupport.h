// Shared by the terrain GPU tests: the test datasets (MOLA Mars, ETOPO5 Earth), cameras from
// poses, and pixel checks (magenta holes inside the planet's silhouette).
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <glm/geometric.hpp>
#include <memory>
#include <string>
#include <vector>

#include "pbdam/gpu/RgbaImage.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::gpu::test {

inline constexpr std::array<std::uint8_t, 3> kMagentaRgb = {255, 0, 255};

/// Opens a test dataset directory; fails the test (returning null) when it does not open.
inline std::unique_ptr<streaming::MappedDataset> openDataset(const std::filesystem::path& dir) {
  auto opened = streaming::MappedDataset::open(dir);
  EXPECT_TRUE(opened.ok()) << (opened.ok() ? "" : opened.error().message);
  return opened.ok() ? std::move(opened).value() : nullptr;
}

inline runtime::Camera cameraAt(const runtime::DatasetView& view, const runtime::CameraPose& pose,
                                std::uint32_t width, std::uint32_t height,
                                double fovDegrees = 60.0) {
  runtime::Viewport viewport;
  viewport.width = width;
  viewport.height = height;
  viewport.fovYDegrees = fovDegrees;
  return runtime::Camera::fromPose(view.planet(), pose, viewport);
}

/// `frames` poses descending east over Tharsis towards Olympus Mons, looking ahead and down: the
/// cut changes every frame, by refinement and by what comes into view.
inline std::vector<runtime::CameraPose> tharsisDescent(std::size_t frames) {
  std::vector<runtime::CameraPose> poses;
  for (std::size_t k = 0; k < frames; ++k) {
    const double s = static_cast<double>(k) / static_cast<double>(frames - 1);
    poses.push_back({10.0 + 8.0 * s, -150.0 + 25.0 * s, 900e3 - 700e3 * s, 80.0 + 20.0 * s,
                     -35.0 - 10.0 * s, 0.0});
  }
  return poses;
}

inline std::string describe(const runtime::CameraPose& p) {
  char text[160];
  std::snprintf(text, sizeof text, "camera %.4f,%.4f,%.0f,%.1f,%.1f,%.1f", p.latDegrees,
                p.lonDegrees, p.altitudeMeters, p.headingDegrees, p.pitchDegrees, p.rollDegrees);
  return text;
}

/// The world-space ray through the centre of pixel (x, y) (y = 0 at the top).
inline glm::dvec3 pixelRay(const runtime::Camera& camera, std::uint32_t x, std::uint32_t y) {
  const runtime::Viewport& v = camera.viewport();
  const double sx = (static_cast<double>(x) + 0.5 - 0.5 * static_cast<double>(v.width)) /
                    camera.pixelsPerRadian();
  const double sy = (static_cast<double>(y) + 0.5 - 0.5 * static_cast<double>(v.height)) /
                    camera.pixelsPerRadian();
  return glm::normalize(camera.forward() + sx * camera.right() - sy * camera.up());
}

/// Whether the ray from `origin` along unit `direction` hits the sphere of `radius` about the
/// planet's centre in front of the origin.
inline bool rayHitsSphere(const glm::dvec3& origin, const glm::dvec3& direction, double radius) {
  const double b = glm::dot(origin, direction);
  const double c = glm::dot(origin, origin) - radius * radius;
  const double disc = b * b - c;
  if (disc < 0.0) return false;
  const double far = -b + std::sqrt(disc);
  return far > 0.0;
}

/// Pixels of an image that hit `radius` and are the clear colour, and how many hit it.
struct SilhouetteCheck {
  std::uint64_t inside = 0;
  std::uint64_t holes = 0;
  std::uint32_t firstHoleX = 0;
  std::uint32_t firstHoleY = 0;
};

inline SilhouetteCheck holesInsideSphere(const RgbaImage& image, const runtime::Camera& camera,
                                         double radius, std::array<std::uint8_t, 3> clear) {
  SilhouetteCheck check;
  for (std::uint32_t y = 0; y < image.heightPixels; ++y) {
    for (std::uint32_t x = 0; x < image.widthPixels; ++x) {
      if (!rayHitsSphere(camera.position(), pixelRay(camera, x, y), radius)) continue;
      ++check.inside;
      const auto p = image.pixel(x, y);
      if (p[0] == clear[0] && p[1] == clear[1] && p[2] == clear[2]) {
        if (check.holes == 0) {
          check.firstHoleX = x;
          check.firstHoleY = y;
        }
        ++check.holes;
      }
    }
  }
  return check;
}

}  // namespace pbdam::gpu::test
