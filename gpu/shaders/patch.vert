// P-BDAM patch vertices (docs/architecture.md "Refinement and drawing"): one indexed draw per patch, its PatchDrawRecord picked by
// the push constant recordIndex, set before each draw. (Not gl_InstanceIndex with firstInstance:
// lavapipe cannot prove an instance index uniform, so every record load became an 8-lane gather;
// a push constant is uniform and made the vertex stage about twice as fast — docs/decisions.md.)
// Vertex attributes: the barycentrics b1, b2 (R16G16_UINT), the displacement h in metres along
// the interpolated normal and that of the vertex's morph target (R32G32_SFLOAT) and the sideways
// offset o that takes the displaced point
// to the vertex's terrain point (R32G32B32_SFLOAT), both computed in double at decode
// (runtime/PatchDraw.h). Texture coordinates come from the vertex's position
// (patch_texcoord.glsl), not from w; the normal is still interpolated in w.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "patch_position.glsl"
#include "patch_texcoord.glsl"

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;  // projection * viewRotation (camera-relative world -> clip)
  vec4 sunAmbient;      // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;     // this draw's PatchDrawRecord
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

void main() {
  const uint r = pc.recordIndex;
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
