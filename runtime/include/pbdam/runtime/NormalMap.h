// The normal-map texel (docs/architecture.md "Light"; formats/FORMAT.md "Texture table"): how the
// builder stores a terrain normal in two channels of a normal-map tile and how the patch
// fragment shader reads it back (gpu/shaders/patch.frag mirrors decodeNormalTexel). Thread-safety:
// pure functions.
//
// A texel holds the normal's components along two tangents of the surface, in a frame every
// texel of a face can form without a singularity (east and north have one at the poles, which
// faces 4 and 5 hold): up U is the reference surface's normal there, the first tangent T is the
// face's u axis made perpendicular to U, the second B = U × T. On its own face U is within 55° of
// the face's axis, so the u axis (perpendicular to that axis) is never parallel to it.
//
// Each component c (of −1..1) is stored companded, as the byte nearest 127.5·(1 + sign(c)·√|c|):
// the slopes that planet-scale texels show are small, and linear bytes would step the normal by
// 0.45° around flat ground, which a low sun turns into visible bands; companded the steps there
// are 0.01° and at 45° slopes 0.75°. The third component is the positive one of a unit vector.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>

#include "pbdam/runtime/CubeMap.h"

namespace pbdam::runtime {

/// The frame a texel's normal is stored in.
struct NormalMapFrame final {
  glm::dvec3 tangent{1.0, 0.0, 0.0};    ///< T: the face's u axis, perpendicular to up
  glm::dvec3 bitangent{0.0, 1.0, 0.0};  ///< B = U × T
  glm::dvec3 up{0.0, 0.0, 1.0};         ///< U: the reference surface's unit normal
};

/// The frame at a point of `face` whose reference-surface unit normal is `up`.
NormalMapFrame normalMapFrame(CubeFace face, const glm::dvec3& up) noexcept;

/// The two bytes that store unit normal `normal` in `frame`.
std::array<std::uint8_t, 2> encodeNormalTexel(const NormalMapFrame& frame,
                                              const glm::dvec3& normal) noexcept;

/// The unit normal two stored bytes give in `frame` (components past the unit circle, which
/// filtering and BC5 can make, are scaled back onto it).
glm::dvec3 decodeNormalTexel(const NormalMapFrame& frame, std::uint8_t x, std::uint8_t y) noexcept;

}  // namespace pbdam::runtime
