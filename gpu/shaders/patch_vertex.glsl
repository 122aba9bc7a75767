// The patch vertex stage's body (patch.vert, patch_indirect.vert): its inputs, outputs and push
// constants, and the vertex of the draw whose PatchDrawRecord is `r`. The two shaders differ only
// in where r comes from.
#include "patch_position.glsl"
#include "patch_texcoord.glsl"

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;  // projection * viewRotation (camera-relative world -> clip)
  vec4 sunAmbient;      // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;     // this draw's PatchDrawRecord
  float sunDisc;        // sine of the sun's angular radius; 0: a light with no horizon
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

// The vertex of the draw whose record is `r`.
void emitPatchVertex(uint r) {
  precise vec3 position = patchVertexPosition(r, inBarycentric, inHeightMeters, inOffsetMeters);
  gl_Position = pc.viewProjection * vec4(position, 1.0);

  const vec3 w = patchVertexWeights(inBarycentric);
  outTexCoord = patchVertexTexCoord(r, position);
  const vec4 morphTexture = draws.records[r].morphTexture;
  outMorphTexCoord = morphTexture.z * outTexCoord + morphTexture.xy;
  outMorphTexture = draws.records[r].morph.zw;
  outLayer = draws.records[r].corner[0].w;
  outNormal = w.x * draws.records[r].normal[0].xyz + w.y * draws.records[r].normal[1].xyz +
              w.z * draws.records[r].normal[2].xyz;
  outCameraRelative = position;
}
