// Camera-relative patch vertices (PatchDraw.h). Built with -ffp-contract=off: the float code
// below must match gpu/shaders/patch.vert operation for operation.
#include "pbdam/runtime/PatchDraw.h"

#include <algorithm>
#include <cmath>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <numbers>
#include <utility>

using namespace pbdam::formats;

namespace pbdam::runtime {
namespace {

constexpr double kBaryUnit = 1.0 / static_cast<double>(kPatchBarycentricOne);
constexpr float kTwoOverPi = static_cast<float>(2.0 / std::numbers::pi);

glm::dvec3 position(const NodeRecord& n, int k) {
  const std::size_t i = 3 * static_cast<std::size_t>(k);
  return {n.cornerPositions[i], n.cornerPositions[i + 1], n.cornerPositions[i + 2]};
}
glm::dvec3 normalOf(const NodeRecord& n, int k) {
  const std::size_t i = 3 * static_cast<std::size_t>(k);
  return {n.cornerNormals[i], n.cornerNormals[i + 1], n.cornerNormals[i + 2]};
}
glm::vec3 fnormalOf(const NodeRecord& n, int k) {
  const std::size_t i = 3 * static_cast<std::size_t>(k);
  return {n.cornerNormals[i], n.cornerNormals[i + 1], n.cornerNormals[i + 2]};
}

std::array<float, 4> vec4(const glm::vec3& v, float w) { return {v.x, v.y, v.z, w}; }
glm::vec3 xyz(const std::array<float, 4>& v) { return {v[0], v[1], v[2]}; }

// Rounds a weight in [0, 1] down to the barycentric grid (exactly representable in float, and so
// is its difference with any vertex weight).
double toBaryGrid(double w) { return std::floor(std::clamp(w, 0.0, 1.0) / kBaryUnit) * kBaryUnit; }

double toHeightGrid(double h, double step) { return std::round(h / step) * step; }

// How much of a simplified patch's terrain normal its tile's normal map gives (patch.frag): 1
// where the map's texels (half the colour tile's resolution: twice its texture error, the
// largest colour texel) are at most half the legs of the patch's triangles (the corner
// triangle's area shared among them, each a right isosceles triangle of leg √(2·area)), 0 where
// they are as large, linear between.
float normalMapWeight(const DatasetView& dataset, const NodeKey& node, const NodeRecord& n,
                      const std::array<glm::dvec3, 3>& corner) noexcept {
  if (n.triangleCount == 0) return 0.0f;
  const double area = 0.5 * glm::length(glm::cross(corner[1] - corner[0], corner[2] - corner[0]));
  const double leg = std::sqrt(2.0 * area / static_cast<double>(n.triangleCount));
  const double texel =
      2.0 * static_cast<double>(dataset.textureNode(dataset.tileOf(node)).errorMeters);
  if (!(texel > 0.0)) return 0.0f;
  return static_cast<float>(std::clamp(leg / texel - 1.0, 0.0, 1.0));
}

// The canonical keys of a node's lattice corners (apex, left, right).
std::array<PointKey, 3> cornerKeys(std::uint32_t latticeCells, const NodeKey& node,
                                   const BinTriangle& tri) noexcept {
  return {latticePointKey(latticeCells, node.face, tri.apex),
          latticePointKey(latticeCells, node.face, tri.left),
          latticePointKey(latticeCells, node.face, tri.right)};
}

// The corners a, b of edge k (opposite corner k) in canonical key order.
std::pair<std::size_t, std::size_t> edgeCorners(const std::array<PointKey, 3>& keys,
                                                std::size_t k) noexcept {
  std::size_t a = (k + 1) % 3, b = (k + 2) % 3;
  if (keys[b] < keys[a]) std::swap(a, b);
  return {a, b};
}

}  // namespace

PatchDrawTemplate makePatchDrawTemplate(const DatasetView& dataset, const NodeKey& node,
                                        const NodeRecord& n, std::uint32_t textureLayer,
                                        const std::optional<TileKey>& morphTile,
                                        std::uint32_t morphTextureLayer,
                                        double exaggeration) noexcept {
  const BinTriangle tri = dataset.triangle(node);
  const std::array<PointKey, 3> keys = cornerKeys(dataset.latticeCells(), node, tri);
  std::array<glm::dvec3, 3> p{}, nd{};
  std::array<glm::vec3, 3> nf{};
  for (int k = 0; k < 3; ++k) {
    p[static_cast<std::size_t>(k)] = position(n, k);
    nd[static_cast<std::size_t>(k)] = normalOf(n, k);
    nf[static_cast<std::size_t>(k)] = fnormalOf(n, k);
  }

  PatchDrawTemplate t{};
  PatchDrawRecord& d = t.record;
  t.corner = p;
  for (std::size_t k = 0; k < 3; ++k) d.normal[k] = vec4(nf[k], 0.0f);
  // Shading (patch.frag): the normal map's slopes scaled by the exaggeration, and how much of
  // the terrain normal the map gives rather than the drawn triangles' facets — all of it where
  // its texels are at most half the triangles' legs, none where they are as large, a linear
  // blend between. A leaf draws the lattice itself: its facets are the finest normals there are.
  d.normal[0][3] = static_cast<float>(exaggeration);
  d.normal[1][3] = n.leaf() ? 0.0f : normalMapWeight(dataset, node, n, p);

  // Edges: computed from the edge's data only, corners in canonical key order.
  const double radius = dataset.planet().equatorialRadiusMeters();
  for (std::size_t k = 0; k < 3; ++k) {
    const auto [a, b] = edgeCorners(keys, k);
    PatchDrawTemplate::Edge& edge = t.edges[k];
    edge.start = p[a];
    edge.direction = p[b] - p[a];
    edge.lengthSquared = glm::dot(edge.direction, edge.direction);
    edge.normal = nd[a];
    edge.normalDelta = glm::dvec3(nf[b] - nf[a]);
    edge.sag = edge.lengthSquared / (8.0 * radius);
    d.edgeVector[k] = vec4(glm::vec3(edge.direction), 0.0f);
    d.edgeNormal[k] = vec4(nf[a], static_cast<float>(b));
    d.edgeNormalDelta[k] = vec4(nf[b] - nf[a], 0.0f);
  }

  // Interior: the camera's projection on the corner plane solves a 2x2 system of these.
  t.axis1 = p[1] - p[0];
  t.axis2 = p[2] - p[0];
  t.a11 = glm::dot(t.axis1, t.axis1);
  t.a12 = glm::dot(t.axis1, t.axis2);
  t.a22 = glm::dot(t.axis2, t.axis2);
  t.det = t.a11 * t.a22 - t.a12 * t.a12;
  t.normal0 = nd[0];
  t.normalDelta1 = glm::dvec3(nf[1] - nf[0]);
  t.normalDelta2 = glm::dvec3(nf[2] - nf[0]);
  t.minHeightMeters = static_cast<double>(n.minHeightMeters) * exaggeration;
  t.maxHeightMeters = static_cast<double>(n.maxHeightMeters) * exaggeration;
  d.axis1 = vec4(glm::vec3(t.axis1), 0.0f);
  d.axis2 = vec4(glm::vec3(t.axis2), 0.0f);
  d.normalDelta1 = vec4(nf[1] - nf[0], 0.0f);
  d.normalDelta2 = vec4(nf[2] - nf[0], 0.0f);

  // The patch's texture tile, the one its draw binds (DatasetView::tileOf): the quadtree node at
  // its texture level that contains it, or in a sparse quadtree the nearest coarser one there
  // is. Placing the coordinates in the tile of its texture level instead drew a coarser tile's
  // texels as if they were that tile's, another region's texture on every patch outside an
  // inset's tiles.
  const TileKey tile = dataset.tileOf(node);
  const std::uint32_t tl = textureLevelOfHeap(tile.heap);
  const std::uint64_t tileInLevel = tile.heap - textureHeapIndex(tl, 0, 0);
  const std::int32_t sideCells = static_cast<std::int32_t>(dataset.latticeCells() >> tl);
  const auto qi = static_cast<std::int32_t>(tileInLevel & ((std::uint64_t{1} << tl) - 1));
  const auto qj = static_cast<std::int32_t>(tileInLevel >> tl);
  const Manifest& m = dataset.manifest();
  t.texCenter = setPatchTexture(
      d, dataset.planet(),
      patchTextureTile(cubeFaceFromIndex(node.face), dataset.latticeCells(), tl,
                       static_cast<std::uint32_t>(qi), static_cast<std::uint32_t>(qj),
                       m.textureTileTexels, m.textureBorderTexels, textureLayer));

  // Geomorph weights, and the coarser tile's texture coordinates as an affine map of the
  // tile's: a lattice point x has tc = (border + ((x − q·side)/side)·inner)/size on either tile,
  // so tc' = a·tc + b with a = side/side' and b = (border·(1 − a) + inner·(q·side −
  // q'·side')/side')/size per axis.
  d.morph = {0.0f, 0.0f, 0.0f, 0.0f};
  d.morphTexture = {0.0f, 0.0f, 1.0f, 0.0f};
  t.blendTexture = d.morphTexture;
  if (morphTile) {
    const std::uint64_t heap = morphTile->heap;
    const std::uint32_t pl = textureLevelOfHeap(heap);
    const std::uint64_t inLevel = heap - textureHeapIndex(pl, 0, 0);
    const double pqi = static_cast<double>(inLevel & ((std::uint64_t{1} << pl) - 1));
    const double pqj = static_cast<double>(inLevel >> pl);
    const double side = static_cast<double>(sideCells);
    const double parentSide = static_cast<double>(dataset.latticeCells() >> pl);
    const double size = static_cast<double>(m.textureTileTexels);
    const double border = static_cast<double>(m.textureBorderTexels);
    const double inner = size - 2.0 * border;
    const double a = side / parentSide;
    const auto offset = [&](double q, double pq) {
      return static_cast<float>(
          (border * (1.0 - a) + inner * (q * side - pq * parentSide) / parentSide) / size);
    };
    t.blendTexture = {offset(static_cast<double>(qi), pqi), offset(static_cast<double>(qj), pqj),
                      static_cast<float>(a), 0.0f};
    t.blendLayer = static_cast<float>(morphTextureLayer);
  }
  return t;
}

PatchDrawConstants patchDrawConstants(const DatasetView& dataset, double exaggeration) noexcept {
  const Manifest& m = dataset.manifest();
  return {m.heightStepMeters, (m.maxHeightMeters - m.minHeightMeters) * exaggeration};
}

void placePatchDraw(const PatchDrawTemplate& t, const PatchDrawConstants& constants,
                    const glm::dvec3& cam, PatchDrawRecord& d) noexcept {
  const double step = constants.heightStepMeters;
  const double span = constants.heightSpanMeters;
  for (std::size_t k = 0; k < 3; ++k) {
    d.corner[k] = vec4(glm::vec3(t.corner[k] - cam), d.corner[k][3]);
  }
  for (std::size_t k = 0; k < 3; ++k) {
    const PatchDrawTemplate::Edge& edge = t.edges[k];
    const glm::dvec3& e = edge.direction;
    const double tr = toBaryGrid(glm::dot(cam - edge.start, e) / edge.lengthSquared);
    const glm::dvec3 nr = edge.normal + tr * edge.normalDelta;
    const glm::dvec3 pr = edge.start + tr * e;
    const double hr = toHeightGrid(
        std::clamp(glm::dot(cam - pr, nr) / glm::dot(nr, nr), -span - 1.0, edge.sag + span + 1.0),
        step);
    d.edgeOrigin[k] = vec4(glm::vec3(pr + hr * nr - cam), static_cast<float>(tr));
    d.edgeVector[k][3] = static_cast<float>(hr);
  }

  // Interior: the camera's projection on the corner plane, clamped into the triangle.
  const glm::dvec3 rel = cam - t.corner[0];
  const double c1 = glm::dot(rel, t.axis1), c2 = glm::dot(rel, t.axis2);
  double r1 = t.det > 0.0 ? (c1 * t.a22 - c2 * t.a12) / t.det : 0.0;
  double r2 = t.det > 0.0 ? (c2 * t.a11 - c1 * t.a12) / t.det : 0.0;
  r1 = std::clamp(r1, 0.0, 1.0);
  r2 = std::clamp(r2, 0.0, 1.0);
  if (r1 + r2 > 1.0) {
    const double s = r1 + r2;
    r1 /= s;
    r2 /= s;
  }
  r1 = toBaryGrid(r1);
  r2 = toBaryGrid(r2);
  const glm::dvec3 nr = t.normal0 + r1 * t.normalDelta1 + r2 * t.normalDelta2;
  const glm::dvec3 pr = t.corner[0] + r1 * t.axis1 + r2 * t.axis2;
  const double hr = toHeightGrid(
      std::clamp(glm::dot(cam - pr, nr) / glm::dot(nr, nr), t.minHeightMeters, t.maxHeightMeters),
      step);
  d.origin = vec4(glm::vec3(pr + hr * nr - cam), static_cast<float>(r1));
  d.axis1[3] = static_cast<float>(r2);
  d.axis2[3] = static_cast<float>(hr);
  const glm::vec3 q(t.texCenter - cam);
  d.texCenter = {q.x, q.y, q.z, d.texCenter[3]};
}

PatchDrawRecord makePatchDrawRecord(const DatasetView& dataset, const PatchDrawInput& input,
                                    const glm::dvec3& cam, double exaggeration) noexcept {
  const PatchDrawTemplate t =
      makePatchDrawTemplate(dataset, input.node, input.record, input.textureLayer, input.morphTile,
                            input.morphTextureLayer, exaggeration);
  PatchDrawRecord d = t.record;
  placePatchDraw(t, patchDrawConstants(dataset, exaggeration), cam, d);
  d.morph = {input.morph[0], input.morph[1], 0.0f, 0.0f};
  if (input.morphTile) {
    d.morph[2] = input.morph[0];
    d.morph[3] = t.blendLayer;
    d.morphTexture = t.blendTexture;
  }
  return d;
}

PatchVertexBase patchVertexBase(const std::array<glm::dvec3, 3>& p,
                                const std::array<glm::vec3, 3>& n,
                                const std::array<PointKey, 3>& keys, std::uint16_t b1,
                                std::uint16_t b2) noexcept {
  // The same case selection as the shader: a corner, else the first edge, else the interior.
  const double w1 = b1 * kBaryUnit, w2 = b2 * kBaryUnit;
  const std::array<double, 3> w{(1.0 - w1) - w2, w1, w2};  // exact: 15-bit dyadics
  const std::array<glm::dvec3, 3> nd{glm::dvec3(n[0]), glm::dvec3(n[1]), glm::dvec3(n[2])};
  for (std::size_t k = 0; k < 3; ++k) {
    if (w[k] == 1.0) return {p[k], nd[k]};
  }
  for (std::size_t k = 0; k < 3; ++k) {
    if (w[k] == 0.0) {
      const auto [a, b] = edgeCorners(keys, k);
      return {p[a] + w[b] * (p[b] - p[a]), nd[a] + w[b] * (nd[b] - nd[a])};
    }
  }
  return {p[0] + w1 * (p[1] - p[0]) + w2 * (p[2] - p[0]),
          nd[0] + w1 * (nd[1] - nd[0]) + w2 * (nd[2] - nd[0])};
}

PatchVertexDisplacement patchVertexDisplacement(const PatchVertexBase& base,
                                                const glm::dvec3& terrain,
                                                double heightStepMeters) noexcept {
  const glm::dvec3 d = terrain - base.flat;
  const float h = static_cast<float>(toHeightGrid(
      glm::dot(d, base.normal) / glm::dot(base.normal, base.normal), heightStepMeters));
  return {h, h, glm::vec3(d - static_cast<double>(h) * base.normal)};
}

PatchVertexPlacement::PatchVertexPlacement(const DatasetView& dataset, const NodeKey& node,
                                           const NodeRecord& record, double exaggeration) noexcept
    : planet_(&dataset.planet()),
      latticeCells_(dataset.latticeCells()),
      face_(node.face),
      heightStepMeters_(dataset.manifest().heightStepMeters),
      exaggeration_(exaggeration) {
  const BinTriangle tri = dataset.triangle(node);
  apex_ = tri.apex;
  leg1_ = tri.left - tri.apex;
  leg2_ = tri.right - tri.apex;
  keys_ = cornerKeys(latticeCells_, node, tri);
  for (int k = 0; k < 3; ++k) {
    corners_[static_cast<std::size_t>(k)] = position(record, k);
    normals_[static_cast<std::size_t>(k)] = fnormalOf(record, k);
  }
  planeOrigin_ = glm::min(tri.apex, glm::min(tri.left, tri.right));
  const LatticeXY size = glm::max(tri.apex, glm::max(tri.left, tri.right)) - planeOrigin_ + 1;
  constexpr std::int32_t kMaxCachedSide = 4096;
  if (size.x <= kMaxCachedSide && size.y <= kMaxCachedSide) {
    // The same uv the lattice direction uses (latticeDirection), so the same bits.
    const double n = static_cast<double>(latticeCells_);
    planeU_.resize(static_cast<std::size_t>(size.x));
    planeV_.resize(static_cast<std::size_t>(size.y));
    for (std::size_t i = 0; i < planeU_.size(); ++i) {
      planeU_[i] = CubeMap::uvToPlaneCoordinate(
          static_cast<double>(planeOrigin_.x + static_cast<std::int32_t>(i)) / n);
    }
    for (std::size_t j = 0; j < planeV_.size(); ++j) {
      planeV_[j] = CubeMap::uvToPlaneCoordinate(
          static_cast<double>(planeOrigin_.y + static_cast<std::int32_t>(j)) / n);
    }
  }
}

bool PatchVertexPlacement::latticePoint(std::uint16_t b1, std::uint16_t b2,
                                        LatticeXY& q) const noexcept {
  constexpr std::int64_t one = kPatchBarycentricOne;
  if (std::int64_t{b1} + b2 > one) return false;
  // q = apex + (b1·leg1 + b2·leg2) / 2^15, which must be a lattice point.
  const std::int64_t x = std::int64_t{b1} * leg1_.x + std::int64_t{b2} * leg2_.x;
  const std::int64_t y = std::int64_t{b1} * leg1_.y + std::int64_t{b2} * leg2_.y;
  if (x % one != 0 || y % one != 0) return false;
  q = apex_ + LatticeXY(static_cast<std::int32_t>(x / one), static_cast<std::int32_t>(y / one));
  return true;
}

glm::dvec3 PatchVertexPlacement::terrainPoint(LatticeXY q,
                                              std::int32_t heightSteps) const noexcept {
  // Times exaggeration_ last, so that F = 1 gives the true height's bits.
  const double h = static_cast<double>(heightSteps) * heightStepMeters_ * exaggeration_;
  // A point inside the face is its own canonical alias (latticeDirection): its direction from
  // the cached plane coordinates is the same bits. Points on face edges take the full path.
  const auto n = static_cast<std::int32_t>(latticeCells_);
  const LatticeXY local = q - planeOrigin_;
  if (q.x > 0 && q.y > 0 && q.x < n && q.y < n && !planeU_.empty() && local.x >= 0 &&
      local.y >= 0 && std::cmp_less(local.x, planeU_.size()) &&
      std::cmp_less(local.y, planeV_.size())) {
    const glm::dvec3 d = CubeMap::planeToDirection(cubeFaceFromIndex(face_),
                                                   planeU_[static_cast<std::size_t>(local.x)],
                                                   planeV_[static_cast<std::size_t>(local.y)]);
    return terrainPointOfDirection(*planet_, d, h);
  }
  return latticeTerrainPoint(*planet_, latticeCells_, face_, q, h);
}

bool PatchVertexPlacement::displacement(const PatchVertex& v,
                                        PatchVertexDisplacement& out) const noexcept {
  LatticeXY q{0};
  if (!latticePoint(v.b1, v.b2, q)) return false;
  out =
      patchVertexDisplacement(base(v.b1, v.b2), terrainPoint(q, v.heightSteps), heightStepMeters_);
  return true;
}

PatchTextureTile patchTextureTile(CubeFace face, std::uint32_t latticeCells,
                                  std::uint32_t textureLevel, std::uint32_t qi, std::uint32_t qj,
                                  std::uint32_t tileTexels, std::uint32_t borderTexels,
                                  std::uint32_t textureLayer) noexcept {
  const double cells = static_cast<double>(latticeCells);
  const double side = static_cast<double>(latticeCells >> textureLevel);
  const double size = static_cast<double>(tileTexels);
  const double inner = size - 2.0 * static_cast<double>(borderTexels);
  PatchTextureTile tile;
  tile.face = face;
  tile.centerFaceUv = {(static_cast<double>(qi) + 0.5) * side / cells,
                       (static_cast<double>(qj) + 0.5) * side / cells};
  tile.texCoordPerFaceUv = (cells / side) * (inner / size);
  tile.textureLayer = textureLayer;
  return tile;
}

glm::dvec3 setPatchTexture(PatchDrawRecord& d, const Planet& planet,
                           const PatchTextureTile& tile) noexcept {
  // Q: the surface point (height 0) in the direction of the tile's centre.
  const double a = planet.equatorialRadiusMeters(), b = planet.polarRadiusMeters();
  const glm::dvec3 dir = CubeMap::faceUvToDirection(tile.face, tile.centerFaceUv);
  const glm::dvec3 q = dir / glm::length(glm::dvec3(dir.x / a, dir.y / a, dir.z / b));
  const CubeFaceFrame frame = CubeMap::faceFrame(tile.face);
  const double qn = glm::dot(q, frame.normal);
  d.texCenter = {0.0f, 0.0f, 0.0f, static_cast<float>(tile.texCoordPerFaceUv)};
  d.texPlane = {static_cast<float>(glm::dot(q, frame.uAxis) / qn),
                static_cast<float>(glm::dot(q, frame.vAxis) / qn), static_cast<float>(qn),
                static_cast<float>(cubeFaceIndex(tile.face))};
  d.corner[0][3] = static_cast<float>(tile.textureLayer);
  d.corner[1][3] = static_cast<float>(a);
  d.corner[2][3] = static_cast<float>(b);
  return q;
}

void setPatchTexture(PatchDrawRecord& d, const Planet& planet, const PatchTextureTile& tile,
                     const glm::dvec3& cam) noexcept {
  const glm::vec3 q(setPatchTexture(d, planet, tile) - cam);
  d.texCenter = {q.x, q.y, q.z, d.texCenter[3]};
}

glm::vec2 shaderTexCoord(const PatchDrawRecord& d, const glm::vec3& cameraRelative) noexcept {
  // Mirrors patch_texcoord.glsl (not bit for bit: atan and inversesqrt differ between devices).
  const CubeFaceFrame frame =
      CubeMap::faceFrame(cubeFaceFromIndex(static_cast<int>(d.texPlane[3])));
  const glm::vec3 en(frame.normal), eu(frame.uAxis), ev(frame.vAxis);
  const glm::vec2 plane0(d.texPlane[0], d.texPlane[1]);
  const float qn = d.texPlane[2];
  // T − Q, and T itself (absolute, only to find the ellipsoid normal and the height).
  const glm::vec3 delta = cameraRelative - xyz(d.texCenter);
  const glm::vec3 t = qn * ((en + plane0.x * eu) + plane0.y * ev) + delta;
  // One fixed-point step: S0 = k·T on the ellipsoid, n0 its normal, H ≈ (T − S0)·n0; D = T − H·n0.
  const float a = d.corner[1][3], b = d.corner[2][3];
  const glm::vec3 e(t.x / a, t.y / a, t.z / b);
  const float k = 1.0f / std::sqrt(glm::dot(e, e));
  const glm::vec3 n0 = glm::normalize(glm::vec3(e.x / a, e.y / a, e.z / b));
  const float h0 = (1.0f - k) * glm::dot(t, n0);
  // Second step from D0 = T − h0·n0: H = (1 − k1)·T·n1 + k1·h0·n0·n1.
  const glm::vec3 d0 = t - h0 * n0;
  const glm::vec3 e1(d0.x / a, d0.y / a, d0.z / b);
  const float k1 = 1.0f / std::sqrt(glm::dot(e1, e1));
  const glm::vec3 n1 = glm::normalize(glm::vec3(e1.x / a, e1.y / a, e1.z / b));
  const float h = (1.0f - k1) * glm::dot(t, n1) + k1 * h0 * glm::dot(n0, n1);
  const glm::vec3 dq = delta - h * n1;  // D − Q
  // Plane coordinates of D relative to Q's, then atan(p) − atan(p0) = atan((p − p0)/(1 + p·p0)).
  const float dn = glm::dot(dq, en);
  const glm::vec2 dPlane =
      (glm::vec2(glm::dot(dq, eu), glm::dot(dq, ev)) - plane0 * dn) / (qn + dn);
  const glm::vec2 plane = plane0 + dPlane;
  const glm::vec2 dUv = kTwoOverPi * glm::atan(dPlane / (1.0f + plane0 * plane));
  return 0.5f + d.texCenter[3] * dUv;
}

glm::vec3 shaderVertexPosition(const PatchDrawRecord& d, std::uint16_t b1, std::uint16_t b2,
                               const PatchVertexDisplacement& v) noexcept {
  // Mirrors patch_position.glsl: every line is one float operation in the same order.
  const glm::vec3 o = v.offsetMeters;
  const float unit = 1.0f / 32768.0f;
  const float w1 = static_cast<float>(b1) * unit;
  const float w2 = static_cast<float>(b2) * unit;
  const float w0 = (1.0f - w1) - w2;
  // The geomorph: the hypotenuse's vertices (w0 = 0) by the grandparent's diamond, the others
  // by the parent's.
  const float g = w0 == 0.0f ? d.morph[1] : d.morph[0];
  const float h = v.heightMeters - g * (v.heightMeters - v.targetHeightMeters);
  const float w[3] = {w0, w1, w2};
  for (std::size_t k = 0; k < 3; ++k) {
    if (w[k] == 1.0f) return (xyz(d.corner[k]) + h * xyz(d.normal[k])) + o;
  }
  for (std::size_t k = 0; k < 3; ++k) {
    if (w[k] == 0.0f) {
      const auto b = static_cast<std::size_t>(d.edgeNormal[k][3]);
      const float t = w[b];
      const float s = t - d.edgeOrigin[k][3];
      const float hr = d.edgeVector[k][3];
      const glm::vec3 dn = xyz(d.edgeNormalDelta[k]);
      const glm::vec3 nrm = xyz(d.edgeNormal[k]) + t * dn;
      const glm::vec3 flat = xyz(d.edgeOrigin[k]) + s * xyz(d.edgeVector[k]);
      return ((flat + (h - hr) * nrm) + hr * (s * dn)) + o;
    }
  }
  const float d1 = w1 - d.origin[3];
  const float d2 = w2 - d.axis1[3];
  const float hr = d.axis2[3];
  const glm::vec3 dn1 = xyz(d.normalDelta1), dn2 = xyz(d.normalDelta2);
  const glm::vec3 nrm = (xyz(d.normal[0]) + w1 * dn1) + w2 * dn2;
  const glm::vec3 flat = (xyz(d.origin) + d1 * xyz(d.axis1)) + d2 * xyz(d.axis2);
  return ((flat + (h - hr) * nrm) + hr * ((d1 * dn1) + (d2 * dn2))) + o;
}

glm::dvec3 exactVertexPosition(const PatchVertexPlacement& placement, const PatchVertex& v,
                               const glm::dvec3& cam) noexcept {
  LatticeXY q{0};
  if (!placement.latticePoint(v.b1, v.b2, q)) return glm::dvec3(0.0);
  return placement.terrainPoint(q, v.heightSteps) - cam;
}

glm::vec3 absoluteFloatVertexPosition(const NodeRecord& n, std::uint16_t b1, std::uint16_t b2,
                                      const PatchVertexDisplacement& v,
                                      const glm::dvec3& cam) noexcept {
  const float w1 = static_cast<float>(b1) / 32768.0f, w2 = static_cast<float>(b2) / 32768.0f;
  const float h = v.heightMeters;
  const glm::vec3 p0(position(n, 0)), p1(position(n, 1)), p2(position(n, 2));
  const glm::vec3 n0 = fnormalOf(n, 0), n1 = fnormalOf(n, 1), n2 = fnormalOf(n, 2);
  const glm::vec3 world = p0 + w1 * (p1 - p0) + w2 * (p2 - p0) +
                          h * (n0 + w1 * (n1 - n0) + w2 * (n2 - n0)) + v.offsetMeters;
  return world - glm::vec3(cam);
}

glm::vec3 cornerRelativeVertexPosition(const NodeRecord& n, std::uint16_t b1, std::uint16_t b2,
                                       const PatchVertexDisplacement& v,
                                       const glm::dvec3& cam) noexcept {
  const float w1 = static_cast<float>(b1) / 32768.0f, w2 = static_cast<float>(b2) / 32768.0f;
  const float h = v.heightMeters;
  const glm::vec3 p0(position(n, 0) - cam), p1(position(n, 1) - cam), p2(position(n, 2) - cam);
  const glm::vec3 n0 = fnormalOf(n, 0), n1 = fnormalOf(n, 1), n2 = fnormalOf(n, 2);
  return p0 + w1 * (p1 - p0) + w2 * (p2 - p0) + h * (n0 + w1 * (n1 - n0) + w2 * (n2 - n0)) +
         v.offsetMeters;
}

}  // namespace pbdam::runtime
