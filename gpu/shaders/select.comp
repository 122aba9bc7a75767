// The data-parallel selection of a cut (runtime/Selection.h, [Yalçın 2011] §6–7): one invocation
// per node of the dataset, in three modes picked by the push constant.
//   0 predicate: the node's screen error (the CPU's Camera::screenError, operation for operation
//     in double, never contracted) and whether it wants to be split (not a leaf, above the level
//     cap, and: its screen error above the tolerance; or its sphere within a focus region's
//     width of its centre line and its error above the region's (runtime/Selection.cpp's
//     arithmetic); or the caller's predicate, evaluated on the host, says so).
//   1 closure step: a split node marks its parent and its diamond partner split; recorded
//     2·(depth + 1) times with barriers in one command buffer, which reaches the fixed point
//     (each step lifts the closure one level or across one diagonal).
//   2 cut: a node is drawn when it is not split, its parent is (or it is a root) and its sphere
//     is inside the frustum (Camera::sphereInFrustum's planes).
#version 450
#extension GL_ARB_gpu_shader_fp64 : require

layout(local_size_x = 64) in;

struct SelectNode {
  dvec4 sphere;   // centre, radius (metres)
  double error;   // refinement error: max(geometry error, texture term of its level)
  double geometryError;  // the stored (saturated) geometry error
  uint parent;    // node index (a root: itself)
  uint partner;   // across the hypotenuse (itself when none)
  uint flags;     // bit 0: leaf; bits 8-15: level
  uint pad1;
};

layout(std430, set = 0, binding = 0) readonly buffer Nodes { SelectNode nodes[]; } tree;
layout(std430, set = 0, binding = 1) readonly buffer Frame {
  dvec4 position;   // xyz: the camera, w: pixels per radian
  dvec4 planes[5];  // inward frustum planes: n, d
  double tolerance;
  double radiusGrowth;  // vertical exaggeration: added to every sphere's radius (metres)
  uint maxLevel;
  uint culling;
  uint count;
  uint regionCount;
  double errorScale;    // vertical exaggeration: times every node's refinement error
  double pad;
} frame;
layout(std430, set = 0, binding = 2) buffer Screen { double screen[]; } errors;
// bit 0: split, bit 1: drawn, bit 2: split because of its screen error (a morph window)
layout(std430, set = 0, binding = 3) buffer State { uint state[]; } nodeState;
struct FocusRegion {
  double width;
  double error;  // the geometry error below which a node near it need not split
  uint firstPoint;
  uint pointCount;
};
layout(std430, set = 0, binding = 4) readonly buffer Regions { FocusRegion regions[]; } focus;
layout(std430, set = 0, binding = 5) readonly buffer Points { dvec4 points[]; } line;
layout(std430, set = 0, binding = 6) readonly buffer Wanted { uint wanted[]; } caller;

layout(push_constant) uniform Pass { uint mode; } pass;

bool leaf(uint i) { return (tree.nodes[i].flags & 1u) != 0u; }

double lengthOf(dvec3 v) {
  precise double squared = (v.x * v.x + v.y * v.y) + v.z * v.z;
  return sqrt(squared);
}

double dotOf(dvec3 a, dvec3 b) {
  precise double d = (a.x * b.x + a.y * b.y) + a.z * b.z;
  return d;
}

// Selection.cpp's near(): the distance from the sphere's centre to the region's centre line.
bool near(uint r, dvec4 sphere) {
  const FocusRegion region = focus.regions[r];
  const dvec3 c = sphere.xyz;
  double d = lengthOf(c - line.points[region.firstPoint].xyz);
  for (uint k = 1u; k < region.pointCount; ++k) {
    const dvec3 a = line.points[region.firstPoint + k - 1u].xyz;
    const dvec3 b = line.points[region.firstPoint + k].xyz;
    precise dvec3 e = b - a;
    const double ee = dotOf(e, e);
    precise double t = ee > 0.0 ? clamp(dotOf(c - a, e) / ee, 0.0LF, 1.0LF) : 0.0LF;
    precise dvec3 closest = a + t * e;
    d = min(d, lengthOf(c - closest));
  }
  precise double gap = d - sphere.w;
  return gap <= region.width;
}

void main() {
  // Rows of groups (ComputeProgram.h, dispatchLinear): more than 65,535 × 64 nodes.
  const uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
  if (i >= frame.count) return;
  SelectNode n = tree.nodes[i];
  // Runtime/Refinement.h's refinementBounds: the sphere and error widened for exaggeration.
  precise double radius = n.sphere.w + frame.radiusGrowth;
  precise double error = n.error * frame.errorScale;
  n.sphere.w = radius;
  if (pass.mode == 0u) {
    precise dvec3 d = n.sphere.xyz - frame.position.xyz;
    precise double squared = (d.x * d.x + d.y * d.y) + d.z * d.z;
    precise double distance = sqrt(squared) - n.sphere.w;
    precise double s = (error * frame.position.w) / distance;
    errors.screen[i] = distance <= 0.0 ? double(uintBitsToFloat(0x7F800000u)) : s;
    const uint level = (n.flags >> 8) & 0xFFu;
    const bool splittable = !leaf(i) && level < frame.maxLevel;
    const bool bySize = splittable && errors.screen[i] > frame.tolerance;
    bool wants = bySize || (splittable && caller.wanted[i] != 0u);
    for (uint r = 0u; r < frame.regionCount && splittable && !wants; ++r) {
      wants = n.geometryError > focus.regions[r].error && near(r, n.sphere);
    }
    nodeState.state[i] = (wants ? 1u : 0u) | (bySize ? 4u : 0u);
  } else if (pass.mode == 1u) {
    if ((nodeState.state[i] & 1u) == 0u) return;
    if (!leaf(n.parent)) atomicOr(nodeState.state[n.parent], 1u);
    if (!leaf(n.partner)) atomicOr(nodeState.state[n.partner], 1u);
  } else {
    if ((nodeState.state[i] & 1u) != 0u) return;
    bool drawn = n.parent == i || (nodeState.state[n.parent] & 1u) != 0u;
    if (drawn && frame.culling != 0u) {
      for (int k = 0; k < 5; ++k) {
        const dvec4 p = frame.planes[k];
        precise double side = ((p.x * n.sphere.x + p.y * n.sphere.y) + p.z * n.sphere.z) + p.w;
        if (side < -n.sphere.w) drawn = false;
      }
    }
    nodeState.state[i] = drawn ? 2u : 0u;  // an unsplit node has no size bit
  }
}
