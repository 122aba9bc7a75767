// Camera-relative patch vertices (docs/architecture.md "Precision", [P-BDAM 2003] §4.2 and Fig. 5):
// where a vertex is drawn, what decode computes for it once per residency in double, what the
// host computes per draw in double, what the vertex shader then computes per vertex in float,
// and a CPU copy of the shader's float arithmetic for tests.
//
// A stored vertex is a lattice point q of its node's triangle, given by barycentrics
// (w0, w1, w2) (exact: 15-bit dyadics) on the corner triangle (P0, P1, P2), and q's own lattice
// height (quantised to the height step). It is drawn at its terrain point T (TerrainPoint.h: q's
// direction on the reference surface raised by the height along the surface normal), the point
// the builder measured. Decode (PatchVertexPlacement, on the decode workers, once per residency)
// splits T in double into the displaced point of paper §4.2 and a residual:
//   T = P(w, h) + o,   P(w, h) = Pflat(w) + h·N(w),
//   Pflat(w) = w0·P0 + w1·P1 + w2·P2,   N(w) = w0·N0 + w1·N1 + w2·N2 (not normalised),
// with h the normal component of T − Pflat rounded to the height step (the patch's relief and
// sag: up to the planet's largest relief) and o = float(T − Pflat − h·N) the sideways rest (the
// cube map's shift, metres to kilometres; zero at the corners). The GPU vertex is (b, h, o). A
// vertex on an edge takes Pflat and N from the edge's corners in canonical key order (and a
// corner its own P_k, N_k), so both patches compute identical doubles and store identical floats.
// Storing T − Pflat as one float offset would round the relief (20 km on Olympus Mons) to 1–2 mm;
// split, h is handled around a reference height near the camera (below), and o, which is small
// near the camera, rounds by 2^-24·|o|.
//
// Fig. 5 rounds the corners (P_i − camera) to float and interpolates them. That is crack-free if
// both patches of an edge do the same operations, but its rounding error scales with the corners'
// distance: a 330 km MOLA leaf has ~2 cm error even at the camera. Here the host instead expands
// P around reference points near the camera, in double, and the shader adds only small float
// terms (docs/decisions.md "Camera-relative precision"), then o:
//   interior vertex: P − cam = R + d1·E1 + d2·E2 + (h − hr)·N(w) + hr·(d1·ΔN1 + d2·ΔN2)
//     with r the patch's reference barycentrics (the camera's projection, rounded to 2^-15),
//     hr its reference displacement (rounded to the height step), d = w − r (exact in float),
//     R = float(P(r, hr) − cam) computed in double, E_i = P_i − P0, ΔN_i = N_i − N0;
//   vertex on edge k (corners a, b in canonical key order, t = weight of b):
//     P − cam = Re + (t − tr)·Ee + (h − hre)·(Na + t·ΔNe) + hre·((t − tr)·ΔNe)
//     with every term computed from the edge's own data (its corners, the camera and
//     dataset-wide constants) so both patches on the edge compute bit-identical floats;
//   corner k: (P_k − cam rounded) + h·N_k;
//   and T − cam = (P − cam) + o in every case.
// The float operations are fixed in order and never contracted into FMAs (GLSL `precise`; this
// file's .cpp is built with -ffp-contract=off), so shaderVertexPosition reproduces the GPU
// bit for bit on IEEE hardware.
//
// Texture coordinates come from where the vertex is drawn, its terrain point. The tile's texture
// coordinate is affine in the face coordinates (u, v) of the vertex's terrain direction,
// tc = 0.5 + k·(u − uc, v − vc) with (uc, vc) the tile's centre. The shader finds the direction by
// inverting T = surface(d) + H·n(d) (exact on a sphere; on an ellipsoid two
// fixed-point steps, which leave millimetres) on the record's own face, and forms u − uc as
// (2/π)·atan of a plane-coordinate
// difference computed from the vertex's offset to the tile centre's surface point Q, so no absolute
// float position is ever rounded (docs/architecture.md "Refinement and drawing"): its error scales
// with the tile, not the planet. Not bit-exact across GPUs (atan, inversesqrt); shaderTexCoord is
// its float mirror. Thread-safety: pure functions; PatchVertexPlacement is an immutable value.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <optional>
#include <vector>

#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/runtime/TerrainPoint.h"

namespace pbdam::runtime {

/// The per-draw record read by the patch vertex shader (std430, 16-byte vec4s; the layout and
/// the arithmetic are mirrored in gpu/shaders/patch_position.glsl — keep them in step). Each
/// draw passes its record's index as a push constant. The texture fields: Q is the surface point
/// (height 0) in the direction of the tile's centre, (ac, bc) its plane coordinates
/// tan(π/4·(2uc − 1)), tan(π/4·(2vc − 1)) on the record's face, Qn = Q · n_face.
struct alignas(16) PatchDrawRecord final {
  std::array<float, 4> corner[3];           ///< xyz: float(P_k − cam), w: see below
                                            ///< (w of corner 0: texture array layer,
                                            ///< 1: equatorial radius, 2: polar radius, metres)
  std::array<float, 4> normal[3];           ///< xyz: N_k; w of normal 0: the normal map's
                                            ///< slope scale (the exaggeration), of normal 1:
                                            ///< the map's share of the terrain normal (0: the
                                            ///< facets' alone, as for a leaf; patch.frag)
  std::array<float, 4> edgeOrigin[3];       ///< xyz: Re, w: tr
  std::array<float, 4> edgeVector[3];       ///< xyz: Ee = P_b − P_a, w: hre
  std::array<float, 4> edgeNormal[3];       ///< xyz: Na, w: index of corner b (0..2)
  std::array<float, 4> edgeNormalDelta[3];  ///< xyz: ΔNe = N_b − N_a
  std::array<float, 4> origin;              ///< xyz: R, w: r1
  std::array<float, 4> axis1;               ///< xyz: E1, w: r2
  std::array<float, 4> axis2;               ///< xyz: E2, w: hr
  std::array<float, 4> normalDelta1;        ///< xyz: ΔN1
  std::array<float, 4> normalDelta2;        ///< xyz: ΔN2
  std::array<float, 4> texCenter;           ///< xyz: float(Q − cam), w: k = d(tc)/d(u)
  std::array<float, 4> texPlane;            ///< x: ac, y: bc, z: Qn (metres), w: face index
  std::array<float, 4> morph;               ///< x, y: 1 − f for interior/leg and hypotenuse
                                            ///< vertices, z: weight of the coarser tile, w: its
                                            ///< texture array layer (docs/architecture.md
                                            ///< "Geomorphing")
  std::array<float, 4> morphTexture;        ///< the coarser tile's tc = z·tc + (x, y)
};
static_assert(sizeof(PatchDrawRecord) == std::size_t{27} * 16);

/// Where a patch's texture tile lies on its cube face.
struct PatchTextureTile final {
  CubeFace face = CubeFace::PosX;  ///< the face the tile is on
  glm::dvec2 centerFaceUv{0.5};    ///< the tile's centre (texture coordinate 0.5, 0.5)
  double texCoordPerFaceUv = 1.0;  ///< k: d(tc.x)/du = d(tc.y)/dv
  std::uint32_t textureLayer = 0;  ///< the tile's layer in the texture array
};

/// The tile of a texture quadtree node (level, column qi, row qj) on a face of a lattice with
/// `latticeCells` cells per side, tiles of `tileTexels` texels with `borderTexels` of filtering
/// border: its inner texels span the node's square exactly, so a lattice point x has
/// tc = (border + ((x − qi·side)/side)·inner)/size, side = latticeCells >> level.
PatchTextureTile patchTextureTile(CubeFace face, std::uint32_t latticeCells,
                                  std::uint32_t textureLevel, std::uint32_t qi, std::uint32_t qj,
                                  std::uint32_t tileTexels, std::uint32_t borderTexels,
                                  std::uint32_t textureLayer) noexcept;

/// Fills the record's texture fields (texCenter, texPlane and the w of corner[]) for `tile` on
/// `planet`, seen from `cameraEcef`. Tests call it directly.
void setPatchTexture(PatchDrawRecord& draw, const Planet& planet, const PatchTextureTile& tile,
                     const glm::dvec3& cameraEcef) noexcept;
/// The same without a camera: texCenter's xyz left zero; returns Q (planetocentric metres).
glm::dvec3 setPatchTexture(PatchDrawRecord& draw, const Planet& planet,
                           const PatchTextureTile& tile) noexcept;

/// The vertex shader's float computation of a vertex's tile texture coordinates from its
/// camera-relative position (patch_texcoord.glsl), on the CPU: the same formula, not bit-exact.
glm::vec2 shaderTexCoord(const PatchDrawRecord& draw, const glm::vec3& cameraRelative) noexcept;

/// What a draw needs besides the node record.
struct PatchDrawInput final {
  NodeKey node;                    ///< the patch's node
  formats::NodeRecord record;      ///< its record
  std::uint32_t textureLayer = 0;  ///< the layer of its tile in the texture array
  /// The geomorph (CutPatch::morph): 1 − f of the parent's and grandparent's diamonds.
  std::array<float, 2> morph{0.0f, 0.0f};
  /// Where the patch blends in its parent's tile (CutPatch::blendsTile): that tile, its layer.
  std::optional<TileKey> morphTile{};
  std::uint32_t morphTextureLayer = 0;  ///< the layer of `morphTile`, when there is one
};

/// Computes the per-draw record of a patch for a camera at `cameraEcef` (double precision):
/// placePatchDraw of its template, then the geomorph of `input`. `exaggeration`: the one its
/// vertices were decoded with (PatchVertexPlacement), which scales the reference heights'
/// ranges (precision only: any reference height gives the same positions up to rounding).
PatchDrawRecord makePatchDrawRecord(const DatasetView& dataset, const PatchDrawInput& input,
                                    const glm::dvec3& cameraEcef,
                                    double exaggeration = 1.0) noexcept;

/// What a patch's record needs that does not depend on the camera: the record's fixed fields
/// and the doubles placePatchDraw starts from. The host makes one per draw; a draw list made on
/// the device (gpu/shaders/draw_list.comp) keeps one per resident patch and repeats
/// placePatchDraw's operations, so both give the same record bit for bit.
struct PatchDrawTemplate final {
  /// Edge k, its corners a, b in canonical key order.
  struct Edge final {
    glm::dvec3 start{0.0};        ///< P_a
    glm::dvec3 direction{0.0};    ///< E = P_b − P_a
    double lengthSquared = 0.0;   ///< E·E
    glm::dvec3 normal{0.0};       ///< N_a
    glm::dvec3 normalDelta{0.0};  ///< float(N_b − N_a)
    double sag = 0.0;             ///< E·E / (8 · equatorial radius): the edge's bow
  };
  PatchDrawRecord record;  ///< every field but the camera's: corners, origins, reference weights
  std::array<glm::dvec3, 3> corner{};  ///< P_k
  std::array<Edge, 3> edges{};         ///< its three edges, k = 0, 1, 2
  /// E1 = P_1 − P_0, E2 = P_2 − P_0
  /// @{
  glm::dvec3 axis1{0.0}, axis2{0.0};
  /// @}
  /// E_i · E_j, and det = a11·a22 − a12²
  /// @{
  double a11 = 0.0, a12 = 0.0, a22 = 0.0, det = 0.0;
  /// @}
  glm::dvec3 normal0{0.0};  ///< N_0
  /// float(N_1 − N_0), float(N_2 − N_0)
  /// @{
  glm::dvec3 normalDelta1{0.0}, normalDelta2{0.0};
  /// @}
  /// The node's lowest and highest vertex heights, the interior's clamp
  /// @{
  double minHeightMeters = 0.0, maxHeightMeters = 0.0;
  /// @}
  glm::dvec3 texCenter{0.0};  ///< Q of the patch's tile
  /// The record's morphTexture and morph.w when the patch blends in `morphTile`.
  std::array<float, 4> blendTexture{0.0f, 0.0f, 1.0f, 0.0f};
  float blendLayer = 0.0f;  ///< the layer of `morphTile` when the patch blends it in
};

/// The template of `node` (record `record`) with its tile in `textureLayer`, and where it
/// would blend in `morphTile` (its parent's tile, in `morphTextureLayer`); its height range
/// times `exaggeration` (the one its vertices were decoded with).
PatchDrawTemplate makePatchDrawTemplate(const DatasetView& dataset, const NodeKey& node,
                                        const formats::NodeRecord& record,
                                        std::uint32_t textureLayer,
                                        const std::optional<TileKey>& morphTile,
                                        std::uint32_t morphTextureLayer,
                                        double exaggeration = 1.0) noexcept;

/// Dataset-wide numbers placePatchDraw uses.
struct PatchDrawConstants final {
  double heightStepMeters = 0.0;  ///< the manifest's height step
  double heightSpanMeters = 0.0;  ///< highest − lowest height of the dataset
};
/// The constants of `dataset`, its height span times `exaggeration` (the one the vertices were
/// decoded with).
PatchDrawConstants patchDrawConstants(const DatasetView& dataset,
                                      double exaggeration = 1.0) noexcept;

/// Sets the camera's fields of `draw` (a copy of `t.record`): corners, edge and interior
/// origins and reference weights, the tile centre — in double, seen from `cameraEcef`.
void placePatchDraw(const PatchDrawTemplate& t, const PatchDrawConstants& constants,
                    const glm::dvec3& cameraEcef, PatchDrawRecord& draw) noexcept;

/// A vertex's point on its flat corner triangle and its interpolated (not normalised) normal.
struct PatchVertexBase final {
  glm::dvec3 flat{0.0};    ///< Pflat(w)
  glm::dvec3 normal{0.0};  ///< N(w), from the float corner normals
};

/// Barycentrics (b1, b2) (units of 2^-15; b1 + b2 ≤ 2^15) on the corner triangle with corner
/// positions `corners` (apex, left, right), float normals `normals` and canonical lattice keys
/// `keys`: a corner's own P_k, N_k; on edge k (w_k = 0) Pa + t·(Pb − Pa) and Na + t·(Nb − Na)
/// with a, b the edge's other corners in key order and t the weight of b (exact), so both
/// triangles on the edge get identical doubles; else P0 + w1·(P1 − P0) + w2·(P2 − P0) and the
/// same for N. The case selection is the shader's.
PatchVertexBase patchVertexBase(const std::array<glm::dvec3, 3>& corners,
                                const std::array<glm::vec3, 3>& normals,
                                const std::array<PointKey, 3>& keys, std::uint16_t b1,
                                std::uint16_t b2) noexcept;

/// What the GPU vertex carries besides b: the displacement along N(w) and the sideways rest.
struct PatchVertexDisplacement final {
  float heightMeters = 0.0f;  ///< h: the normal component of T − Pflat on the height grid
  /// The same for the vertex's morph target (its coarser surface's height, dataset format 4):
  /// the shader draws h − g·(h − target), g the record's 1 − f for the vertex.
  /// patchVertexDisplacement sets it to h (no morph).
  float targetHeightMeters = 0.0f;
  glm::vec3 offsetMeters{0.0f};  ///< o = float(T − Pflat − h·N)
};

/// Splits `terrain` (T, planetocentric metres) over `base` (the header comment): exact for
/// identical inputs, so both patches on an edge get the same floats.
PatchVertexDisplacement patchVertexDisplacement(const PatchVertexBase& base,
                                                const glm::dvec3& terrain,
                                                double heightStepMeters) noexcept;

/// Where the vertices of one patch are drawn, in double (the header comment): built once per
/// decoded patch from its node and record.
class PatchVertexPlacement final {
 public:
  /// The placement of the vertices of `node`, whose record is `record`, with their heights
  /// times `exaggeration` (vertical exaggeration: each vertex drawn at T(q, F·height); 1 draws
  /// the true terrain, bit for bit).
  PatchVertexPlacement(const DatasetView& dataset, const NodeKey& node,
                       const formats::NodeRecord& record, double exaggeration = 1.0) noexcept;

  /// The lattice point of barycentrics (b1, b2) on the node's triangle, or false when they are
  /// not one (b1 + b2 > 2^15, or off the lattice: a blob that does not belong to the node).
  bool latticePoint(std::uint16_t b1, std::uint16_t b2, LatticeXY& q) const noexcept;
  /// The vertex's terrain point T(q, heightSteps · heightStep · exaggeration), planetocentric
  /// metres.
  glm::dvec3 terrainPoint(LatticeXY q, std::int32_t heightSteps) const noexcept;
  /// patchVertexBase of (b1, b2) on the node's corner triangle.
  PatchVertexBase base(std::uint16_t b1, std::uint16_t b2) const noexcept {
    return patchVertexBase(corners_, normals_, keys_, b1, b2);
  }
  /// The GPU vertex's h and o; false for barycentrics latticePoint rejects.
  bool displacement(const formats::PatchVertex& vertex,
                    PatchVertexDisplacement& out) const noexcept;

 private:
  const Planet* planet_;
  std::uint32_t latticeCells_;
  int face_;
  double heightStepMeters_;
  double exaggeration_;
  LatticeXY apex_{0}, leg1_{0}, leg2_{0};
  // Plane coordinates of the columns x0.. and rows y0.. of the triangle's bounding box (the
  // tangents of the cube map, once per column and row instead of twice per vertex); empty
  // where the box is too large to be worth it.
  LatticeXY planeOrigin_{0};
  std::vector<double> planeU_, planeV_;
  std::array<glm::dvec3, 3> corners_{};
  std::array<glm::vec3, 3> normals_{};
  std::array<PointKey, 3> keys_{};
};

/// The vertex shader's float computation of a vertex's camera-relative position, on the CPU.
glm::vec3 shaderVertexPosition(const PatchDrawRecord& draw, std::uint16_t b1, std::uint16_t b2,
                               const PatchVertexDisplacement& vertex) noexcept;

/// The same vertex in double: its terrain point T − camera (what the shader approximates).
glm::dvec3 exactVertexPosition(const PatchVertexPlacement& placement,
                               const formats::PatchVertex& vertex,
                               const glm::dvec3& cameraEcef) noexcept;

/// The technique camera-relative drawing replaces, for comparison: absolute float corners
/// interpolated in float, displaced, the offset added, then the camera subtracted in float.
glm::vec3 absoluteFloatVertexPosition(const formats::NodeRecord& record, std::uint16_t b1,
                                      std::uint16_t b2, const PatchVertexDisplacement& vertex,
                                      const glm::dvec3& cameraEcef) noexcept;

/// Fig. 5 as published: corners rounded camera-relative, interpolated in float (no reference
/// points), displaced, the offset added, for the precision comparison in tests and docs.
glm::vec3 cornerRelativeVertexPosition(const formats::NodeRecord& record, std::uint16_t b1,
                                       std::uint16_t b2, const PatchVertexDisplacement& vertex,
                                       const glm::dvec3& cameraEcef) noexcept;

}  // namespace pbdam::runtime
