// The per-draw record of a patch (runtime::PatchDrawRecord, runtime/PatchDraw.h): included by
// patch_position.glsl, which reads it, and by draw_list.comp, which writes it on the device.
// Keep it, PatchDraw.h and PatchDraw.cpp in step.
#ifndef PBDAM_PATCH_RECORD_GLSL
#define PBDAM_PATCH_RECORD_GLSL

// std430: 27 vec4, 432 bytes (static_assert in PatchDraw.h). The texture fields are read by
// patch_texcoord.glsl; patch_position.glsl never reads them nor the w of corner[].
struct PatchDrawRecord {
  vec4 corner[3];           // xyz: float(P_k - camera), w: 0 layer, 1 equatorial, 2 polar radius
  vec4 normal[3];           // xyz: N_k; w of 0: the normal map's slope scale, of 1: its share
  vec4 edgeOrigin[3];       // xyz: Re, w: tr
  vec4 edgeVector[3];       // xyz: Ee = P_b - P_a, w: hre
  vec4 edgeNormal[3];       // xyz: Na, w: index of corner b (0..2)
  vec4 edgeNormalDelta[3];  // xyz: dNe = N_b - N_a
  vec4 origin;              // xyz: R, w: r1
  vec4 axis1;               // xyz: E1, w: r2
  vec4 axis2;               // xyz: E2, w: hr
  vec4 normalDelta1;        // xyz: dN1
  vec4 normalDelta2;        // xyz: dN2
  vec4 texCenter;           // xyz: float(Q - camera), w: k = d(tc)/d(face u)
  vec4 texPlane;            // x, y: Q's plane coordinates on the face, z: Q . n_face, w: face
  vec4 morph;               // x, y: 1 - f for interior/leg and hypotenuse vertices,
                            // z: weight of the coarser tile, w: its layer
  vec4 morphTexture;        // the coarser tile's tc = z * tc + xy
};

#endif
