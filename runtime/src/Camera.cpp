// The double-precision camera (Camera.h).
#include "pbdam/runtime/Camera.h"

#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

constexpr double kPi = 3.14159265358979323846;
double radians(double degrees) { return degrees * kPi / 180.0; }

}  // namespace

Result<CameraPose> parseCameraPose(std::string_view text) {
  std::vector<double> v;
  if (!parseNumberList(text, 3, v) && !parseNumberList(text, 6, v)) {
    return makeError(ErrorCode::InvalidArgument,
                     "camera '" + std::string(text) +
                         "': expected LAT,LON,ALT or LAT,LON,ALT,HEADING,PITCH,ROLL (numbers)");
  }
  CameraPose pose{v[0], v[1], v[2]};
  if (v.size() == 6) {
    pose.headingDegrees = v[3];
    pose.pitchDegrees = v[4];
    pose.rollDegrees = v[5];
  }
  return pose;
}

Result<void> validateCameraPose(const CameraPose& p, const Planet& planet) {
  const auto bad = [](const std::string& what) {
    return makeError(ErrorCode::InvalidArgument, "camera " + what);
  };
  if (!std::isfinite(p.latDegrees) || std::abs(p.latDegrees) > 90.0) {
    return bad("latitude must be in [-90, 90]");
  }
  if (!std::isfinite(p.lonDegrees) || std::abs(p.lonDegrees) > 360.0) {
    return bad("longitude must be in [-360, 360]");
  }
  if (!std::isfinite(p.altitudeMeters) || p.altitudeMeters <= -0.5 * planet.polarRadiusMeters() ||
      p.altitudeMeters > 1e3 * planet.equatorialRadiusMeters()) {
    return bad("altitude must be finite, above -R/2 and below 1000 R");
  }
  if (!std::isfinite(p.headingDegrees) || !std::isfinite(p.pitchDegrees) ||
      !std::isfinite(p.rollDegrees) || std::abs(p.pitchDegrees) > 90.0) {
    return bad("heading/pitch/roll must be finite degrees, pitch in [-90, 90]");
  }
  return {};
}

Result<void> validateViewport(const Viewport& v) {
  if (v.width < 1 || v.height < 1 || v.width > 16384 || v.height > 16384) {
    return makeError(ErrorCode::InvalidArgument, "image size " + std::to_string(v.width) + "x" +
                                                     std::to_string(v.height) +
                                                     " out of range (1..16384)");
  }
  if (!std::isfinite(v.fovYDegrees) || v.fovYDegrees <= 0.0 || v.fovYDegrees >= 179.0) {
    return makeError(ErrorCode::InvalidArgument, "field of view must be in (0, 179) degrees");
  }
  return {};
}

Camera::Camera(const glm::dvec3& positionEcef, const glm::dvec3& right, const glm::dvec3& up,
               const glm::dvec3& forward, const Viewport& viewport) noexcept
    : position_(positionEcef), right_(right), up_(up), forward_(forward), viewport_(viewport) {
  pixelScale_ = static_cast<double>(viewport_.height) /
                (2.0 * std::tan(radians(viewport_.fovYDegrees) / 2.0));
  updatePlanes();
}

Camera Camera::fromPose(const Planet& planet, const CameraPose& pose,
                        const Viewport& viewport) noexcept {
  const EnuFrame enu = planet.enuFrame(pose.latDegrees, pose.lonDegrees, pose.altitudeMeters);
  const glm::dvec3 east = enu.axes[0], north = enu.axes[1], upAxis = enu.axes[2];
  const double h = radians(pose.headingDegrees), p = radians(pose.pitchDegrees),
               r = radians(pose.rollDegrees);
  const glm::dvec3 horizontal = std::sin(h) * east + std::cos(h) * north;
  const glm::dvec3 forward = std::cos(p) * horizontal + std::sin(p) * upAxis;
  // Right is horizontal (roll 0) even looking straight down, where it follows the heading.
  const glm::dvec3 right0 = std::cos(h) * east - std::sin(h) * north;
  const glm::dvec3 up0 = glm::cross(right0, forward);
  const glm::dvec3 right = std::cos(r) * right0 - std::sin(r) * up0;
  const glm::dvec3 up = std::sin(r) * right0 + std::cos(r) * up0;
  return Camera(enu.originEcef, glm::normalize(right), glm::normalize(up), glm::normalize(forward),
                viewport);
}

void Camera::setNearMeters(double nearMeters) noexcept {
  nearMeters_ = nearMeters;
  updatePlanes();
}

Camera Camera::withFrustumMargin(double marginDegrees) const noexcept {
  Camera wider = *this;
  wider.marginRadians_ = radians(marginDegrees);
  wider.updatePlanes();
  return wider;
}

void Camera::updatePlanes() noexcept {
  // A widened half-angle stops at 90°: the plane through the camera facing forward.
  const double quarter = 0.5 * std::numbers::pi;
  const double halfY = std::min(
      std::atan(static_cast<double>(viewport_.height) / (2.0 * pixelScale_)) + marginRadians_,
      quarter);
  const double halfX = std::min(
      std::atan(static_cast<double>(viewport_.width) / (2.0 * pixelScale_)) + marginRadians_,
      quarter);
  const auto plane = [&](const glm::dvec3& normal) {
    const glm::dvec3 n = glm::normalize(normal);
    return glm::dvec4(n, -glm::dot(n, position_));
  };
  // Inward normals of the side planes through the camera.
  planes_[0] = plane(std::cos(halfX) * right_ + std::sin(halfX) * forward_);
  planes_[1] = plane(-std::cos(halfX) * right_ + std::sin(halfX) * forward_);
  planes_[2] = plane(std::cos(halfY) * up_ + std::sin(halfY) * forward_);
  planes_[3] = plane(-std::cos(halfY) * up_ + std::sin(halfY) * forward_);
  planes_[4] = glm::dvec4(forward_, -glm::dot(forward_, position_) - nearMeters_);
}

bool Camera::sphereInFrustum(const glm::dvec3& centre, double radius) const noexcept {
  for (const glm::dvec4& p : planes_) {
    if (glm::dot(glm::dvec3(p), centre) + p.w < -radius) return false;
  }
  return true;
}

double Camera::screenError(double errorMeters, const glm::dvec3& centre,
                           double radius) const noexcept {
  const double distance = glm::length(centre - position_) - radius;
  if (distance <= 0.0) return std::numeric_limits<double>::infinity();
  return errorMeters * pixelScale_ / distance;
}

glm::mat4 Camera::viewRotation() const noexcept { return glm::mat4(viewRotationDouble()); }

glm::mat4 Camera::projection() const noexcept { return glm::mat4(projectionDouble()); }

glm::dmat4 Camera::viewRotationDouble() const noexcept {
  // Rows: right, up, −forward (columns of the transpose in glm's column-major storage).
  glm::dmat4 m(1.0);
  for (int c = 0; c < 3; ++c) {
    m[c][0] = right_[c];
    m[c][1] = up_[c];
    m[c][2] = -forward_[c];
  }
  return m;
}

glm::dmat4 Camera::projectionDouble() const noexcept {
  const double aspect =
      static_cast<double>(viewport_.width) / static_cast<double>(viewport_.height);
  const double f = 2.0 * pixelScale_ / static_cast<double>(viewport_.height);
  glm::dmat4 m(0.0);
  m[0][0] = f / aspect;
  m[1][1] = -f;  // Vulkan clip space has y down
  m[2][3] = -1.0;
  m[3][2] = nearMeters_;  // depth = near / −z_view: 1 at the near plane, 0 at infinity
  return m;
}

}  // namespace pbdam::runtime
