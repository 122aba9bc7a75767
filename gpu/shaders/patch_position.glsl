// The per-draw record of a patch and the camera-relative vertex position computed from it
// (runtime/PatchDraw.h; docs/architecture.md "Precision", [P-BDAM 2003] §4.2). Included by
// patch.vert and by the GPU tests' position-capture shader, so both run exactly this code.
//
// patchVertexPosition computes exactly the floats of pbdam::shaderVertexPosition
// (runtime/src/PatchDraw.cpp): each case's operations in the same order and grouping, plus terms
// that are exact no-ops (see below). Everything it computes is `precise` (SPIR-V NoContraction):
// no multiply-add is fused, so the two patches that share an edge or a corner compute
// bit-identical positions there, and the CPU mirror reproduces them (tests/gpu/
// TestPatchShader.cpp). Keep this file, PatchDraw.cpp and PatchDrawRecord (PatchDraw.h) in step.

#include "patch_record.glsl"

layout(std430, set = 0, binding = 0) readonly buffer PatchDrawRecords {
  PatchDrawRecord records[];
} draws;

// The vertex's barycentric weights (w0, w1, w2) from its stored b1, b2 (units of 2^-15): exact.
vec3 patchVertexWeights(uvec2 bary) {
  precise float w1 = float(bary.x) * (1.0 / 32768.0);
  precise float w2 = float(bary.y) * (1.0 / 32768.0);
  precise float w0 = (1.0 - w1) - w2;
  return vec3(w0, w1, w2);
}

// Selects a, b or c by k (0, 1, 2) per vertex, without branching or indexing memory.
vec4 pick(vec4 a, vec4 b, vec4 c, int k) {
  return mix(mix(a, b, bvec4(k == 1)), c, bvec4(k == 2));
}

// T - camera for a vertex of the patch drawn with record `r`, its displacement h along the
// interpolated normal (heights.x; heights.y: its morph target's) and its decoded sideways offset
// o (see PatchDraw.h for the corner, edge and interior cases): the displaced point P(w, h) -
// camera, then + o. The geomorph first moves h towards the target by the record's 1 - f of the
// diamond that governs the vertex: the grandparent's on the hypotenuse (w0 = 0), else the
// parent's (docs/architecture.md "Geomorphing").
//
// shaderVertexPosition evaluates one of three formulas:
//   corner k:  (C_k + h N_k) + o
//   edge k:    ((Re + s Ee + (h - hr)(Na + t dNe)) + hr (s dNe)) + o
//   interior:  (((R + d1 E1) + d2 E2 + (h - hr)((N0 + w1 dN1) + w2 dN2))
//               + hr ((d1 dN1) + (d2 dN2))) + o
// Here all three are the interior formula, with the inputs of the vertex's case selected per
// vertex and zeros for the terms a case does not have: +0 scalars and -0 vectors, so that every
// absent term is a product (+0)(-0) = -0 or a sum of such, and x + (-0) = x and x - (+0) = x hold
// for every float x, signed zeros included. The result is the same bits as the case's own
// formula (TestPatchShader checks it against the CPU mirror), from one straight-line evaluation
// instead of three divergent branches with dynamically indexed loads: with the record index
// uniform (a push constant), lavapipe's SIMD vertex stage runs about twice as fast
// (docs/decisions.md).
precise vec3 patchVertexPosition(uint r, uvec2 bary, vec2 heights, vec3 offset) {
  precise vec3 w = patchVertexWeights(bary);
  const PatchDrawRecord d = draws.records[r];
  const float g = w.x == 0.0 ? d.morph.y : d.morph.x;
  precise float h = heights.x - g * (heights.x - heights.y);

  // The case: corner k (w_k == 1), else the first edge k with w_k == 0, else interior.
  const int corner = w.x == 1.0 ? 0 : (w.y == 1.0 ? 1 : (w.z == 1.0 ? 2 : -1));
  const int edge = w.x == 0.0 ? 0 : (w.y == 0.0 ? 1 : (w.z == 0.0 ? 2 : -1));
  const bool isCorner = corner >= 0;
  const bool isEdge = !isCorner && edge >= 0;
  const bool isInterior = !isCorner && !isEdge;

  const int e = max(edge, 0);
  const vec4 edgeOrigin = pick(d.edgeOrigin[0], d.edgeOrigin[1], d.edgeOrigin[2], e);
  const vec4 edgeVector = pick(d.edgeVector[0], d.edgeVector[1], d.edgeVector[2], e);
  const vec4 edgeNormal = pick(d.edgeNormal[0], d.edgeNormal[1], d.edgeNormal[2], e);
  const vec4 edgeDelta = pick(d.edgeNormalDelta[0], d.edgeNormalDelta[1], d.edgeNormalDelta[2], e);
  const int c = max(corner, 0);
  const vec4 cornerPosition = pick(d.corner[0], d.corner[1], d.corner[2], c);
  const vec4 cornerNormal = pick(d.normal[0], d.normal[1], d.normal[2], c);

  // Edge: t is the weight of the edge's corner b.
  const int b = int(edgeNormal.w);
  const float t = b == 0 ? w.x : (b == 1 ? w.y : w.z);
  precise float s = t - edgeOrigin.w;
  // Interior.
  precise float d1i = w.y - d.origin.w;
  precise float d2i = w.z - d.axis1.w;

  const vec3 zero = vec3(uintBitsToFloat(0x80000000u));  // -0.0: see above
  const vec3 A = isCorner ? cornerPosition.xyz : (isEdge ? edgeOrigin.xyz : d.origin.xyz);
  const vec3 B = isCorner ? zero : (isEdge ? edgeVector.xyz : d.axis1.xyz);
  const vec3 C = isInterior ? d.axis2.xyz : zero;
  const vec3 N = isCorner ? cornerNormal.xyz : (isEdge ? edgeNormal.xyz : d.normal[0].xyz);
  const vec3 D1 = isCorner ? zero : (isEdge ? edgeDelta.xyz : d.normalDelta1.xyz);
  const vec3 D2 = isInterior ? d.normalDelta2.xyz : zero;
  const float d1 = isCorner ? 0.0 : (isEdge ? s : d1i);
  const float d2 = isInterior ? d2i : 0.0;
  const float x1 = isCorner ? 0.0 : (isEdge ? t : w.y);
  const float x2 = isInterior ? w.z : 0.0;
  const float hr = isCorner ? 0.0 : (isEdge ? edgeVector.w : d.axis2.w);

  precise vec3 planar = (A + d1 * B) + d2 * C;
  precise vec3 nrm = (N + x1 * D1) + x2 * D2;
  precise vec3 displaced = (planar + (h - hr) * nrm) + hr * ((d1 * D1) + (d2 * D2));
  return displaced + offset;
}
