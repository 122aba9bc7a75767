// Test-only: runs the patch vertex shader's position code (gpu/shaders/patch_position.glsl) and
// stores each vertex's camera-relative position, so tests can compare the GPU's floats with
// pbdam::shaderVertexPosition bit for bit. Drawn as points with rasterization discarded; the
// record is picked by a push constant, as in patch.vert.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "patch_position.glsl"

layout(push_constant) uniform CapturePush {
  uint recordIndex;
} pc;

layout(location = 0) in uvec2 inBarycentric;
layout(location = 1) in float inHeightMeters;

layout(std430, set = 0, binding = 1) writeonly buffer CapturedPositions {
  vec4 positions[];
} captured;

void main() {
  precise vec3 position =
      patchVertexPosition(pc.recordIndex, inBarycentric, inHeightMeters);
  captured.positions[gl_VertexIndex] = vec4(position, 1.0);
  gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
  gl_PointSize = 1.0;
}
