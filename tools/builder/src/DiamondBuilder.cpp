// One diamond of a bintree level: patches, measurement, saturation and its part-file bytes
// (DiamondBuilder.h; [P-BDAM 2003] §5; docs/builder.md "Saturation").
#include "DiamondBuilder.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

struct Sphere {
  glm::dvec3 center{0.0};
  double radius = 0.0;
};

/// The smallest sphere enclosing two spheres.
Sphere merge(const Sphere& a, const Sphere& b) {
  const double d = glm::length(b.center - a.center);
  if (d + b.radius <= a.radius) return a;
  if (d + a.radius <= b.radius) return b;
  const double r = 0.5 * (d + a.radius + b.radius);
  return Sphere{a.center + (b.center - a.center) * ((r - a.radius) / d), r};
}

/// Rounds a radius up to a float that still encloses (with a millimetre-scale margin).
float storedRadius(double r) {
  const double padded = r * (1.0 + 1e-6) + 1e-3;
  float f = static_cast<float>(padded);
  if (static_cast<double>(f) < padded) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

/// A half is measured through its children when it has more lattice cells than this per child
/// triangle, else against its samples (docs/decisions.md "Builder": measured on MOLA and ETOPO5,
/// where one overlap test of the bound costs about as much as scanning a few lattice cells).
constexpr double kBoundCellsPerChildTriangle = 4.0;

}  // namespace

float roundUpToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

/// A node as its level produces it: the record (saturated), its blob, and what saturation
/// needs.
struct DiamondBuilder::Node {
  std::uint64_t id = 0;
  BinTriangle triangle;
  NodeRecord record;
  std::vector<std::byte> blob;
  double measuredError = 0.0;
  Sphere sphere;
};

/// The saturated error and sphere of a diamond (both its triangles store them).
struct DiamondBuilder::Saturated {
  double error = 0.0;  // the stored float, as double
  Sphere sphere;       // centre, stored radius
  double floor = 0.0;  // the largest leaf error under the diamond (stored float)
};

void DiamondBuilder::noteFailure(Error error) {
  std::lock_guard lock(failureMutex_);
  if (!failed_) failure_ = std::move(error);
  failed_ = true;
}

bool DiamondBuilder::makeNode(const BinTriangle& t, WorkPatch& patch, Node& n,
                              const std::array<const WorkPatch*, 2>* children,
                              double targetMeters) {
  const SampleGrid& grid = level_.grid;
  n.id = nodeId(t, level_.depth);
  n.triangle = t;
  MeasuredPatch m = children != nullptr
                        ? measurePatchFromChildren(grid, t, patch, *children,
                                                   level_.heightStepMeters, targetMeters)
                        : measurePatch(grid, t, patch, level_.heightStepMeters);
  patch.sampleErrorMeters = std::move(m.triangleSampleErrors);
  optimizePatchForRendering(m.mesh);
  auto blob = encodePatch(m.mesh);
  if (!blob) {
    noteFailure(makeError(ErrorCode::Internal,
                          "patch " + std::to_string(n.id) + ": " + blob.error().message));
    return false;
  }
  n.blob = std::move(blob).value();
  const NodeCorners corners = nodeCorners(grid, t);
  for (std::size_t c = 0; c < 3; ++c) {
    for (std::size_t a = 0; a < 3; ++a) {
      n.record.cornerPositions[c * 3 + a] = corners.positions[c][static_cast<int>(a)];
      n.record.cornerNormals[c * 3 + a] = corners.normals[c][static_cast<int>(a)];
    }
  }
  n.record.vertexCount = static_cast<std::uint32_t>(m.mesh.vertices.size());
  n.record.triangleCount = static_cast<std::uint32_t>(m.mesh.triangleCount());
  n.record.measuredErrorMeters = roundUpToFloat(m.errorMeters);
  n.record.minHeightMeters = static_cast<float>(m.minHeightMeters);
  n.record.maxHeightMeters = static_cast<float>(m.maxHeightMeters);
  n.measuredError = m.errorMeters;
  n.sphere = Sphere{m.sphereCenter, m.sphereRadiusMeters};
  return true;
}

bool DiamondBuilder::readChildren(const std::array<BinTriangle, 2>& tri,
                                  std::array<Saturated, 4>& saturated,
                                  std::array<std::array<WorkPatch, 2>, 2>& children) {
  // The four child diamonds are those whose spines are this diamond's legs: the diamonds of
  // the triangles' children (first child: leg apex–left, second: apex–right). Leaves are made
  // again rather than carried.
  for (std::size_t s = 0; s < 2; ++s) {
    const auto kids = Lattice::children(tri[s]);
    for (std::size_t c = 0; c < 2; ++c) {
      const std::uint64_t kid = nodeId(kids[c], level_.depth);
      const bool leaf = level_.plan.isLeaf(level_.level + 1, kid);
      CarrySaturation carried;
      if (!level_.below->find(kid, carried, leaf ? nullptr : &children[s][c])) {
        noteFailure(makeError(ErrorCode::Internal,
                              "node " + std::to_string(kid) + " is missing from the level " +
                                  std::to_string(level_.level + 1) + " carry"));
        return false;
      }
      saturated[2 * s + c] =
          Saturated{static_cast<double>(carried.errorMeters),
                    Sphere{carried.sphereCenter, static_cast<double>(carried.sphereRadiusMeters)},
                    static_cast<double>(carried.floorMeters)};
      if (leaf) children[s][c] = level_.plan.leafPatch(kids[c]);
    }
  }
  return true;
}

bool DiamondBuilder::makeNodes(const std::array<BinTriangle, 2>& tri, std::size_t count, bool leaf,
                               std::array<Node, 2>& nodes, std::array<WorkPatch, 2>& made,
                               std::array<Saturated, 4>& childSaturated) {
  if (leaf) {
    bool ok = true;
    for (std::size_t s = 0; s < count; ++s) {
      WorkPatch leafPatch = level_.plan.leafPatch(tri[s]);
      ok = makeNode(tri[s], leafPatch, nodes[s]) && ok;
    }
    return ok;
  }
  std::array<std::array<WorkPatch, 2>, 2> children;
  if (!readChildren(tri, childSaturated, children)) return false;
  const std::array<std::array<const WorkPatch*, 2>, 2> childPointers = {
      {{&children[0][0], &children[0][1]}, {&children[1][0], &children[1][1]}}};
  // The block's target (docs/builder.md "Patches"): its saturated error will be (1 + r) times
  // its children's largest; the heights get what the leaves' floor leaves of it.
  double childError = 0.0;
  double floor = 0.0;
  for (const Saturated& child : childSaturated) {
    childError = std::max(childError, child.error);
    floor = std::max(floor, child.floor);
  }
  const double target = (1.0 + level_.errorMargin) * childError;
  // Each level from the level below (docs/decisions.md "Builder"): where every child carries its
  // patch and per-triangle sample errors (all but the leaves' parents: leaves are made again,
  // not carried), the block inserts only the children's vertices, and its patches' errors are
  // bounded through the children where that is cheaper than reading the samples. Either way the
  // heights work to the target less the leaves' floor.
  bool fromChildren = true;
  for (const auto& pair : children) {
    for (const WorkPatch& child : pair) {
      fromChildren = fromChildren && !child.indices.empty() &&
                     child.sampleErrorMeters.size() == child.indices.size() / 3;
    }
  }
  const BlockTargets targets{std::max(0.0, target - floor), level_.minPatchTriangles,
                             kPatchMaxVertices};
  BlockResult block = simplifyBlock(level_.grid, tri, childPointers, targets);
  inserted_ += block.stats.insertedPoints;
  overTarget_ += block.stats.halvesOverTarget;
  // The bound costs a few overlap tests per child triangle, the samples one evaluation each:
  // where the half holds few lattice points per child triangle (the levels just above the
  // leaves' parents) reading the samples is the cheaper way to the errors.
  const std::array<std::array<const WorkPatch*, 2>, 2> pairs = {
      {{&children[0][0], &children[0][1]}, {&children[1][0], &children[1][1]}}};
  std::array<const std::array<const WorkPatch*, 2>*, 2> boundBy = {nullptr, nullptr};
  for (std::size_t s = 0; s < 2 && fromChildren; ++s) {
    const double cells =
        0.5 * static_cast<double>(std::abs(doubleArea(tri[s].apex, tri[s].left, tri[s].right)));
    const double childTriangles =
        static_cast<double>(children[s][0].indices.size() + children[s][1].indices.size()) / 3.0;
    if (cells > kBoundCellsPerChildTriangle * childTriangles) boundBy[s] = &pairs[s];
  }
  bool ok = makeNode(tri[0], block.first, nodes[0], boundBy[0], target);
  ok = makeNode(tri[1], block.second, nodes[1], boundBy[1], target) && ok;
  made = {std::move(block.first), std::move(block.second)};
  return ok;
}

DiamondBuilder::Saturated DiamondBuilder::saturate(
    const std::array<Node, 2>& nodes, std::size_t count, bool leaf,
    const std::array<Saturated, 4>& childSaturated) const {
  // Saturate over the diamond DAG, with the margin: at least (1 + r) times every child
  // diamond's error, so that the errors of consecutive levels never come closer than that.
  double e = nodes[0].measuredError;
  Sphere sphere = nodes[0].sphere;
  if (count == 2) {
    e = std::max(e, nodes[1].measuredError);
    sphere = merge(sphere, nodes[1].sphere);
  }
  double floor = e;  // a leaf diamond's floor is its error
  if (!leaf) {
    floor = 0.0;
    for (const Saturated& child : childSaturated) {
      e = std::max(e, (1.0 + level_.errorMargin) * child.error);
      floor = std::max(floor, child.floor);
      sphere = merge(sphere, child.sphere);
    }
  }
  const float storedError = roundUpToFloat(e);
  const float radius = storedRadius(sphere.radius);
  return Saturated{static_cast<double>(storedError),
                   Sphere{sphere.center, static_cast<double>(radius)},
                   static_cast<double>(roundUpToFloat(floor))};
}

void DiamondBuilder::serialise(std::array<Node, 2>& nodes, std::size_t count, bool leaf,
                               const Saturated& saturated, const std::array<WorkPatch, 2>& made,
                               DiamondBytes& out) const {
  ByteWriter w;
  std::array<std::byte, kNodeRecordBytes> record{};
  for (std::size_t s = 0; s < count; ++s) {
    Node& node = nodes[s];
    node.record.errorMeters = static_cast<float>(saturated.error);
    node.record.sphereRadiusMeters = static_cast<float>(saturated.sphere.radius);
    node.record.sphereCenter = {saturated.sphere.center.x, saturated.sphere.center.y,
                                saturated.sphere.center.z};
    out.rawBytes += 8ULL * node.record.vertexCount + 6ULL * node.record.triangleCount;
    encodeNodeRecord(node.record, record);
    putNodeEntry(w, node.id, record, node.blob);
  }
  out.nodes = w.take();
  if (!level_.writeCarry) return;
  const CarrySaturation carried{static_cast<float>(saturated.error), saturated.sphere.center,
                                static_cast<float>(saturated.sphere.radius),
                                static_cast<float>(saturated.floor)};
  // The parent's block is made from the whole patch (its vertices are the parent's candidates,
  // its triangles' sample errors what the parent's are bounded through); a leaf's is made again.
  ByteWriter c;
  putCarryRecord(c, carried, leaf ? nullptr : &made[0]);
  out.firstCarryBytes = c.bytes().size();
  if (count == 2) putCarryRecord(c, carried, leaf ? nullptr : &made[1]);
  out.carry = c.take();
}

bool DiamondBuilder::build(const Diamond& diamond, DiamondBytes& out) {
  const std::size_t count = diamond[1] == ForestPlan::kNoNode ? 1 : 2;
  std::array<BinTriangle, 2> tri{};
  for (std::size_t s = 0; s < count; ++s) {
    tri[s] = triangleOfNode(level_.lattice, diamond[s], level_.depth);
  }
  // Both triangles of a diamond are split alike (a closed forest); one alone is a leaf.
  const bool leaf = level_.plan.isLeaf(level_.level, diamond[0]);
  std::array<Node, 2> nodes;
  std::array<WorkPatch, 2> made;
  std::array<Saturated, 4> childSaturated;
  if (!makeNodes(tri, count, leaf, nodes, made, childSaturated) || failed_) return false;
  serialise(nodes, count, leaf, saturate(nodes, count, leaf, childSaturated), made, out);
  return true;
}

}  // namespace pbdam::builder
