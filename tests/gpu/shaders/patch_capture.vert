// Test-only: runs the patch vertex shader's position and texture-coordinate code
// (gpu/shaders/patch_position.glsl, patch_texcoord.glsl) and stores, per vertex, its
// camera-relative position and its tile texture coordinates, so tests can compare the GPU's
// floats with pbdam::shaderVertexPosition (bit for bit) and pbdam::shaderTexCoord. Drawn as
// points with rasterization discarded; the record is picked by a push constant, as in patch.vert.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "patch_position.glsl"
#include "patch_texcoord.glsl"

layout(push_constant) uniform CapturePush {
  uint recordIndex;
} pc;

layout(location = 0) in uvec2 inBarycentric;
layout(location = 1) in vec2 inHeightMeters;  // x: own, y: morph target
layout(location = 2) in vec3 inOffsetMeters;

struct CapturedVertex {
  vec4 position;  // xyz: camera-relative position
  vec4 texCoord;  // xy: tile texture coordinates
};

layout(std430, set = 0, binding = 1) writeonly buffer CapturedVertices {
  CapturedVertex vertices[];
} captured;

void main() {
  precise vec3 position =
      patchVertexPosition(pc.recordIndex, inBarycentric, inHeightMeters, inOffsetMeters);
  captured.vertices[gl_VertexIndex].position = vec4(position, 1.0);
  captured.vertices[gl_VertexIndex].texCoord =
      vec4(patchVertexTexCoord(pc.recordIndex, position), 0.0, 0.0);
  gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
  gl_PointSize = 1.0;
}
