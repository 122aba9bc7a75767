// The patch vertex stage's body (patch.vert, patch_indirect.vert): its inputs, outputs and push
// constants, and the vertex of the draw whose PatchDrawRecord is `r`. The two shaders differ only
// in where r comes from.
#include "atmosphere.glsl"
#include "patch_position.glsl"
#include "patch_texcoord.glsl"

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;  // projection * viewRotation (camera-relative world -> clip)
  vec4 sunAmbient;      // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;     // this draw's PatchDrawRecord
  float sunDisc;        // sine of the sun's angular radius; 0: a light with no horizon
  float normalMaps;     // 1: simplified patches shaded by their normal maps (patch.frag)
  vec4 camera;          // xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
} pc;

layout(location = 0) in uvec2 inBarycentric;
layout(location = 1) in vec2 inHeightMeters;
layout(location = 2) in vec3 inOffsetMeters;

layout(location = 0) out vec2 outTexCoord;
layout(location = 1) flat out float outLayer;
layout(location = 2) out vec3 outNormal;
layout(location = 3) out vec3 outCameraRelative;
layout(location = 4) out vec2 outMorphTexCoord;
layout(location = 5) flat out vec2 outMorphTexture;  // x: the coarser tile's weight, y: its layer
// With the atmosphere (pc.camera.w > 0), what the air does at the vertex, interpolated over the
// triangle: the aerial perspective as an extinction per km and the in-scattered light it tends
// to (transmittance T = e^(−k·d), in-scattering S∞·(1 − T)), which vary slowly where T and S
// themselves do not (a large triangle near the camera: the fragment applies them at its own
// distance); the sun's irradiance through the air and the sky's irradiance of a horizontal
// surface there.
layout(location = 6) out vec3 outInScatterLimit;
layout(location = 7) out vec3 outExtinctionPerKm;
layout(location = 8) out vec3 outSunIrradiance;
layout(location = 9) out vec3 outSkyIrradiance;
// The normal map's frame: the reference surface's normal (interpolated), and flat: xyz the
// face's u axis, w the map's slope scale; and the map's share of the terrain normal (0: the
// patch is shaded by its triangles' facets alone; PatchDraw.cpp normalMapWeight).
layout(location = 10) out vec3 outUp;
layout(location = 11) flat out vec4 outNormalMap;
layout(location = 12) flat out float outNormalMapShare;

// The vertex of the draw whose record is `r`.
void emitPatchVertex(uint r) {
  precise vec3 position = patchVertexPosition(r, inBarycentric, inHeightMeters, inOffsetMeters);
  gl_Position = pc.viewProjection * vec4(position, 1.0);

  const vec3 w = patchVertexWeights(inBarycentric);
  outTexCoord = patchVertexTexCoordAndUp(r, position, outUp);
  outNormalMap = vec4(kFaceU[int(draws.records[r].texPlane.w)], draws.records[r].normal[0].w);
  outNormalMapShare = draws.records[r].normal[1].w;
  const vec4 morphTexture = draws.records[r].morphTexture;
  outMorphTexCoord = morphTexture.z * outTexCoord + morphTexture.xy;
  outMorphTexture = draws.records[r].morph.zw;
  outLayer = draws.records[r].corner[0].w;
  outNormal = w.x * draws.records[r].normal[0].xyz + w.y * draws.records[r].normal[1].xyz +
              w.z * draws.records[r].normal[2].xyz;
  outCameraRelative = position;
  outInScatterLimit = vec3(0.0);
  outExtinctionPerKm = vec3(0.0);
  outSunIrradiance = vec3(0.0);
  outSkyIrradiance = vec3(0.0);
  if (pc.camera.w > 0.0) {
    const vec3 point = pc.camera.xyz + toAtmosphereOffsetKm(position);
    const vec3 sun = toAtmosphereDirection(pc.sunAmbient.xyz);
    sunAndSkyIrradiance(point, sun, outSunIrradiance, outSkyIrradiance);
    vec3 transmittance;
    const vec3 inScatter = skyRadianceToPoint(pc.camera.xyz, point, sun, transmittance);
    const float km = max(length(position) * 0.001, 1e-3);
    const vec3 t = clamp(transmittance, vec3(1e-6), vec3(1.0));
    outExtinctionPerKm = -log(t) / km;
    outInScatterLimit = inScatter / max(vec3(1.0) - t, vec3(1e-4));
  }
}
