// Camera-relative patch vertices (design.md §4 "Precision", paper 004 §4.2 and Fig. 5): what the
// host computes per draw in double, what the vertex shader then computes per vertex in float, and
// a CPU copy of the shader's float arithmetic for tests.
//
// A vertex with barycentrics (w0, w1, w2) (exact: 15-bit dyadics) and displacement h is at
//   P(w, h) = w0·P0 + w1·P1 + w2·P2 + h·N(w),   N(w) = w0·N0 + w1·N1 + w2·N2 (not normalised).
// Fig. 5 rounds the corners (P_i − camera) to float and interpolates them. That is crack-free if
// both patches of an edge do the same operations, but its rounding error scales with the corners'
// distance: a 330 km MOLA leaf has ~2 cm error even at the camera. Here the host instead expands
// P around reference points near the camera, in double, and the shader adds only small float
// terms (docs/decisions.md "Camera-relative precision"):
//   interior vertex: P − cam = R + d1·E1 + d2·E2 + (h − hr)·N(w) + hr·(d1·ΔN1 + d2·ΔN2)
//     with r the patch's reference barycentrics (the camera's projection, rounded to 2^-15),
//     hr its reference displacement (rounded to the height step), d = w − r (exact in float),
//     R = float(P(r, hr) − cam) computed in double, E_i = P_i − P0, ΔN_i = N_i − N0;
//   vertex on edge k (corners a, b in canonical key order, t = weight of b):
//     P − cam = Re + (t − tr)·Ee + (h − hre)·(Na + t·ΔNe) + hre·((t − tr)·ΔNe)
//     with every term computed from the edge's own data (its corners, the camera and
//     dataset-wide constants) so both patches on the edge compute bit-identical floats;
//   corner k: (P_k − cam rounded) + h·N_k.
// The float operations are fixed in order and never contracted into FMAs (GLSL `precise`; this
// file's .cpp is built with -ffp-contract=off), so shaderVertexPosition reproduces the GPU
// bit for bit on IEEE hardware. Thread-safety: pure functions.
#pragma once

#include <array>
#include <cstdint>
#include <glm/vec3.hpp>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam {

/// The per-draw record read by the patch vertex shader (std430, 16-byte vec4s; the layout and
/// the arithmetic are mirrored in gpu/shaders/patch_position.glsl — keep them in step). Each
/// draw passes its record's index as a push constant.
struct alignas(16) PatchDrawRecord final {
  std::array<float, 4> corner[3];           ///< xyz: float(P_k − cam)
  std::array<float, 4> normal[3];           ///< xyz: N_k
  std::array<float, 4> edgeOrigin[3];       ///< xyz: Re, w: tr
  std::array<float, 4> edgeVector[3];       ///< xyz: Ee = P_b − P_a, w: hre
  std::array<float, 4> edgeNormal[3];       ///< xyz: Na, w: index of corner b (0..2)
  std::array<float, 4> edgeNormalDelta[3];  ///< xyz: ΔNe = N_b − N_a
  std::array<float, 4> origin;              ///< xyz: R, w: r1
  std::array<float, 4> axis1;               ///< xyz: E1, w: r2
  std::array<float, 4> axis2;               ///< xyz: E2, w: hr
  std::array<float, 4> normalDelta1;        ///< xyz: ΔN1
  std::array<float, 4> normalDelta2;        ///< xyz: ΔN2
  std::array<float, 4> texCoord01;          ///< T0.xy, T1.xy (tile texture coordinates)
  std::array<float, 4> texCoord2Layer;      ///< T2.xy, z: texture array layer, w: unused
};
static_assert(sizeof(PatchDrawRecord) == 25 * 16);

/// What a draw needs besides the node record.
struct PatchDrawInput final {
  NodeKey node;
  NodeRecord record;
  std::uint32_t textureLayer = 0;
};

/// Computes the per-draw record of a patch for a camera at `cameraEcef` (double precision).
PatchDrawRecord makePatchDrawRecord(const DatasetView& dataset, const PatchDrawInput& input,
                                    const glm::dvec3& cameraEcef) noexcept;

/// A vertex's displacement in metres as the GPU receives it (exact: steps · 2^-6 in float).
float vertexHeightMeters(std::int32_t heightSteps, double heightStepMeters) noexcept;

/// The vertex shader's float computation of a vertex's camera-relative position, on the CPU.
glm::vec3 shaderVertexPosition(const PatchDrawRecord& draw, std::uint16_t b1, std::uint16_t b2,
                               float heightMeters) noexcept;

/// The same vertex in double: P(w, h) − camera, with the stored (float) normals.
glm::dvec3 exactVertexPosition(const NodeRecord& record, std::uint16_t b1, std::uint16_t b2,
                               double heightMeters, const glm::dvec3& cameraEcef) noexcept;

/// The technique camera-relative drawing replaces, for comparison: absolute float corners
/// interpolated in float, then the camera subtracted in float.
glm::vec3 absoluteFloatVertexPosition(const NodeRecord& record, std::uint16_t b1, std::uint16_t b2,
                                      float heightMeters, const glm::dvec3& cameraEcef) noexcept;

/// Fig. 5 as published: corners rounded camera-relative, interpolated in float (no reference
/// points), for the precision comparison in tests and docs.
glm::vec3 cornerRelativeVertexPosition(const NodeRecord& record, std::uint16_t b1, std::uint16_t b2,
                                       float heightMeters, const glm::dvec3& cameraEcef) noexcept;

}  // namespace pbdam
