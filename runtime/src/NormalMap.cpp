// The normal-map texel (NormalMap.h).
#include "pbdam/runtime/NormalMap.h"

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>

namespace pbdam::runtime {
namespace {

std::uint8_t encodeComponent(double c) noexcept {
  const double companded = std::copysign(std::sqrt(std::min(std::abs(c), 1.0)), c);
  return static_cast<std::uint8_t>(std::lround(std::clamp(127.5 * (1.0 + companded), 0.0, 255.0)));
}

double decodeComponent(std::uint8_t byte) noexcept {
  const double s = static_cast<double>(byte) / 127.5 - 1.0;
  return s * std::abs(s);
}

}  // namespace

NormalMapFrame normalMapFrame(CubeFace face, const glm::dvec3& up) noexcept {
  const glm::dvec3 u = CubeMap::faceFrame(face).uAxis;
  NormalMapFrame frame;
  frame.up = up;
  frame.tangent = glm::normalize(u - glm::dot(u, up) * up);
  frame.bitangent = glm::cross(up, frame.tangent);
  return frame;
}

std::array<std::uint8_t, 2> encodeNormalTexel(const NormalMapFrame& frame,
                                              const glm::dvec3& normal) noexcept {
  return {encodeComponent(glm::dot(normal, frame.tangent)),
          encodeComponent(glm::dot(normal, frame.bitangent))};
}

glm::dvec3 decodeNormalTexel(const NormalMapFrame& frame, std::uint8_t x, std::uint8_t y) noexcept {
  double a = decodeComponent(x);
  double b = decodeComponent(y);
  const double planar = a * a + b * b;
  if (planar > 1.0) {
    const double scale = 1.0 / std::sqrt(planar);
    a *= scale;
    b *= scale;
  }
  const double c = std::sqrt(std::max(0.0, 1.0 - a * a - b * b));
  return a * frame.tangent + b * frame.bitangent + c * frame.up;
}

}  // namespace pbdam::runtime
