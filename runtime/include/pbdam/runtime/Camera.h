// The double-precision camera (docs/architecture.md "Refinement and drawing"): position in
// planetocentric metres, orientation from heading/pitch/roll in the local east-north-up frame, a
// symmetric perspective with an infinite reversed-Z projection, frustum planes for culling and the
// screen-space error scale. Nothing here is float except the projection handed to the GPU:
// positions are made camera-relative in double before they are rounded (runtime/PatchDraw.h).
// Thread-safety: plain values.
#pragma once

#include <array>
#include <cstdint>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <string_view>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// Where a camera is and where it looks: degrees, metres above the reference surface (the
/// planet's sphere or ellipsoid, not the terrain), heading clockwise from north, pitch up from
/// the horizon (−90 = straight down), roll clockwise about the view direction.
struct CameraPose final {
  double latDegrees = 0.0;      ///< latitude of the eye
  double lonDegrees = 0.0;      ///< longitude of the eye
  double altitudeMeters = 0.0;  ///< above the reference surface
  double headingDegrees = 0.0;  ///< clockwise from north
  double pitchDegrees = -90.0;  ///< up from the horizon
  double rollDegrees = 0.0;     ///< clockwise about the view direction
};

/// Parses "LAT,LON,ALT[,HEADING,PITCH,ROLL]" (pitch defaults to −90: looking down).
formats::Result<CameraPose> parseCameraPose(std::string_view text);

/// Checks ranges: |lat| ≤ 90, |lon| ≤ 360, altitude > −0.5·polar radius and finite, angles
/// finite.
formats::Result<void> validateCameraPose(const CameraPose& pose, const Planet& planet);

/// The image a camera renders: size in pixels and vertical field of view.
struct Viewport final {
  std::uint32_t width = 1280;  ///< pixels
  std::uint32_t height = 720;  ///< pixels
  double fovYDegrees = 60.0;   ///< the vertical field of view
};

/// Checks 1 ≤ width, height ≤ 16384 and 0 < fov < 179°.
formats::Result<void> validateViewport(const Viewport& viewport);

/// A double-precision perspective camera: position and axes in planetocentric metres, the
/// viewport, the frustum's planes for culling, the screen-space error of an object-space one,
/// and the camera-relative view and projection handed to the GPU. A plain value.
class Camera final {
 public:
  /// A camera at `positionEcef` with orthonormal world-space axes (right, up, forward).
  Camera(const glm::dvec3& positionEcef, const glm::dvec3& right, const glm::dvec3& up,
         const glm::dvec3& forward, const Viewport& viewport) noexcept;

  /// The camera of a pose on a planet.
  static Camera fromPose(const Planet& planet, const CameraPose& pose,
                         const Viewport& viewport) noexcept;

  /// The eye, planetocentric metres.
  const glm::dvec3& position() const noexcept { return position_; }
  /// The unit world-space axes: screen right, screen up, and the view direction.
  /// @{
  const glm::dvec3& right() const noexcept { return right_; }
  const glm::dvec3& up() const noexcept { return up_; }
  const glm::dvec3& forward() const noexcept { return forward_; }
  /// @}
  /// The image it renders.
  const Viewport& viewport() const noexcept { return viewport_; }

  /// Pixels per unit of (size / distance): viewport height / (2·tan(fov/2)).
  double pixelsPerRadian() const noexcept { return pixelScale_; }

  /// Screen-space size in pixels of an object-space `errorMeters` at the nearest point of the
  /// sphere (docs/architecture.md "Refinement and drawing"); infinite when the camera is inside the
  /// sphere.
  double screenError(double errorMeters, const glm::dvec3& centre, double radius) const noexcept;

  /// False when the sphere lies wholly outside one of the frustum's side or near planes.
  bool sphereInFrustum(const glm::dvec3& centre, double radius) const noexcept;
  /// The frustum's planes: inward unit normals (xyz) and offsets (w), a point x inside when
  /// dot(normal, x) + w ≥ 0 for all five (left, right, bottom, top side planes, then near).
  const std::array<glm::dvec4, 5>& frustumPlanes() const noexcept { return planes_; }
  /// This camera with its side planes turned outward by `marginDegrees` each (the culling of a
  /// view that may turn that far); its screen error, projection and near plane are unchanged.
  Camera withFrustumMargin(double marginDegrees) const noexcept;

  /// World-to-view rotation for camera-relative positions (view looks along −z, y up), and the
  /// infinite reversed-Z Vulkan projection (depth 1 at the near plane, → 0 at infinity, y down):
  /// the float matrices the terrain's shaders take.
  /// @{
  glm::mat4 viewRotation() const noexcept;
  glm::mat4 projection() const noexcept;
  /// @}
  /// The same two in double precision, from which the float ones are rounded: what a host that
  /// draws its own objects beside the terrain composes with its positions relative to
  /// position() (docs/embedding.md "Drawing into your own pass").
  /// @{
  glm::dmat4 viewRotationDouble() const noexcept;
  glm::dmat4 projectionDouble() const noexcept;
  /// @}
  /// The near plane's distance from the eye.
  double nearMeters() const noexcept { return nearMeters_; }
  /// Sets the near plane (default 0.1 m; reversed-Z float depth keeps precision far away).
  void setNearMeters(double nearMeters) noexcept;

 private:
  void updatePlanes() noexcept;

  glm::dvec3 position_;
  glm::dvec3 right_, up_, forward_;
  Viewport viewport_;
  double pixelScale_ = 1.0;
  double nearMeters_ = 0.1;
  double marginRadians_ = 0.0;          ///< added to the side planes' half-angles (culling only)
  std::array<glm::dvec4, 5> planes_{};  ///< inward normals (xyz) and offsets (w), world space
};

}  // namespace pbdam::runtime
