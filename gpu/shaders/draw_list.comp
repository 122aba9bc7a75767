// The draw list made on the device (docs/architecture.md "Selection by predicate",
// [Yalçın 2011] §8): from the selection passes' node states (select.comp), the cut's indexed draws
// and their per-draw records, in refine()'s depth-first order, without the host. Three modes picked
// by the push constant, over the nodes in depth-first order (position j, node order[j]):
//   0 each workgroup's exclusive prefix sum of the drawn flags into slot[j], its total into
//     groupSums;
//   1 one invocation turns groupSums into exclusive prefixes and writes the draw count (and the
//     cut's triangles) for vkCmdDrawIndexedIndirectCount;
//   2 each drawn node writes its VkDrawIndexedIndirectCommand and its PatchDrawRecord at its
//     slot: the record's camera-independent fields copied from the node's template, the
//     camera-dependent ones computed here in double with runtime::makePatchDrawRecord's
//     operations in its order (never contracted), so on IEEE doubles the records are the host's
//     bit for bit.
// The node templates are made by the host once, from every patch resident in the GPU cache
// (gpu/src/DeviceDrawList.cpp).
#version 450
#extension GL_ARB_gpu_shader_fp64 : require
#extension GL_GOOGLE_include_directive : require

#include "patch_record.glsl"

layout(local_size_x = 256) in;

// One node's camera-independent inputs (DeviceDrawList.cpp's DrawNode, std430).
struct DrawNode {
  dvec4 corner[3];      // xyz: P_k; w: unused
  dvec4 edgeStart[3];   // xyz: P_a of edge k (its corners in canonical key order), w: its sag
  dvec4 edgeDir[3];     // xyz: E = P_b - P_a, w: E . E
  dvec4 edgeNormal[3];  // xyz: N_a (the float normal in double)
  dvec4 edgeDelta[3];   // xyz: double(float(N_b - N_a))
  dvec4 axis1;          // xyz: E1 = P_1 - P_0, w: E1 . E1
  dvec4 axis2;          // xyz: E2 = P_2 - P_0, w: E2 . E2
  dvec4 normal0;        // xyz: N_0, w: E1 . E2
  dvec4 delta1;         // xyz: double(float(N_1 - N_0)), w: the 2x2 determinant
  dvec4 delta2;         // xyz: double(float(N_2 - N_0)), w: the node's lowest height
  dvec4 texQ;           // xyz: Q, w: the node's highest height
  PatchDrawRecord record;  // the camera-independent fields, the others zero
  vec4 blendTexture;    // the record's morphTexture when the patch blends its parent's tile
  uvec4 draw;           // x: index count, y: first index, z: vertex offset, w: flags
  vec4 aux;             // x: the parent tile's texture layer
};
// DrawNode.draw.w: bit 0 the parent's tile is another tile than the node's; bits 8-15 level.

layout(std430, set = 0, binding = 1) readonly buffer Nodes { DrawNode nodes[]; } table;
layout(std430, set = 0, binding = 2) readonly buffer Frame {
  dvec4 camera;     // xyz: the camera (planetocentric metres)
  double tolerance;
  double morphRange;
  double heightStep;
  double span;      // the dataset's height range (metres)
  double pad0;
  double pad;
  uint count;       // nodes
  uint groups;      // workgroups of mode 0
  uint pad1;
  uint pad2;
} frame;
layout(std430, set = 0, binding = 3) readonly buffer Screen { double screen[]; } errors;
layout(std430, set = 0, binding = 4) readonly buffer State { uint state[]; } nodeState;
layout(std430, set = 0, binding = 5) readonly buffer Order { uint order[]; } dfs;
layout(std430, set = 0, binding = 6) buffer Slots { uint slot[]; } slots;
layout(std430, set = 0, binding = 7) buffer GroupSums { uint sums[]; } groupSums;
layout(std430, set = 0, binding = 0) writeonly buffer Records { PatchDrawRecord records[]; } out_;
struct DrawCommand {
  uint indexCount;
  uint instanceCount;
  uint firstIndex;
  int vertexOffset;
  uint firstInstance;
};
layout(std430, set = 0, binding = 8) writeonly buffer Commands { DrawCommand commands[]; } draws_;
layout(std430, set = 0, binding = 9) buffer Count { uint drawCount; uint triangles; } total;
layout(std430, set = 0, binding = 10) readonly buffer Parents { uint parent[]; } tree;

layout(push_constant) uniform Pass { uint mode; } pass;

shared uint partial[256];

bool drawn(uint node) {
  return (nodeState.state[node] & 2u) != 0u && table.nodes[node].draw.x > 0u;
}

double dotOf(dvec3 a, dvec3 b) {
  precise double d = (a.x * b.x + a.y * b.y) + a.z * b.z;
  return d;
}

// PatchDraw.cpp's toBaryGrid: down to the 2^-15 grid after clamping into [0, 1] (floor() is
// exact here: its argument is at most 2^15, see truncExact).
double toBaryGrid(double w) {
  precise double q = clamp(w, 0.0LF, 1.0LF) / (1.0LF / 32768.0LF);
  precise double r = floor(q) * (1.0LF / 32768.0LF);
  return r;
}

// trunc(q) from additions alone. lavapipe's trunc() and floor() of a double are not exact on
// every CPU: on x86-64 without AVX-512 (its generic rounding path) they return any |q| >= 2^24
// unchanged, as if a double's fraction ended where a float's does, which left heights 2^24
// height steps (262 km) and more above the planet off the height grid. Adding and taking away
// 2^52 rounds |q| to an integer exactly on every IEEE device.
double truncExact(double q) {
  const double big = 4503599627370496.0LF;  // 2^52: every double at or above it is an integer
  precise double a = abs(q);
  if (!(a < big)) return q;
  precise double n = (a + big) - big;
  precise double t = n > a ? n - 1.0LF : n;
  return q < 0.0LF ? -t : t;
}

// std::round (halves away from zero) of h / step, times step.
double toHeightGrid(double h, double step) {
  precise double q = h / step;
  precise double t = truncExact(q);
  precise double rest = abs(q - t);
  precise double rounded = rest >= 0.5LF ? t + sign(q) : t;
  precise double r = rounded * step;
  return r;
}

// Refinement.cpp's morphWeight: 1 - f of a diamond of screen error s.
float morphWeight(double s) {
  if (!(frame.morphRange > 0.0LF)) return 0.0;
  precise double f = clamp((s / frame.tolerance - 1.0LF) / frame.morphRange, 0.0LF, 1.0LF);
  return float(1.0LF - f);
}

// The screen error a child sees from node i (GpuSelector's depth-first walk): i's when i was
// split for its screen error (a morph window), else none.
double splitScreen(uint i) {
  const double none = double(uintBitsToFloat(0x7F800000u));
  return (nodeState.state[i] & 4u) != 0u ? errors.screen[i] : none;
}

void writeDraw(uint i, uint at) {
  const dvec3 cam = frame.camera.xyz;
  PatchDrawRecord d = table.nodes[i].record;
  for (int k = 0; k < 3; ++k) {
    precise dvec3 rel = table.nodes[i].corner[k].xyz - cam;
    d.corner[k].xyz = vec3(rel);
  }
  for (int k = 0; k < 3; ++k) {
    const dvec3 pa = table.nodes[i].edgeStart[k].xyz;
    const dvec3 e = table.nodes[i].edgeDir[k].xyz;
    const dvec3 dn = table.nodes[i].edgeDelta[k].xyz;
    const double sag = table.nodes[i].edgeStart[k].w;
    precise dvec3 toCam = cam - pa;
    precise double tr = toBaryGrid(dotOf(toCam, e) / table.nodes[i].edgeDir[k].w);
    precise dvec3 nr = table.nodes[i].edgeNormal[k].xyz + tr * dn;
    precise dvec3 pr = pa + tr * e;
    precise dvec3 up = cam - pr;
    precise double along = dotOf(up, nr) / dotOf(nr, nr);
    precise double lo = -frame.span - 1.0LF;
    precise double hi = (sag + frame.span) + 1.0LF;
    precise double hr = toHeightGrid(along < lo ? lo : (hi < along ? hi : along), frame.heightStep);
    precise dvec3 origin = (pr + hr * nr) - cam;
    d.edgeOrigin[k] = vec4(vec3(origin), float(tr));
    d.edgeVector[k].w = float(hr);
  }
  {
    const dvec3 p0 = table.nodes[i].corner[0].xyz;
    const dvec3 e1 = table.nodes[i].axis1.xyz, e2 = table.nodes[i].axis2.xyz;
    const double a11 = table.nodes[i].axis1.w, a22 = table.nodes[i].axis2.w;
    const double a12 = table.nodes[i].normal0.w, det = table.nodes[i].delta1.w;
    precise dvec3 rel = cam - p0;
    precise double c1 = dotOf(rel, e1);
    precise double c2 = dotOf(rel, e2);
    precise double r1 = det > 0.0LF ? (c1 * a22 - c2 * a12) / det : 0.0LF;
    precise double r2 = det > 0.0LF ? (c2 * a11 - c1 * a12) / det : 0.0LF;
    r1 = clamp(r1, 0.0LF, 1.0LF);
    r2 = clamp(r2, 0.0LF, 1.0LF);
    precise double s = r1 + r2;
    if (s > 1.0LF) {
      r1 = r1 / s;
      r2 = r2 / s;
    }
    r1 = toBaryGrid(r1);
    r2 = toBaryGrid(r2);
    const dvec3 dn1 = table.nodes[i].delta1.xyz, dn2 = table.nodes[i].delta2.xyz;
    precise dvec3 nr = (table.nodes[i].normal0.xyz + r1 * dn1) + r2 * dn2;
    precise dvec3 pr = (p0 + r1 * e1) + r2 * e2;
    precise dvec3 up = cam - pr;
    precise double along = dotOf(up, nr) / dotOf(nr, nr);
    const double lo = table.nodes[i].delta2.w, hi = table.nodes[i].texQ.w;
    precise double hr = toHeightGrid(along < lo ? lo : (hi < along ? hi : along), frame.heightStep);
    precise dvec3 origin = (pr + hr * nr) - cam;
    d.origin = vec4(vec3(origin), float(r1));
    d.axis1.w = float(r2);
    d.axis2.w = float(hr);
  }
  precise dvec3 q = table.nodes[i].texQ.xyz - cam;
  d.texCenter.xyz = vec3(q);

  // The geomorph of refine()'s walk: the parent's and grandparent's screen errors where they
  // were split for them (none for a root and its children's missing grandparent).
  const double none = double(uintBitsToFloat(0x7F800000u));
  const uint parent = tree.parent[i];
  const double up0 = parent == i ? none : splitScreen(parent);
  const uint grand = tree.parent[parent];
  const double up1 = (parent == i || grand == parent) ? none : splitScreen(grand);
  const float w0 = morphWeight(up0);
  d.morph = vec4(w0, morphWeight(up1), 0.0, 0.0);
  d.morphTexture = vec4(0.0, 0.0, 1.0, 0.0);
  const uint flags = table.nodes[i].draw.w;
  if (w0 > 0.0 && ((flags >> 8) & 0xFFu) > 0u && (flags & 1u) != 0u) {
    d.morph.z = w0;
    d.morph.w = table.nodes[i].aux.x;
    d.morphTexture = table.nodes[i].blendTexture;
  }
  out_.records[at] = d;

  DrawCommand c;
  c.indexCount = table.nodes[i].draw.x;
  c.instanceCount = 1u;
  c.firstIndex = table.nodes[i].draw.y;
  c.vertexOffset = int(table.nodes[i].draw.z);
  c.firstInstance = 0u;
  draws_.commands[at] = c;
}

void main() {
  // Rows of groups (ComputeProgram.h, dispatchLinear): more than 65,535 groups of 256 nodes.
  const uint group = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  const uint local = gl_LocalInvocationID.x;
  const uint j = group * 256u + local;
  if (pass.mode == 0u) {
    // Hillis-Steele inclusive scan in shared memory, then exclusive.
    const uint flag = j < frame.count && drawn(dfs.order[j]) ? 1u : 0u;
    partial[local] = flag;
    barrier();
    for (uint offset = 1u; offset < 256u; offset <<= 1u) {
      const uint add = local >= offset ? partial[local - offset] : 0u;
      barrier();
      partial[local] += add;
      barrier();
    }
    if (j < frame.count) slots.slot[j] = partial[local] - flag;
    if (local == 255u && group < frame.groups) groupSums.sums[group] = partial[255];
  } else if (pass.mode == 1u) {
    if (j != 0u) return;
    uint running = 0u;
    for (uint g = 0u; g < frame.groups; ++g) {
      const uint sum = groupSums.sums[g];
      groupSums.sums[g] = running;
      running += sum;
    }
    total.drawCount = running;
  } else {
    if (j >= frame.count) return;
    const uint i = dfs.order[j];
    if (!drawn(i)) return;
    const uint at = groupSums.sums[group] + slots.slot[j];
    writeDraw(i, at);
    atomicAdd(total.triangles, table.nodes[i].draw.x / 3u);
  }
}
