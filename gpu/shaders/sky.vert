// The sky behind the terrain (docs/architecture.md "Light"): one triangle covering the viewport at
// the far depth (0, reversed-Z); each fragment gets its view ray (camera-relative world axes) from
// the inverse of the frame's view-projection. Drawn after the terrain where the depth is still the
// far one, so that only the sky's own pixels are shaded.
#version 450

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;  // projection * viewRotation (camera-relative world -> clip)
  vec4 sunAmbient;      // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
  float sunDisc;
  vec4 camera;          // xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
} pc;

layout(location = 0) out vec3 outRay;

void main() {
  const vec2 corner = vec2(float((gl_VertexIndex << 1) & 2), float(gl_VertexIndex & 2));
  const vec2 ndc = corner * 2.0 - 1.0;
  const mat4 inverseViewProjection = inverse(pc.viewProjection);
  const vec4 nearPoint = inverseViewProjection * vec4(ndc, 1.0, 1.0);
  const vec4 farPoint = inverseViewProjection * vec4(ndc, 0.5, 1.0);
  outRay = farPoint.xyz / farPoint.w - nearPoint.xyz / nearPoint.w;
  gl_Position = vec4(ndc, 0.0, 1.0);
}
